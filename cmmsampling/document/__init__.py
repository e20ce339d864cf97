"""Sampling results as FreeCAD document objects: probe points, substitute surface, deviation report.

One call adds them, in the GUI, the Python console or headless::

    group = cmmsampling.add_to_document(result, doc, source=(body, "Face3"))
    points, surface, report = group.Group

``points`` is a Part::FeaturePython holding a compound of N vertices and the per-point data;
``surface`` the fitted substitute face with its deviation field; ``report`` a spreadsheet.
After the CAD face changed, :func:`reevaluate` projects the same (u, v) onto it and measures again.

This room never imports the GUI at its top: view providers are attached only when ``FreeCAD.GuiUp``.
Lengths are in mm, times in s.

The room's modules: objects (the proxies and their makers), results (add_to_document,
add_plan_to_document, reevaluate), sheets (the spreadsheets), transaction (undoable steps),
object_types (what an object is, by its proxy's Type), export_hook (File > Export),
export_defaults (the options an export starts from, whichever command writes it), settings (the
workbench's values kept in FreeCAD's parameter group) and
inspections (measured points judged against the CAD model: add_inspection_to_document).
Documents saved with the proxies at ``cmmsampling.document.ProbePoints`` (before this room had
modules) still open: the names below keep that path.
"""
from .export_hook import export
from .inspections import MeasuredPoints, add_inspection_to_document
from .object_types import probe_points_in
from .objects import ProbePoints, SubstituteSurface, TypedProxy
from .results import add_plan_to_document, add_to_document, reevaluate
from .transaction import recompute, transaction

__all__ = ["MeasuredPoints", "ProbePoints", "SubstituteSurface", "TypedProxy", "add_inspection_to_document",
           "add_plan_to_document", "add_to_document", "export",
           "probe_points_in", "recompute", "reevaluate", "transaction"]
