"""Measured points from what CMM software writes: the project's point files (DMIS output with its
FA(label) actuals, in any UNITS; CSV with label,x,y,z,i,j,k; PC-DMIS XYZIJK; QIF 3.0 results,
cmmsampling.formats.qif.read) and tables of text:
a header naming the columns (cmmsampling.inspection.columns) or one point a line, ``label x y z``
(or ``x y z``, labels P1..PN by order), the fields separated by commas, semicolons or whitespace,
optionally followed by the vector i j k; and a CMM's text report of point locations
(cmmsampling.inspection.text_report). A DMIS program with nominal points only is refused (it
is the plan, not a measurement), as are a number with a decimal comma, a line of another length,
a label given twice or no point at all, each with its line.
"""
from __future__ import annotations

import os
import re
from typing import Any

import numpy as np

from ..formats.files import read_text
from ..formats.pointfiles import points_from_text, resolve_format
from ..formats.pointset import PointSet
from ..formats.registry import FORMATS
from ..formats.text import number
from ..geometry.validation import InputError
from ..runtime.packages import MissingPackage
from .columns import COORDINATES, header_columns
from .text_report import is_text_report, read_text_report

# Lines that say nothing about a point: comments of CSV, DMIS and C-like exports.
COMMENT = re.compile(r"\s*(#|//|\$\$|;)")
FIELD_COUNTS = {3: "x y z", 4: "label x y z", 6: "x y z i j k", 7: "label x y z i j k"}


def read_measured(path: str | os.PathLike) -> PointSet:
    """The measured points of a file: a PointSet of contact points or ball centres (normals NaN
    where the file gives no vectors). The file is read once, as every point file is
    (:func:`cmmsampling.formats.files.read_text`: a regular file of at most 100 MB); DMIS, XYZIJK
    and QIF files and CSV files with the project's header are read as
    :func:`cmmsampling.read_points` reads them (a DMIS program or a QIF plan without measured
    points is refused); any other text is read as labelled x, y, z lines
    (:func:`read_labelled_text`)."""
    text = read_text(path, "measured-points file")
    path = os.fspath(path)
    fmt = _project_format(path, text)
    if fmt is not None:
        point_set = points_from_text(text, path, fmt)
        unmeasured = FORMATS[fmt].unmeasured
        why = None if unmeasured is None else unmeasured(point_set)
        if why is not None:
            raise InputError(f"{path}: {why}")
        return point_set
    if is_text_report(text):
        point_set = read_text_report(text, path)
    else:
        point_set = read_labelled_text(text, path)
        point_set.metadata["format"] = "labelled text"
    point_set.metadata["path"] = os.path.abspath(path)
    return point_set


def _project_format(path: str, text: str) -> str | None:
    """The name of the registered format that reads the file as its own (None for none): by its
    extension, and where the format tells its files by their header (``FileFormat.recognises``:
    CSV's label,x,y,z,i,j,k, XYZIJK's), by the text's first line that is no comment.
    MissingPackage when the format of its extension needs a package this Python lacks (QIF:
    lxml), never a read as labelled text."""
    try:
        fmt = resolve_format(path, None)
    except MissingPackage:
        raise
    except InputError:
        return None
    recognises = FORMATS[fmt].recognises
    if recognises is None:
        return fmt
    head = [line for line in text[:4096].splitlines() if line.strip() and not line.startswith("#")][:1]
    return fmt if recognises(head[0].lower().replace(" ", "") if head else "") else None


def read_labelled_text(text: str, path: str = "<text>") -> PointSet:
    """PointSet from a table of measured points: a header naming the columns (label, x, y, z and
    optionally i, j, k in any order and case, see cmmsampling.inspection.columns), or none and
    lines of ``[label] x y z [i j k]``; comma, semicolon or whitespace between fields, comment
    lines skipped. Without a label column the points are labelled P1..PN by order, which the
    metadata says (``labels: by order``). InputError naming the line for a decimal comma, a line
    of another length, a label given twice, a header of nominal coordinates only, or no point."""
    rows: list[list[float]]
    layout: dict[str, Any] | None
    rows, labels, seen, layout = [], [], set(), None
    for line_number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or COMMENT.match(line):
            continue
        fields = _fields(line, path, line_number)
        if layout is None:
            layout = header_columns(fields, path, line_number)
            if layout is not None:
                layout.update(width=len(fields), what="header", names=", ".join(fields))
                continue
            layout = _plain_layout(fields, path, line_number)
        elif len(fields) != layout["width"]:
            raise InputError(f"{path}, line {line_number}: {len(fields)} fields where the {layout['what']} has "
                             f"{layout['width']} ({layout['names']})")
        label = fields[layout["label"]].strip() if layout["label"] is not None else f"P{len(rows) + 1}"
        if label in seen:
            raise InputError(f"{path}, line {line_number}: point {label} is given twice; keep one measurement per "
                             "point")
        seen.add(label)
        labels.append(label)
        rows.append([number(fields[layout[name]], path, line_number, name) if layout[name] is not None else np.nan
                     for name in COORDINATES])
    if not rows:
        raise InputError(f"{path}: no measured point found; write one point a line as label, x, y, z")
    data = np.array(rows)
    assert layout is not None   # set by the first point's line, and there is one
    metadata = {} if layout["label"] is not None else {"labels": "by order"}
    units = layout.get("units", {})
    if any(unit[0] != 1.0 for unit in units.values()):
        data[:, :3] *= [units[name][0] for name in "xyz"]
        metadata["units_read"] = ("coordinates read in " + ", ".join(f"{name} {units[name][1] or 'mm'}" for name in "xyz")
                                  + " (the header's units) and converted to mm")
    return PointSet(labels, data[:, :3], data[:, 3:], metadata=metadata)


def _plain_layout(fields: list[str], path: str, line_number: int) -> dict[str, Any]:
    """The columns of a table without a header, from its first point's fields: label (or None),
    x, y, z, i, j, k (or None) by position."""
    width = len(fields)
    if width not in FIELD_COUNTS:
        raise InputError(f"{path}, line {line_number}: {width} fields; a measured point is one of "
                         f"{'; '.join(FIELD_COUNTS.values())}, or name the columns in a header line "
                         "(label, x, y, z, i, j, k)")
    labelled = int(width in (4, 7))
    layout = {"label": 0 if labelled else None, "width": width, "what": "first point",
              "names": FIELD_COUNTS[width]}
    layout.update({name: labelled + index if labelled + index < width else None
                   for index, name in enumerate(COORDINATES)})
    if labelled and not _is_number(fields[0]) and not all(_is_number(field) for field in fields[1:4]):
        raise InputError(f"{path}, line {line_number}: {fields[1].strip()!r} is neither a number nor a column "
                         "name this reader knows; name the columns in a header (label, x, y, z, i, j, k) or write "
                         "one point a line as label x y z")
    return layout


def _is_number(field: str) -> bool:
    """True where a field reads as a float."""
    try:
        float(field)
    except ValueError:
        return False
    return True


def _fields(line: str, path: str, line_number: int) -> list[str]:
    """The fields of a line: split at semicolons where it has any, else at tabs, else at commas,
    else at blanks; a number with a comma inside (12,5 between semicolons or blanks) is a decimal
    comma, refused."""
    if ";" in line:
        fields = [field.strip() for field in line.split(";")]
        for field in fields[1:]:
            if re.fullmatch(r"[-+]?\d*,\d+", field):
                raise InputError(f"{path}, line {line_number}: {field!r} has a decimal comma; write numbers with a "
                                 f"decimal point ({field.replace(',', '.')})")
        return [field for field in fields if field]
    if "\t" in line.strip():
        return [field.strip() for field in line.strip().split("\t")]
    tokens = line.split()
    commas = [token for token in tokens if re.fullmatch(r"[-+]?\d*,\d+", token)]
    if len(tokens) in FIELD_COUNTS and commas:
        raise InputError(f"{path}, line {line_number}: {commas[0]!r} has a decimal comma; write numbers with a "
                         f"decimal point ({commas[0].replace(',', '.')})")
    if "," in line:
        return [field.strip() for field in line.split(",")]
    return tokens
