"""Sampling results and plans added to a FreeCAD document, and re-evaluated after the CAD face
changed: each in one transaction (one Undo removes it; a fault adds nothing)."""
from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np

from ..access.probe import Probe
from ..formats.pointset import PointSet
from ..geometry.freecad_env import import_part
from ..geometry.surface import lies_on
from ..geometry.validation import InputError, InputTypeError
from ..planning.mbd_plan import MbdPlan
from ..planning.part_plan import DATUM_STRATEGY, PartPlan
from ..access.probe_moves import probe_moves
from ..strategies.result import SamplingResult
from ..strategies.sampling import evaluate
from .object_types import in_document, source_face
from .objects import (POINT_TOLERANCE_MM, SUMMARY_FIGURES, ProbePoints, make_plan_group, make_probe_path,
                      make_probe_points, make_substitute_surface, passes_through)
from .sheets import write_deviation_report, write_plan_report
from .transaction import hide_results, recompute, transaction

Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

FIT_SETTINGS = ("fit_degree", "fit_poles", "smoothing", "grid")


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


def _fill_result_group(group, result, source, with_path=True, label_prefix=""):
    """Add a result's probe points, substitute surface and deviation report to ``group`` (inside a
    transaction), and its probe path when it was run with the part and ``with_path`` (a plan
    draws one path through all its faces instead); label_prefix: what the points' labels start
    with (a plan's face name and _); returns the objects."""
    doc = group.Document
    surface = make_substitute_surface(doc)
    report = doc.addObject("Spreadsheet::Sheet", "DeviationReport")
    report.Label = "Deviation report"
    points = make_probe_points(doc, source, surface, report)
    points.LabelPrefix = label_prefix
    group.addObjects([points, surface, report])
    write_result(points, result, dict(result.settings), result.timings.get("total_s", 0.0))
    paths = []
    if with_path and result.access is not None and result.access.reachable.all():
        paths = make_probe_path(doc, probe_moves(result))
        group.addObjects(paths)
    return [points, surface, report] + paths


def add_plan_to_document(plan: PartPlan, doc: FreeCAD.Document, part: FreeCAD.DocumentObject,
                         hide_others: bool = True,
                         replace: FreeCAD.DocumentObject | None = None) -> FreeCAD.DocumentObject:
    """Add a PartPlan to ``doc`` in one transaction (one Undo removes it all).

    plan: a :class:`cmmsampling.planning.part_plan.PartPlan` of ``part``'s faces (a document
    object whose shape the plan's face names, Face1.., refer to); hide_others: as in
    :func:`add_to_document`. Creates a group "Plan <part label> (<strategy>)" holding a sub-group
    per datum face ("Datum A <part> Face1": its probe points only, spread to hold the frame, not
    fitted), then one per toleranced face with points (as :func:`add_to_document` makes it) and a
    "Plan report" spreadsheet: face, area (mm^2), N, maximum deviation and bound (mm), tolerance
    met, notes, one row per face and a row for the part, then the probe, its path's length and
    the measuring time. The group states the plan's datums and tolerance (Datums, Tolerance),
    which its programs and ``inspect(group, measured)`` take. replace: the group this function
    made for an earlier plan of the part (a cancelled plan that ``plan`` resumed), removed with
    everything in it in the same transaction. Returns the group.
    """
    sources = [_check_source((part, face.name), doc) for face in plan.placed]
    replaced = _plan_objects(replace, doc)
    for face in plan.placed:
        if not lies_on(plan.shapes[face.name], part.getSubObject(face.name)):
            raise InputError(f"{part.Label}.{face.name} is not the plan's {face.name}: give the object whose shape "
                             "was planned")
    results = [None if face.datum else plan.result(face.name) for face in plan.placed]
    with transaction(doc, "Add part plan"):
        for obj in replaced:
            doc.removeObject(obj.Name)
        group = make_plan_group(doc)
        group.Datums = list(plan.datums)
        # Faces planned to their own tolerances (a QIF MBD model's) state no one profile tolerance.
        group.Tolerance = 0.0 if plan.face_tolerances else (plan.tolerance or 0.0)
        _state_model(group, plan)
        if hide_others:
            hide_results(doc)
        group.Label = f"Plan {part.Label} ({plan.strategy})"
        objects = []
        for face, source, result in zip(plan.placed, sources, results):
            face_group = doc.addObject("App::DocumentObjectGroup", "Sampling")
            group.addObject(face_group)
            if face.datum:
                face_group.Label = f"Datum {face.datum} {source[0].Label} {source[1]}"
                objects += _fill_datum_group(face_group, face, source, plan.probe)
                continue
            face_group.Label = _group_label(result, source)
            objects += _fill_result_group(face_group, result, source, with_path=False, label_prefix=f"{source[1]}_")
        sheet = doc.addObject("Spreadsheet::Sheet", "PlanReport")
        sheet.Label = "Plan report"
        group.addObject(sheet)
        moves = None
        if plan.has_path:
            moves = probe_moves(plan)
            paths = make_probe_path(doc, moves)
            group.addObjects(paths)
            objects += paths
        write_plan_report(sheet, plan, moves)
        recompute(doc, objects + [sheet])
    return group


def _fill_datum_group(group, face, source, probe):
    """Add a datum face's probe points (face: its FacePlan) to ``group``, inside a transaction:
    labels '<face>_P<i>', no substitute or report (a datum's few points hold the frame, they are
    not fitted), the probe's reach where the plan judged it. Returns the objects."""
    doc = group.Document
    points = make_probe_points(doc, source)
    points.LabelPrefix = f"{source[1]}_"
    group.addObject(points)
    points.Labels = [f"{source[1]}_P{i}" for i in range(1, face.n + 1)]
    points.Points = [FreeCAD.Vector(*p) for p in np.asarray(face.points, dtype=float)]
    points.Normals = [FreeCAD.Vector(*n) for n in np.asarray(face.normals, dtype=float)]
    points.U = [float(u) for u in face.uv[:, 0]]
    points.V = [float(v) for v in face.uv[:, 1]]
    points.Deviation = [0.0] * face.n
    points.Strategy = DATUM_STRATEGY
    points.Parameters = json.dumps(face.settings, default=_json_value)
    points.Notes = [f"datum {face.datum}: {face.n} points spread to fix {face.settings['motions']} motions of the "
                    "part's frame; they are not fitted (no substitute or deviation)"]
    write_access(points, face.access, None if probe is None else asdict(probe))
    return [points]


def _plan_objects(group, doc):
    """The objects of a plan's group, the group last ([] for None); InputError when ``group`` is
    not a plan's group in ``doc``."""
    if group is None:
        return []
    if (not in_document(group, doc) or not group.isDerivedFrom("App::DocumentObjectGroup")
            or not group.Label.startswith("Plan ")):
        raise InputError("replace must be the group add_plan_to_document made for an earlier plan, in this "
                         "document: give that group, or None to keep it")
    return _members(group)


def _members(group):
    """A group's objects, those of its sub-groups before each sub-group, the group last."""
    objects = []
    for child in group.Group:
        objects += _members(child) if child.isDerivedFrom("App::DocumentObjectGroup") else [child]
    return objects + [group]


def reevaluate(points: FreeCAD.DocumentObject, occ_check: bool = True) -> SamplingResult:
    """Measure the probe points again on their (possibly changed) source face.

    points: a probe-points object made by :func:`add_to_document`. Keeps each point's (u, v),
    projects it onto the face as it is now, refits the substitute with the stored fit and grid
    settings (no optimisation) and updates the points, the substitute surface and the report in
    one transaction (rolled back when a step fails); points sampled with a probe are judged with
    that probe on their part as it is now, so their axes and probe path stay. Returns the new
    SamplingResult.
    Raises ValueError when the source face is gone (the object is orphaned) or was never set.
    """
    face, problem = source_face(points)
    if face is None:
        raise InputError(f"cannot re-evaluate {points.Label}: {problem}")
    if points.Strategy == DATUM_STRATEGY:
        raise InputError(f"{points.SourceName or points.Label} holds a datum's points, spread to hold the part's frame "
                         "and not fitted: plan the part again to place them on the face as it is now")
    face, renamed = _renumbered(points, face)
    settings = json.loads(points.Parameters)
    uv = np.column_stack([points.U, points.V])
    fit = {key: settings[key] for key in FIT_SETTINGS if key in settings}
    result = evaluate(face, uv, strategy=points.Strategy, occ_check=occ_check, **fit, **_reach_of(points))
    with transaction(points.Document, "Re-evaluate probe points"):
        if renamed is not None:
            result.notes.append(f"the part's faces were renumbered: the points' face {points.Source[1][0]} is now "
                                f"{renamed}")
            points.Source = (points.Source[0], [renamed])
            points.SourceName = f"{points.Source[0].Label}:{renamed}"
        write_result(points, result, settings, points.RunTime)
        recompute(points.Document, [o for o in (points, points.Substitute, points.Report) if o is not None])
    return result


def _renumbered(points, face):
    """(the face to re-evaluate the points on, its new name or None): the linked face, unless it no
    longer passes through the points and exactly one other face of the source object does, the
    same surface under a new number (the part's faces were renumbered), which is taken instead."""
    if passes_through(face, points):
        return face, None
    spread = FreeCAD.BoundBox()
    for point in points.Points:
        spread.add(point)
    found = [(f"Face{k}", other) for k, other in enumerate(points.Source[0].Shape.Faces, start=1)
             if _grown(other.BoundBox).isInside(spread) and passes_through(other, points)]
    return (found[0][1], found[0][0]) if len(found) == 1 else (face, None)


def _grown(box):
    """A face's FreeCAD BoundBox grown by the points' tolerance (its own copy, changed in place)."""
    box.enlarge(POINT_TOLERANCE_MM)
    return box


def _reach_of(points):
    """evaluate()'s part= and probe= for probe points sampled with a probe (their source object's
    shape as it is now and the stored Probe), none for points sampled without."""
    if not getattr(points, "Probe", ""):
        return {}
    return {"part": points.Source[0].Shape, "probe": Probe(**json.loads(points.Probe))}


def write_result(points, result, settings, run_time_s):
    """Write a result into the probe points and their linked substitute surface and report.

    settings: the parameters of the original run (JSON-friendly dict); run_time_s: its duration.
    """
    point_set = PointSet.from_result(result, points.SourceName)
    points.Labels = [getattr(points, "LabelPrefix", "") + label for label in point_set.labels]
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
    points.MaxNormalAngle = float(np.nan_to_num(result.deviation.normal_angle))
    if points.Substitute is not None:
        write_substitute(points.Substitute, result)
    if points.Report is not None:
        write_deviation_report(points.Report, points)


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


def write_substitute(surface, result):
    """The fitted surface as the object's shape, with the deviation field of the result."""
    stats = result.deviation
    surface.Proxy.add_missing_properties(surface)
    surface.MaxDeviation = float(stats.maximum)
    surface.MaxLocation = FreeCAD.Vector(*map(float, stats.max_location()))
    surface.Shape = result.substitute_shape()
    surface.GridU = [float(u) for u in stats.grid_uv[:, 0, 0]]
    surface.GridV = [float(v) for v in stats.grid_uv[0, :, 1]]
    surface.DeviationField = [float(d) for d in np.ravel(stats.field)]


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


def _state_model(group: FreeCAD.DocumentObject, plan: PartPlan) -> None:
    """A plan from a QIF MBD model (an MbdPlan) states the model's file, the characteristics
    planned and its programs' frame on its group (MbdFile, Characteristics, FrameDatums); a plan
    of faces states none."""
    if not isinstance(plan, MbdPlan):
        return
    group.MbdFile = plan.model.path
    group.Characteristics = [f"{key} {text}" for key, text in plan.stated().items()]
    group.FrameDatums = [" ".join([label, *faces]) for label, faces in plan.program_frame.items()]
