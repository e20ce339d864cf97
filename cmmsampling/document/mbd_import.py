"""FreeCAD's File > Open and File > Import hook for QIF 3.0 MBD models (registered in Init.py).

Opening ``part.qif`` reads it with :func:`cmmsampling.read_mbd` and adds, in one transaction, the
part (a Part::Feature named after the file, its shape the file's B-rep) and a *Characteristics*
spreadsheet: one row per characteristic (its QIF id, name, kind, tolerance in mm and as the
file writes it, datums, the part's faces, whether this tool judges it and why not), then the
datums and their faces. A file that is no QIF MBD model is refused in one line before anything
is added.
"""
import os

import FreeCAD

from .sheets import fit_columns, write_rows
from .transaction import recompute, transaction

HEADER = ("id", "characteristic", "kind", "tolerance mm", "as the file states it", "datums", "faces", "judged",
          "why not")


def add_mbd_to_document(model, doc, name):
    """Add an MbdModel's part (named ``name``) and its Characteristics sheet to ``doc`` in one
    transaction; returns (part, sheet)."""
    with transaction(doc, "Import QIF MBD model"):
        part = doc.addObject("Part::Feature", name)
        part.Shape = model.shape
        part.addProperty("App::PropertyFile", "MbdFile", "QIF MBD",
                         "The QIF MBD model the part was read from: Plan part plans its characteristics")
        part.MbdFile = model.path
        sheet = doc.addObject("Spreadsheet::Sheet", "Characteristics")
        sheet.Label = f"Characteristics {part.Label}"
        rows = characteristic_rows(model)
        write_rows(sheet, rows)
        fit_columns(sheet, rows)
        recompute(doc, [part, sheet])
    return part, sheet


def characteristic_rows(model):
    """The sheet's rows: a summary line, the header, one row per characteristic, then the datums."""
    rows = [(f"{os.path.basename(model.path)}: {model.summary()}",), HEADER]
    for c in model.characteristics:
        rows.append((c.id, c.name, c.kind, "" if c.tolerance is None else c.tolerance, c.tolerance_text,
                     " | ".join(c.datums), " ".join(c.faces), "yes" if c.judged else "no", c.why_not))
    rows += [(), ("datum", "faces")]
    rows += [(label, " ".join(datum.faces)) for label, datum in sorted(model.datums.items())]
    return rows


def insert(filename, docname):
    """FreeCAD's File > Import: add the model in ``filename`` to the document ``docname``."""
    from ..formats.qif.model import read_mbd

    model = read_mbd(filename)
    doc = FreeCAD.getDocument(docname)
    part, _ = add_mbd_to_document(model, doc, _part_name(filename))
    FreeCAD.Console.PrintMessage(f"cmmsampling: {filename}: {model.summary()}; the part is {part.Label}\n")
    return part


def open(filename):  # the name FreeCAD's File > Open calls (this module uses no built-in open)
    """FreeCAD's File > Open: a new document holding the model in ``filename``."""
    from ..formats.qif.model import read_mbd

    model = read_mbd(filename)   # refused before the document is made
    doc = FreeCAD.newDocument(_part_name(filename))
    part, _ = add_mbd_to_document(model, doc, _part_name(filename))
    FreeCAD.Console.PrintMessage(f"cmmsampling: {filename}: {model.summary()}; the part is {part.Label}\n")
    return doc


def _part_name(filename):
    """The part's name: the file's name without its extension, as a document object name."""
    stem = os.path.splitext(os.path.basename(filename))[0]
    return "".join(ch if ch.isalnum() else "_" for ch in stem) or "Model"

