"""Sampling results as FreeCAD document objects: probe points, substitute surface, deviation report.

One call adds them, in the GUI, the Python console or headless::

    group = cmmsampling.add_to_document(result, doc, source=(body, "Face3"))
    points, surface, report = group.Group

``points`` is a Part::FeaturePython holding a compound of N vertices and the per-point data;
``surface`` the fitted substitute face with its deviation field; ``report`` a spreadsheet.
After the CAD face changed, :func:`reevaluate` projects the same (u, v) onto it and measures again.

This module never imports the GUI: view providers are attached only when ``FreeCAD.GuiUp``.
Lengths are in mm, times in s.
"""
from __future__ import annotations

import contextlib
import json
from xml.etree import ElementTree

import numpy as np

from .access.obstacles import Obstacles
from .access.probe import Probe
from .formats.pointset import PointSet
from .geometry.freecad_env import import_part
from .geometry.surface import SurfaceModel
from .geometry.validation import InputError, InputTypeError
from .object_types import PROBE_POINTS, SUBSTITUTE_SURFACE, is_probe_points, source_face
from .planning.part_plan import PartPlan
from .planning.probe_moves import moves_through, probe_moves
from .strategies.result import SamplingResult
from .strategies.sampling import evaluate

Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

POINT_TOLERANCE_MM = 1e-7
FIT_SETTINGS = ("fit_degree", "fit_poles", "smoothing", "grid")
REPORT_COLUMNS = "ABCDEFGHIJ"
REPORT_WIDTHS = {"A": 190, "B": 110, "C": 110, **{c: 95 for c in "DEFGHIJ"}}
PARAMETER_NAMES = {
    "fit_degree": "Fit degree (u x v)", "fit_poles": "Fit poles (u x v)", "smoothing": "Fit smoothing",
    "grid": "Evaluation grid (u x v)", "seed": "Seed", "workers": "Processes",
    "edge_offset": "Edge offset (mm)", "min_spacing": "Minimum spacing (mm)",
    "population": "PSO population", "iterations": "PSO iterations", "w1": "PSO inertia w1",
    "w2": "PSO inertia w2", "c1": "PSO c1", "c2": "PSO c2", "velocity_limit": "PSO velocity limit",
    "start_from_uniform": "PSO starts from uniform", "start": "Descent start",
    "time_limit": "Time limit (s)", "max_evaluations": "Most evaluations", "closest": "Closest points (mm)",
}
NOTES_DOC = "What the run did that the user should know, in sentences (e.g. points moved onto the face)"
SUMMARY_FIGURES = (
    ("MaxDeviation", "maximum",
     "Largest distance in space from the face to the substitute, over the grid's nodes on the face"),
    ("MeanDeviation", "mean", "Mean distance from the face to the substitute at the nodes"),
    ("RmsDeviation", "rms", "Root-mean-square distance at the nodes"),
    ("StdDeviation", "std", "Standard deviation of the distance at the nodes"),
    ("OccMaxDeviation", "occ_maximum",
     "The maximum again: OpenCASCADE's closest-point distance at the nodes of largest deviation"),
)


def add_to_document(result: SamplingResult, doc: FreeCAD.Document, source: tuple | None = None, hide_source: bool = False,
                    hide_others: bool = True) -> FreeCAD.DocumentObject:
    """Add a SamplingResult to ``doc`` in one transaction (one Undo removes it all).

    result: a :class:`cmmsampling.SamplingResult`; doc: a FreeCAD document;
    source: ``(obj, "Face3")``, the document face the result was sampled on, or None;
    hide_source: hide the whole source object (by default it stays visible: the substitute is
    drawn over its face); hide_others: hide the probe points and substitutes of earlier results,
    so that one result is shown at a time (Undo shows them again).
    Creates a group "Sampling <label> <face> (<strategy>)" holding the probe points, the substitute
    surface and the deviation report (in that order) and returns the group.
    When any step fails, nothing is added (see :func:`transaction`) and the exception is raised.
    """
    source = _check_source(source, doc)
    with transaction(doc, "Add sampling result"):
        group = doc.addObject("App::DocumentObjectGroup", "Sampling")
        if hide_others:
            hide_results(doc)
        group.Label = _group_label(result, source)
        objects = _fill_result_group(group, result, source)
        if source is not None and hide_source:
            source[0].Visibility = False
        recompute(doc, objects)
    return group


def _fill_result_group(group, result, source, with_path=True):
    """Add a result's probe points, substitute surface and deviation report to ``group`` (inside a
    transaction), and its probe path when it was run with the part and ``with_path`` (a plan
    draws one path through all its faces instead); returns the objects."""
    doc = group.Document
    surface = make_substitute_surface(doc)
    report = doc.addObject("Spreadsheet::Sheet", "DeviationReport")
    report.Label = "Deviation report"
    points = make_probe_points(doc, source, surface, report)
    group.addObjects([points, surface, report])
    write_result(points, result, dict(result.settings), result.timings.get("total_s", 0.0))
    paths = []
    if with_path and result.access is not None and result.access.reachable.all():
        paths = make_probe_path(doc, probe_moves(result))
        group.addObjects(paths)
    return [points, surface, report] + paths


# Colours of a probe path: the moves between points and the touches (approach and retract).
PATH_COLOURS = {"moves": (0.15, 0.35, 0.85), "touches": (0.85, 0.15, 0.1)}


def make_probe_path(doc, moves):
    """Two wire objects of a probe path (cmmsampling.planning.probe_moves.ProbeMoves): "Probe
    moves" (travel and axis moves, blue) and "Probe touches" (approach and retract, red), ball
    centres in mm; returns them."""
    objects = []
    for name, label, chosen in (("ProbeMoves", "Probe moves", moves.kinds != "touch"),
                                ("ProbeTouches", "Probe touches", moves.kinds == "touch")):
        starts, ends = moves.waypoints[:-1][chosen], moves.waypoints[1:][chosen]
        keep = np.linalg.norm(ends - starts, axis=1) > 1e-9
        edges = [Part.LineSegment(FreeCAD.Vector(*a), FreeCAD.Vector(*b)).toShape()
                 for a, b in zip(starts[keep], ends[keep])]
        obj = doc.addObject("Part::Feature", name)
        obj.Label = label
        obj.Shape = Part.Compound(edges)
        if FreeCAD.GuiUp:
            obj.ViewObject.LineColor = PATH_COLOURS["moves" if name == "ProbeMoves" else "touches"]
            obj.ViewObject.LineWidth = 2.0
        objects.append(obj)
    return objects


def add_plan_to_document(plan: PartPlan, doc: FreeCAD.Document, part: FreeCAD.DocumentObject,
                         hide_others: bool = True) -> FreeCAD.DocumentObject:
    """Add a PartPlan to ``doc`` in one transaction (one Undo removes it all).

    plan: a :class:`cmmsampling.planning.part_plan.PartPlan` of ``part``'s faces (a document
    object whose shape the plan's face names, Face1.., refer to); hide_others: as in
    :func:`add_to_document`. Creates a group "Plan <part label> (<strategy>)" holding a sub-group
    per face with points (as :func:`add_to_document` makes it) and a "Plan report" spreadsheet:
    face, area (mm^2), N, maximum deviation and bound (mm), tolerance met, notes, one row per
    face and a row for the part. Returns the group.
    """
    sources = [_check_source((part, face.name), doc) for face in plan.placed]
    results = [plan.result(face.name) for face in plan.placed]
    with transaction(doc, "Add part plan"):
        group = doc.addObject("App::DocumentObjectGroup", "Plan")
        if hide_others:
            hide_results(doc)
        group.Label = f"Plan {part.Label} ({plan.strategy})"
        objects = []
        for source, result in zip(sources, results):
            face_group = doc.addObject("App::DocumentObjectGroup", "Sampling")
            face_group.Label = _group_label(result, source)
            group.addObject(face_group)
            objects += _fill_result_group(face_group, result, source, with_path=False)
        sheet = doc.addObject("Spreadsheet::Sheet", "PlanReport")
        sheet.Label = "Plan report"
        group.addObject(sheet)
        write_plan_report(sheet, plan)
        if plan.probe is not None and plan.placed and not any(face.unreached for face in plan.placed):
            paths = make_probe_path(doc, probe_moves(plan))
            group.addObjects(paths)
            objects += paths
        recompute(doc, objects + [sheet])
    return group


PLAN_COLUMNS = ("Face", "Area (mm^2)", "N", "Max deviation (mm)", "Bound (mm)", "Tolerance met", "Notes")


def write_plan_report(sheet, plan):
    """The per-part table of a plan in a spreadsheet: a title, the goal, one row per face and a
    row for the part (points in all, the worst face's deviation)."""
    goal = (f"tolerance {plan.tolerance:g} mm" if plan.tolerance is not None else f"{plan.budget} points")
    rows = [("CMM sampling plan",), ("Goal", goal), ("Strategy", plan.strategy), (), PLAN_COLUMNS]
    for face in plan.faces:
        rows.append((face.name, f"{face.area:.2f}", face.n, _figure(face.maximum), _figure(face.bound),
                     face.met_text, face.notes))
    rows.append(("Part", f"{plan.area:.2f}", plan.n_total, _figure(plan.worst), "",
                 "", f"{len(plan.refused)} faces without points" if plan.refused else ""))
    for row, values in enumerate(rows, start=1):
        for column, value in zip(REPORT_COLUMNS, values):
            sheet.set(f"{column}{row}", _cell_text(value))
    sheet.setStyle("A1", "bold")
    sheet.setStyle("A5:G5", "bold")
    sheet.setColumnWidth("A", 110)
    sheet.setColumnWidth("G", 400)


def _figure(value):
    """A deviation in mm as text at the CMM's resolution ('' for NaN)."""
    return "" if not np.isfinite(value) else f"{value:.6f}"


def hide_results(doc):
    """Hide the probe points and substitute surfaces of every result in ``doc``.

    Within a transaction, call it after the transaction has added an object: FreeCAD records
    changes of Visibility for Undo only in a transaction that has begun with another change."""
    for obj in probe_points_in(doc.Objects):
        for shown in (obj, getattr(obj, "Substitute", None)):
            if shown is not None and shown.Visibility:
                shown.Visibility = False


@contextlib.contextmanager
def transaction(doc, name):
    """One undoable step named ``name``: commit when the block ends, roll back when it raises.

    On an exception the transaction is aborted, which removes the objects the block added and
    restores the properties it changed, and the exception is raised again. Undo is switched on for
    the time of the step when the document has it off (headless documents do), so that the
    rollback also works there; it is switched off again afterwards.
    """
    undo_mode = doc.UndoMode
    doc.UndoMode = 1
    doc.openTransaction(name)
    try:
        yield
    except BaseException:
        doc.abortTransaction()
        raise
    else:
        doc.commitTransaction()
    finally:
        doc.UndoMode = undo_mode


def recompute(doc, objects):
    """Recompute ``doc``; RuntimeError naming the first of ``objects`` whose computation failed
    (FreeCAD only marks such an object invalid)."""
    doc.recompute()
    for obj in objects:
        if "Invalid" in obj.State:
            raise RuntimeError(f"{obj.Label} could not be computed: {obj.getStatusString()}")


def reevaluate(points: FreeCAD.DocumentObject, occ_check: bool = True) -> SamplingResult:
    """Measure the probe points again on their (possibly changed) source face.

    points: a probe-points object made by :func:`add_to_document`. Keeps each point's (u, v),
    projects it onto the face as it is now, refits the substitute with the stored fit and grid
    settings (no optimisation) and updates the points, the substitute surface and the report in
    one transaction (rolled back when a step fails). Returns the new SamplingResult.
    Raises ValueError when the source face is gone (the object is orphaned) or was never set.
    """
    face, problem = source_face(points)
    if face is None:
        raise InputError(f"cannot re-evaluate {points.Label}: {problem}")
    settings = json.loads(points.Parameters)
    uv = np.column_stack([points.U, points.V])
    fit = {key: settings[key] for key in FIT_SETTINGS if key in settings}
    result = evaluate(face, uv, strategy=points.Strategy, occ_check=occ_check, **fit)
    with transaction(points.Document, "Re-evaluate probe points"):
        write_result(points, result, settings, points.RunTime)
        recompute(points.Document, [o for o in (points, points.Substitute, points.Report) if o is not None])
    return result


def write_result(points, result, settings, run_time_s):
    """Write a result into the probe points and their linked substitute surface and report.

    settings: the parameters of the original run (JSON-friendly dict); run_time_s: its duration.
    """
    point_set = PointSet.from_result(result, points.SourceName)
    points.Labels = list(point_set.labels)
    points.Points = [FreeCAD.Vector(*p) for p in point_set.points]
    points.Normals = [FreeCAD.Vector(*n) for n in point_set.normals]
    points.U = [float(u) for u in point_set.uv[:, 0]]
    points.V = [float(v) for v in point_set.uv[:, 1]]
    points.Deviation = [float(d) for d in point_set.deviation]
    points.Strategy = result.strategy
    points.Parameters = json.dumps(settings, default=_json_value)
    points.RunTime = float(run_time_s)
    points.Cancelled = bool(result.cancelled)
    ProbePoints.add_properties(points)
    points.Notes = list(result.notes)
    write_access(points, result.access, result.settings.get("probe"))
    for prop, attribute, _ in SUMMARY_FIGURES:
        setattr(points, prop, float(getattr(result.deviation, attribute)))
    if points.Substitute is not None:
        write_substitute(points.Substitute, result)
    if points.Report is not None:
        write_report(points.Report, points)


def write_access(points, access, probe):
    """The probe's reach of a run made with the part (access: cmmsampling.access.reach.Access,
    probe: the Probe's settings as a dict) into the probe points: the axis used at each point,
    the probe (JSON) and the regions of the face it cannot reach; emptied for a run without."""
    if access is None:
        points.Axes, points.Tilted, points.Probe, points.Unreached, points.UnreachedArea = [], [], "", [], 0.0
        return
    points.Axes = [FreeCAD.Vector(*a) for a in np.asarray(access.axes, dtype=float)]
    points.Tilted = [bool(t) for t in access.tilted]
    points.Probe = json.dumps(probe or {}, default=_json_value)
    rectangles = np.zeros((0, 4)) if access.unreached is None else np.asarray(access.unreached, dtype=float)
    points.Unreached = [float(x) for x in rectangles.ravel()]
    points.UnreachedArea = float(access.unreached_area)


def make_probe_points(doc, source=None, surface=None, report=None):
    """A probe-points object (Part::FeaturePython), empty until :func:`write_result` fills it."""
    obj = doc.addObject("Part::FeaturePython", "ProbePoints")
    ProbePoints(obj)
    obj.Label = "Probe points"
    if source is not None:
        obj.Source = (source[0], [source[1]])
        obj.SourceName = f"{source[0].Label}:{source[1]}"
    obj.Substitute = surface
    obj.Report = report
    if FreeCAD.GuiUp:
        from .gui import view_providers

        view_providers.ViewProviderProbePoints(obj.ViewObject)
    return obj


def make_substitute_surface(doc):
    """A substitute-surface object (Part::FeaturePython), empty until :func:`write_substitute`."""
    obj = doc.addObject("Part::FeaturePython", "SubstituteSurface")
    SubstituteSurface(obj)
    obj.Label = "Substitute surface"
    if FreeCAD.GuiUp:
        from .gui import view_providers

        view_providers.ViewProviderSubstituteSurface(obj.ViewObject)
    return obj


def write_substitute(surface, result):
    """The fitted surface as the object's shape, with the deviation field of the result."""
    stats = result.deviation
    surface.MaxDeviation = float(stats.maximum)
    surface.Shape = result.substitute_shape()
    surface.GridU = [float(u) for u in stats.grid_uv[:, 0, 0]]
    surface.GridV = [float(v) for v in stats.grid_uv[0, :, 1]]
    surface.DeviationField = [float(d) for d in np.ravel(stats.field)]


def write_report(sheet, points):
    """Fill the spreadsheet with the probe points' summary, run parameters, notes and per-point
    table, in readable columns.

    The summary figures are numbers in column B with aliases (strategy, n, max_mm, mean_mm,
    rms_mm, std_mm, occ_max_mm, time_s) for expressions such as ``=DeviationReport.max_mm``;
    column C repeats them readably, with their unit (the spreadsheet shows numbers with two
    decimals, which hides micrometres). The per-point table is text at the CMM's resolution.
    """
    clear_cells(sheet)
    summary = summary_rows(points)
    rows = ([row[:2] + _readable(row) for row in summary] + parameter_rows(points)
            + note_rows(points) + [()] + table_rows(points))
    for row, values in enumerate(rows, start=1):
        for column, value in zip(REPORT_COLUMNS, values):
            sheet.set(f"{column}{row}", _cell_text(value))
    for row, entry in enumerate(summary, start=1):
        if len(entry) == 3:
            sheet.setAlias(f"B{row}", entry[2])
    header = len(rows) - len(points.Labels)
    sheet.setStyle("A1", "bold")
    sheet.setStyle(f"A{header}:J{header}", "bold")
    sheet.setAlignment(f"B{header}:J{len(rows)}", "right")
    for column, width in REPORT_WIDTHS.items():
        sheet.setColumnWidth(column, width)


def clear_cells(sheet):
    """Empty every used cell of a spreadsheet (content, alias, style), undoably.

    FreeCAD 0.20's ``Sheet.clearAll()`` is not undoable: an Undo after it restores an empty sheet.
    Clearing cell by cell is. The used cells are read from the sheet's saved form.
    """
    for cell in ElementTree.fromstring(sheet.cells.Content).iter("Cell"):
        sheet.clear(cell.get("address"))


def summary_rows(points):
    """The report's summary: rows (name, value[, alias])."""
    return [
        ("CMM sampling report",),
        ("Source", points.SourceName or "(none)"),
        ("Strategy", points.Strategy, "strategy"),
        ("Points", len(points.Labels), "n"),
        ("Max deviation (mm)", points.MaxDeviation.Value, "max_mm"),
        ("Mean deviation (mm)", points.MeanDeviation.Value, "mean_mm"),
        ("RMS deviation (mm)", points.RmsDeviation.Value, "rms_mm"),
        ("Std deviation (mm)", points.StdDeviation.Value, "std_mm"),
        ("OCC max deviation (mm)", points.OccMaxDeviation.Value, "occ_max_mm"),
        ("Sampling time (s)", points.RunTime, "time_s"),
        ("Cancelled", "yes" if points.Cancelled else "no"),
    ] + reach_rows(points)


def reach_rows(points):
    """The report's rows on the probe's reach, for points sampled with the part: the points
    reached with the stylus tilted, those it cannot reach, and the face's area out of reach."""
    if not getattr(points, "Probe", ""):
        return []
    reached = np.isfinite(np.array([tuple(a) for a in points.Axes], dtype=float)).all(axis=1)
    return [
        ("Probe", probe_text(json.loads(points.Probe))),
        ("Points reached tilted", int(sum(points.Tilted)), "tilted"),
        ("Points the probe cannot reach", int(np.count_nonzero(~reached)), "unreached"),
        ("Area out of reach (mm^2)", points.UnreachedArea.Value, "unreached_mm2"),
    ]


def probe_text(probe):
    """A probe's settings (dict of cmmsampling.Probe's fields) in words: 'ball 2 mm, stylus 20 x
    1.5 mm, ...'."""
    return (f"ball {probe.get('ball_diameter', 0):g} mm, stylus {probe.get('stylus_length', 0):g} x "
            f"{probe.get('stylus_diameter', 0):g} mm, tilt up to {probe.get('max_tilt', 0):g} deg")


def parameter_rows(points):
    """The run's parameters other than strategy, N and the probe (:func:`reach_rows` says it):
    rows (name with its unit, value)."""
    settings = json.loads(points.Parameters)
    return [(PARAMETER_NAMES.get(key, key.replace("_", " ").capitalize()), _parameter_text(value))
            for key, value in settings.items() if key not in ("strategy", "n", "probe")]


def note_rows(points):
    """The run's notes: rows ("Note", sentence)."""
    return [("Note", note) for note in getattr(points, "Notes", [])]


def table_rows(points):
    """The per-point table: a header and rows (label, x, y, z, i, j, k, u, v, deviation), the
    values as text: coordinates to 0.1 um, approach vectors to 6 decimals, parameters and
    deviations to 6 significant digits."""
    header = ("Label", "X (mm)", "Y (mm)", "Z (mm)", "I", "J", "K", "U", "V", "Deviation (mm)")
    return [header] + [
        (label, *(f"{c:.4f}" for c in p), *(f"{c:.6f}" for c in n), f"{u:.6g}", f"{v:.6g}", f"{d:.6g}")
        for label, p, n, u, v, d in zip(points.Labels, points.Points, points.Normals,
                                        points.U, points.V, points.Deviation)
    ]


def _readable(row):
    """(text,) for a summary row (name, number[, alias]) whose name ends in its unit, 'Max
    deviation (mm)': the number to four significant digits with the unit, so that micrometres
    show; () for other rows."""
    if len(row) < 2 or isinstance(row[1], (str, bool)) or not row[0].endswith(")"):
        return ()
    unit = row[0][row[0].rindex("(") + 1:-1]
    return (f"{row[1]:.4g} {unit}",)


class TypedProxy:
    """A document-object proxy that saves only its Type with the document (FreeCAD 0.20 and
    0.21+ names)."""

    Type = ""

    def __getstate__(self):
        return {"Type": self.Type}

    def __setstate__(self, state):
        return None

    def dumps(self):
        return self.__getstate__()

    def loads(self, state):
        return self.__setstate__(state)


class ProbePoints(TypedProxy):
    """Proxy of the probe-points object: N labelled points with approach vectors on a face.

    Properties: Labels; Points (mm) and Normals (unit, out of the material); U, V (face
    parameters); Deviation (mm, substitute to face at each point); Source (the face) and
    SourceName ('Label:FaceK', kept when the face is deleted);
    Strategy, Parameters (JSON), RunTime (s), Cancelled; the deviation summary (mm);
    Substitute and Report (the other two result objects); Orphaned, Outdated, Status.
    """

    Type = PROBE_POINTS

    def __init__(self, obj):
        obj.Proxy = self
        self.add_properties(obj)

    @staticmethod
    def add_properties(obj):
        """Create the properties it lacks (read-only where they come from a run): all of them for
        a new object, those added since for one made by an earlier version."""
        points = [
            ("App::PropertyStringList", "Labels", "Point labels P1..PN"),
            ("App::PropertyVectorList", "Points", "Probe points on the face (mm)"),
            ("App::PropertyVectorList", "Normals",
             "Approach vectors: unit normals out of the material (the probe travels along -normal)"),
            ("App::PropertyFloatList", "U", "Face parameter u of each point"),
            ("App::PropertyFloatList", "V", "Face parameter v of each point"),
            ("App::PropertyFloatList", "Deviation",
             "Distance from the substitute surface to the face at each point (mm)"),
        ]
        sampling = [
            ("App::PropertyString", "Strategy", "Sampling strategy of the run"),
            ("App::PropertyString", "Parameters", "Every parameter of the run (JSON)"),
            ("App::PropertyFloat", "RunTime", "Duration of the sampling run (s)"),
            ("App::PropertyBool", "Cancelled", "The run was stopped early (best points so far)"),
            ("App::PropertyStringList", "Notes", NOTES_DOC),
        ]
        reach = [
            ("App::PropertyVectorList", "Axes",
             "The probe's axis at each point, ball towards head (NaN where it cannot reach); empty when "
             "the run did not know the part"),
            ("App::PropertyBoolList", "Tilted",
             "Points reached only with the stylus tilted (the head's orientation nearest the normal is blocked)"),
            ("App::PropertyString", "Probe", "The probe whose reach was judged (JSON), empty when none"),
            ("App::PropertyFloatList", "Unreached",
             "Regions of the face the probe cannot reach, as parameter rectangles u0, u1, v0, v1 in turn"),
            ("App::PropertyArea", "UnreachedArea", "Area of the face the probe cannot reach (mm^2)"),
        ]
        status = [
            ("App::PropertyString", "SourceName", "The sampled face when the points were made"),
            ("App::PropertyBool", "Orphaned", "The source face was deleted"),
            ("App::PropertyBool", "Outdated",
             "The source face no longer passes through the points; run Re-evaluate"),
            ("App::PropertyString", "Status", "Whether the points still match their face"),
        ]
        figures = [("App::PropertyLength", prop, doc + " (mm)") for prop, _, doc in SUMMARY_FIGURES]
        for group, props in (("Probe points", points), ("Sampling", sampling), ("Probe reach", reach),
                             ("Source", status), ("Deviation", figures)):
            for kind, name, doc in props:
                if name not in obj.PropertiesList:
                    obj.addProperty(kind, name, group, doc)
                    obj.setEditorMode(name, 1)
        for name, kind, group, doc in (
                ("Source", "App::PropertyLinkSubGlobal", "Source", "The sampled face"),
                ("Substitute", "App::PropertyLink", "Results", "The substitute surface"),
                ("Report", "App::PropertyLink", "Results", "The deviation report sheet")):
            if name not in obj.PropertiesList:
                obj.addProperty(kind, name, group, doc)

    def execute(self, obj):
        """Shape: a compound of the points as vertices; Status: whether the face still fits."""
        obj.Shape = Part.makeCompound([Part.Vertex(p) for p in obj.Points])
        face, problem = source_face(obj)
        obj.Orphaned = face is None and bool(obj.SourceName)
        obj.Outdated = face is not None and not _passes_through(face, obj)
        if obj.Orphaned:
            obj.Status = f"orphaned: {problem}"
            FreeCAD.Console.PrintWarning(f"{obj.Label} is orphaned: {problem}\n")
        elif face is None:
            obj.Status = problem
        elif obj.Outdated:
            obj.Status = "outdated: the source face changed; run Re-evaluate"
        else:
            obj.Status = "up to date"

    def onDocumentRestored(self, obj):
        _view_provider_when_missing(obj)

    def point_set(self, obj):
        """The probe points as a :class:`cmmsampling.formats.pointset.PointSet`."""
        settings = json.loads(obj.Parameters or "{}")
        metadata = {
            "source": obj.SourceName, **settings,
            **{key: getattr(obj, prop).Value for prop, key in (
                ("MaxDeviation", "max_mm"), ("MeanDeviation", "mean_mm"), ("RmsDeviation", "rms_mm"),
                ("StdDeviation", "std_mm"), ("OccMaxDeviation", "occ_max_mm"))},
        }
        axes = [tuple(a) for a in getattr(obj, "Axes", [])]
        return PointSet(
            labels=list(obj.Labels),
            points=np.array([tuple(p) for p in obj.Points], dtype=float).reshape(-1, 3),
            normals=np.array([tuple(n) for n in obj.Normals], dtype=float).reshape(-1, 3),
            uv=np.column_stack([obj.U, obj.V]).reshape(-1, 2),
            deviation=np.array(obj.Deviation, dtype=float),
            metadata=metadata,
            axes=np.array(axes, dtype=float) if len(axes) == len(obj.Labels) and axes else None,
        )

    def probe_moves(self, obj, motion=None):
        """The collision-free probe path through the points (cmmsampling.planning.probe_moves.
        ProbeMoves) on their source object's shape, with the probe and axes of their run; motion:
        the CMM's speeds (cmmsampling.access.probe.Motion). ValueError naming what is missing:
        points sampled without the part, points the probe cannot reach, a deleted source."""
        if not getattr(obj, "Probe", "") or len(obj.Axes) != len(obj.Labels):
            raise InputError(f"{obj.Label} were sampled without the part, so they have no probe axes: sample "
                             "the face again with the part (and a probe), or export with order='short_path'")
        point_set = self.point_set(obj)
        if not np.isfinite(point_set.axes).all():
            raise InputError(f"the probe cannot reach some of {obj.Label}: export with order='short_path'")
        if obj.Source is None:
            raise InputError(f"the part of {obj.Label} was deleted; a probe path needs it to keep clear of")
        probe = Probe(**json.loads(obj.Probe))
        return moves_through(probe, Obstacles(obj.Source[0].Shape), point_set.points, point_set.normals,
                             point_set.axes, motion)


class SubstituteSurface(TypedProxy):
    """Proxy of the substitute surface: the fitted B-spline face and its deviation field.

    Properties: Shape (the fitted face); GridU (g_u), GridV (g_v): the evaluation grid's
    parameters; DeviationField: g_u * g_v deviations in mm, row-major (u first), NaN off the face;
    MaxDeviation (mm).
    """

    Type = SUBSTITUTE_SURFACE

    def __init__(self, obj):
        obj.Proxy = self
        for kind, name, doc in (
            ("App::PropertyFloatList", "GridU", "Parameters u of the evaluation grid"),
            ("App::PropertyFloatList", "GridV", "Parameters v of the evaluation grid"),
            ("App::PropertyFloatList", "DeviationField",
             "Deviation from the face at each grid node (mm), u-major, NaN off the face"),
            ("App::PropertyLength", "MaxDeviation", "Largest deviation of the delivered substitute (mm)"),
        ):
            obj.addProperty(kind, name, "Deviation", doc)
            obj.setEditorMode(name, 1)

    def execute(self, obj):
        """Nothing to rebuild: the shape is written with the result."""

    def onDocumentRestored(self, obj):
        _view_provider_when_missing(obj)

    def deviation_grid(self, obj):
        """(GridU (g_u,), GridV (g_v,), field (g_u, g_v) mm) as numpy arrays."""
        u = np.array(obj.GridU, dtype=float)
        v = np.array(obj.GridV, dtype=float)
        return u, v, np.array(obj.DeviationField, dtype=float).reshape(len(u), len(v))


def export(objects, filename):
    """FreeCAD's File > Export hook (registered in Init.py): write the one probe-points object
    among ``objects`` (directly or inside a Sampling group) with :func:`cmmsampling.export`; the
    format follows the file's extension (.dmi/.dmis DMIS, .xyz PC-DMIS XYZIJK, .csv CSV).

    Raises ValueError unless exactly one probe-points object is found.
    """
    from .formats.exporting import export as write_points

    found = probe_points_in(objects)
    if len(found) != 1:
        raise InputError(f"select exactly one set of probe points (or its Sampling group) to export, "
                         f"found {len(found)}")
    return write_points(found[0], filename)


def probe_points_in(objects):
    """The probe-points objects among ``objects`` and inside those that are groups, once each."""
    found = []
    for obj in objects:
        for candidate in [obj] + list(getattr(obj, "Group", [])):
            if is_probe_points(candidate) and candidate not in found:
                found.append(candidate)
    return found


def _view_provider_when_missing(obj):
    """In the GUI, give an object restored from a document saved headless its view provider."""
    if FreeCAD.GuiUp:
        from .gui import view_providers

        view_providers.attach_when_missing(obj)


def _passes_through(face, points):
    """True when the face at the stored (u, v) still gives the stored points."""
    if not points.Points:
        return True
    uv = np.column_stack([points.U, points.V])
    now = SurfaceModel.from_face(face).points(uv)
    stored = np.array([tuple(p) for p in points.Points], dtype=float)
    return bool(np.abs(now - stored).max() <= POINT_TOLERANCE_MM)


def _check_source(source, doc):
    """(obj, "FaceK") checked against doc, or None."""
    if source is None:
        return None
    if not (isinstance(source, (tuple, list)) and len(source) == 2 and isinstance(source[1], str)):
        raise InputTypeError(f"source must be (obj, 'FaceK') or None, got {source!r}")
    obj, name = source
    try:
        document_name = getattr(getattr(obj, "Document", None), "Name", None)
    except ReferenceError:
        raise InputError(f"the source object of {name} was deleted; "
                         "name a face of an object that is in the document") from None
    if document_name != doc.Name:
        raise InputError(f"source object {getattr(obj, 'Name', obj)!r} is not in document {doc.Name!r}")
    if not isinstance(obj.getSubObject(name), Part.Face):
        raise InputError(f"source {obj.Label}.{name} is not a face; name one like 'Face1'")
    return obj, name


def _group_label(result, source):
    """'Sampling <object label> <face> (<strategy>)', or 'Sampling <strategy>' without a source.

    The label never ends in a digit: FreeCAD makes a repeated label unique by replacing its
    trailing digits, which would turn a second 'Sampling Body Face1' into '... Face002'.
    """
    if source is None:
        return f"Sampling {result.strategy}"
    return f"Sampling {source[0].Label} {source[1]} ({result.strategy})"


def _json_value(value):
    """JSON fallback for numpy scalars and arrays."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def _parameter_text(value):
    """A run parameter as report text: (u, v) pairs as 'a x b', other lists as JSON."""
    if isinstance(value, (list, tuple)):
        if len(value) == 2 and all(isinstance(v, (int, float)) for v in value):
            return f"{value[0]} x {value[1]}"
        return json.dumps(value)
    return value


def _cell_text(value):
    """Spreadsheet cell content: numbers in full precision, text always as text (never a
    formula or a number, e.g. the table's '12.3456')."""
    if isinstance(value, bool):
        return "'yes" if value else "'no"
    if isinstance(value, (int, float, np.floating, np.integer)):
        return format(float(value), ".10g")
    return "'" + str(value)
