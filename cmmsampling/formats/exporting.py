"""Export probe points for a CMM.

:func:`export` writes a PointSet (or a SamplingResult, or a document object whose Proxy offers
``point_set(obj)``) as a DMIS input program, a PC-DMIS XYZ file or a CSV file (one module per
format, :mod:`cmmsampling.formats.pointfiles`), in the global frame or in a local coordinate
system, optionally as probe-ball centres and in a short probing order. Files are replaced
atomically (:mod:`cmmsampling.formats.files`): a failed export leaves an existing file as it was.
"""
from __future__ import annotations

import os
from dataclasses import asdict, dataclass, replace

import numpy as np

from ..access.probe import Motion, Probe
from ..access.probe_moves import probe_moves
from ..geometry.probe_path import PathOrder, path_length, short_path, unchanged
from ..geometry.validation import InputError, InputTypeError, check_choice, check_real
from ..strategies.result import SamplingResult
from .files import write_atomically
from .frames import FRAME_KEYS, frame_facts, resolve_frame, to_local
from .pointfiles import FORMATS, READER_KEYS, resolve_format
from .pointset import PointSet
from .registry import WriteOptions

ORDERS = ("as_optimised", "short_path", "probe_path")
UNIT_TOLERANCE = 1e-3
PROBE_KEYS = ("probe_radius_mm", "ball_radius_mm", "points")
ORDER_KEYS = ("order", "path_length_mm")
WRITTEN_KEYS = FRAME_KEYS + PROBE_KEYS + ORDER_KEYS + ("count", "units") + READER_KEYS


@dataclass(frozen=True)
class ExportReport:
    """What :func:`export` wrote.

    path: absolute path; format: 'dmis', 'xyz' or 'csv'; count: points written; order: the order
    asked for; length_before, length_after: mm, open 3D path through the written points in the
    source's order and in the written order; frame: 'global' or 'local'; probe_radius: mm added
    along the normals (0: contact points); ball_radius: mm, the radius stated beside contact
    points (DMIS); for a probe path: length_before is the straight
    nearest-neighbour order with the detours it needs, length_after the path's travel, detours
    its moves over the clearance plane, seconds the estimated measuring time, orientations the
    head orientations (sensors) and tip_changes the changes between them along the path.
    """

    path: str
    format: str
    count: int
    order: str
    length_before: float
    length_after: float
    frame: str
    probe_radius: float
    detours: int = 0
    seconds: float | None = None
    ball_radius: float = 0.0
    orientations: int = 0
    tip_changes: int = 0

    @property
    def saving(self):
        """Path shortening in mm."""
        return self.length_before - self.length_after

    def __str__(self):
        what = "contact points"
        if self.probe_radius > 0:
            what = f"ball centres, probe radius {self.probe_radius:g} mm"
        elif self.ball_radius > 0:
            what = f"contact points, ball radius {self.ball_radius:g} mm stated"
        line = (f"Wrote {self.count} points to {self.path} ({FORMATS[self.format].title}, "
                f"{self.frame} frame, {what}). ")
        if self.order == "probe_path":
            return line + (f"Collision-free probe path: {self.length_after:.1f} mm of moves, {self.detours} over the "
                           f"clearance plane (the straight nearest-neighbour order with its detours: "
                           f"{self.length_before:.1f} mm); {self.orientations} head orientation(s), "
                           f"{self.tip_changes} tip change(s); about {self.seconds:.0f} s of measuring.")
        if self.order == "short_path":
            line += f"Probe path {self.length_after:.1f} mm in the short-path order"
            if self.saving > 0:
                line += (f" ({self.length_before:.1f} mm in the optimised order: "
                         f"{100 * self.saving / self.length_before:.0f} % shorter)")
            return line + "."
        return line + f"Probe path {self.length_before:.1f} mm in the optimised order."


@dataclass(frozen=True)
class ResultsReport:
    """What :func:`export` wrote of an inspection: path (absolute), format, count (points),
    profile (mm; None for a model's characteristics, each with its own value) and passed (True,
    False, or None without a tolerance or a verdict)."""

    path: str
    format: str
    count: int
    profile: float | None
    passed: bool | None = None

    def __str__(self):
        verdict = "" if self.passed is None else f", {'PASS' if self.passed else 'FAIL'}"
        figure = "" if self.profile is None else f": profile {self.profile:.4f} mm"
        return (f"Wrote the results of {self.count} measured points to {self.path} ({FORMATS[self.format].title})"
                f"{figure}{verdict}.")


def is_inspection(source):
    """True for an inspection's results (cmmsampling.inspection.result.Inspection: measured points,
    their deviations and the alignment's transform)."""
    return (all(hasattr(source, name) for name in ("deviations", "transform", "face_profiles", "measured"))
            or is_mbd_inspection(source))


def _judged(source):
    """source, or the inspection of a run that judges its own points (a callable judged());
    InputError where it has none (too few points)."""
    judged = getattr(source, "judged", None)
    if not callable(judged) or is_inspection(source):
        return source
    inspection = judged()
    if inspection is None:
        raise InputError(f"{type(source).__name__} measured too few points to be judged: it has no results to write")
    return inspection


def is_mbd_inspection(source):
    """True for a QIF MBD model's characteristics judged (cmmsampling.inspection.characteristics.
    MbdInspection), whose results go into the model's own document."""
    return all(hasattr(source, name) for name in ("characteristics", "plan", "rows", "labels"))


def export_results(inspection, path, fmt, label=None, **asked):
    """Write an inspection's results (a format with write_results: QIF). asked: export()'s
    options that do not apply to results, refused unless left at their defaults."""
    if FORMATS[fmt].write_results is None:
        with_results = [record for record in FORMATS.values() if record.write_results is not None]
        kinds = ", ".join(f"{record.title} ({', '.join(record.extensions)})" for record in with_results)
        raise InputError(f"an inspection's results are written as {kinds}, not {FORMATS[fmt].title}; give a path "
                         f"ending in {with_results[0].extensions[0]}")
    changed = [name for name, (value, default) in asked.items() if value != default]
    if changed:
        raise InputError(f"an inspection's results are written as measured and aligned; leave {', '.join(changed)} "
                         "at the default")
    text = FORMATS[fmt].write_results(inspection, "part" if label is None else str(label))
    target = write_atomically(path, text, FORMATS[fmt].encoding)
    return ResultsReport(target, fmt, len(inspection.labels), inspection.profile, inspection.passed)


def export(source: SamplingResult | PointSet | object, path: str | os.PathLike, format: str | None = None,
           *, frame: object = None, probe_radius: float = 0.0, order: str | None = None, name: str | None = None,
           approach: float = 2.0, retract: float = 2.0, search: float = 5.0, comments: bool = True,
           motion: Motion | None = None, label: str | None = None) -> ExportReport | ResultsReport:
    """Write probe points to a file for a CMM.

    source: a PointSet, a SamplingResult, a PartPlan, a document object whose Proxy has
    ``point_set(obj)``, or an Inspection, or a run that judges its own points with judged()
    (cmmsampling.measure_until_decided's DecidedRun: its inspection) (their results, QIF only:
    ResultsReport);
    points: (N, 3) mm, normals (N, 3) unit vectors out of the material (the probe travels along
    -normal), both global. path: the file; format: 'dmis', 'xyz', 'csv' or 'qif', by default
    from the extension (.dmi/.dmis, .xyz/.txt, .csv, .qif).
    frame: None for global coordinates, or the local coordinate system as a FreeCAD.Placement or an
    object with a Placement (e.g. a datum coordinate system; its global placement is used): points
    are written as placement.inverse() * p, normals rotated only.
    probe_radius: mm; when positive the points are probe-ball centres p + r * n (the radius is
    stated in CSV comments; the XYZ format has no comments, so an XYZ file holds the points as
    written and the caller has to keep the radius with it). DMIS nominals (FEAT/POINT, PTMEAS)
    are surface points whatever the radius: the CMM takes its ball's radius off itself, so a DMIS
    file keeps the contact points and states the radius (``$$ ball_radius_mm``); its GOTO moves
    are ball centres.
    order: 'as_optimised' keeps the source's order, 'short_path' visits the points along a short
    path (nearest neighbour + 2-opt, :mod:`cmmsampling.geometry.probe_path`), 'probe_path' along
    the collision-free path of a run made with the part (``sample(..., part=)``,
    :mod:`cmmsampling.access.probe_moves`): DMIS then gets a sensor per head orientation and the
    GOTO moves between the points, CSV the probe axis of each point; None (the default):
    'probe_path' for a source made with the part and a probe (:func:`made_with_probe`: the same
    program File > Export writes; one whose probe cannot reach every point is refused, never
    written through the part), else 'as_optimised'. Every DMIS program selects its sensor
    (SNSDEF, SNSLCT: the run's probe, else cmmsampling.Probe()'s 2 mm ball, vertical) and
    states its ball radius; motion: the CMM's speeds for the time estimate
    (cmmsampling.access.probe.Motion).
    name: DMIS program name (default: the file name without extension); approach, retract,
    search: DMIS SNSET distances, mm; comments: write the source's metadata (source face,
    strategy, parameters, deviation figures) as comments; the frame, probe radius and order are
    stated in DMIS and CSV files either way; label: the source's name in those comments (e.g.
    'part.step:Face3'), by default the source's own.
    The file is written to a temporary file in the same folder and then moved over the target, so
    an existing file survives any failure. Returns an ExportReport; ValueError or TypeError for bad
    input, ExportError (an OSError) naming the path and the reason when it cannot be written.
    """
    fmt = resolve_format(path, format)
    source = _judged(source)
    if is_inspection(source):
        return export_results(source, path, fmt, label, frame=(frame, None), probe_radius=(probe_radius, 0.0),
                              order=(order, None))
    order = check_choice("order", order, list(ORDERS)) if order is not None else (
        "probe_path" if made_with_probe(source) else "as_optimised")
    radius = check_real("probe_radius", probe_radius, minimum=0.0)
    options = WriteOptions(
        name=_stem(path) if name is None else str(name),
        approach=check_real("approach", approach, above=0.0),
        retract=check_real("retract", retract, above=0.0),
        search=check_real("search", search, above=0.0),
        comments=bool(comments),
    )
    placement, frame_name = resolve_frame(frame)
    point_set, moves = as_point_set(source), None
    if label is not None:
        point_set = replace(point_set, metadata={**point_set.metadata, "source": str(label)})
    if order == "probe_path":
        moves = probe_moves(source, motion)
        point_set = along_moves(point_set, moves)
    probe = point_set.metadata.get("probe") or asdict(Probe())
    options = replace(options, probe=probe)
    if FORMATS[fmt].contact_nominals and radius == 0.0 and not float(point_set.metadata.get("probe_radius_mm", 0.0)):
        radius = 0.5 * float(probe["ball_diameter"])
    point_set, facts = prepared(point_set, placement, radius, frame_name, FORMATS[fmt].contact_nominals)
    if moves is not None:
        path_order = PathOrder(np.arange(len(point_set)), moves.baseline, moves.travel)
    else:
        path_order = short_path_within(point_set) if order == "short_path" else unchanged(point_set.points)
        point_set = reordered(point_set, path_order.order)
    facts.update(order=order, path_length_mm=path_order.length_after)
    text = FORMATS[fmt].write(point_set, facts, options)
    target = write_atomically(path, text, FORMATS[fmt].encoding)
    return ExportReport(target, fmt, len(point_set), order, path_order.length_before, path_order.length_after,
                        facts["frame"], facts.get("probe_radius_mm", 0.0), 0 if moves is None else moves.detours,
                        None if moves is None else moves.seconds, facts.get("ball_radius_mm", 0.0),
                        0 if moves is None else moves.orientations, 0 if moves is None else moves.tip_changes)


def measuring_groups(point_set: PointSet) -> list[np.ndarray]:
    """The point indices a program measures one group after the other: each datum's points
    (metadata ``datums``, primary first; a datum of several faces one group), then the others;
    one group without datums."""
    datums = list(point_set.datum_rows().values())
    if not datums:
        return [np.arange(len(point_set))]
    rest = np.setdiff1d(np.arange(len(point_set)), np.concatenate(datums))
    return datums + ([rest] if rest.size else [])


def short_path_within(point_set: PointSet) -> PathOrder:
    """A short path (cmmsampling.geometry.probe_path.short_path) through each of the point set's
    measuring groups in turn (the datum points first): a PathOrder over all its points."""
    groups = measuring_groups(point_set)
    order = np.concatenate([group[short_path(point_set.points[group]).order] for group in groups])
    return PathOrder(order, path_length(point_set.points), path_length(point_set.points, order))


def made_with_probe(source: object) -> bool:
    """True for a source made with the part and a probe, whose export follows the collision-free
    probe path by default: a SamplingResult run with part= (its access), a PartPlan made with
    probe=, a document object whose Proxy says ``follows_probe(obj)``."""
    follows = getattr(getattr(source, "Proxy", None), "follows_probe", None)
    if callable(follows):
        return bool(follows(source))
    if isinstance(source, SamplingResult):
        return source.access is not None
    return getattr(source, "probe", None) is not None and callable(getattr(source, "probe_moves", None))


def along_moves(point_set, moves):
    """The point set in the order of a probe path (ProbeMoves) with its travel moves."""
    ordered = reordered(point_set, moves.order)
    ordered.travel = moves.travel_pairs()
    return ordered


def _stem(path):
    """The file name of path without folder and extension."""
    return os.path.splitext(os.path.basename(os.fspath(path)))[0]


def as_point_set(source):
    """The PointSet of a PointSet, a SamplingResult, a document object whose Proxy has
    point_set(obj), or a source that hands its own points over with point_set() (a PartPlan)."""
    if isinstance(source, PointSet):
        return source
    if isinstance(source, SamplingResult):
        return PointSet.from_result(source)
    method = getattr(getattr(source, "Proxy", None), "point_set", None)
    if callable(method):
        return _handed(method(source), f"{source.Name}.Proxy.point_set()")
    method = getattr(source, "point_set", None)
    if callable(method):
        return _handed(method(), f"{type(source).__name__}.point_set()")
    raise InputTypeError(
        f"cannot export a {type(source).__name__}; give a PointSet, a SamplingResult or a document "
        "object whose Proxy has point_set(obj)"
    )


def _handed(point_set, said):
    """point_set when it is a PointSet; TypeError naming what handed it (``said``) otherwise."""
    if isinstance(point_set, PointSet):
        return point_set
    raise InputTypeError(f"{said} returned {type(point_set).__name__}, not a PointSet")


def prepared(point_set, placement, radius, frame_name="", contact_nominals=False):
    """The point set as it is written, and the facts that say what its numbers mean.

    Checks the point set, moves the points to the ball centres p + radius * n, then into the
    placement's frame. A point set whose metadata already states a local frame or a probe radius
    (e.g. one read from a file) keeps those facts when neither is applied again, and is refused
    when one would be applied on top. contact_nominals (a format of nominal surface points,
    DMIS): the points stay (or go back to) contact points and the radius is stated as
    ball_radius_mm. Returns (PointSet, facts dict).
    """
    point_set = checked(point_set)
    stated = point_set.metadata
    if placement is not None and stated.get("frame", "global") != "global":
        raise InputError("these points are already in a local frame; export them with frame=None, "
                         "or export the global points")
    stated_radius = float(stated.get("probe_radius_mm", 0.0))
    if radius > 0 and stated_radius > 0:
        raise InputError(f"these points are already probe-ball centres (radius {stated_radius} mm); "
                         "export them with probe_radius=0, or export the contact points")
    total = radius + stated_radius
    offset = -stated_radius if contact_nominals else radius
    points = point_set.points + offset * point_set.normals
    normals, axes, travel = point_set.normals, point_set.axes, point_set.travel
    if placement is None:
        facts = {key: stated[key] for key in FRAME_KEYS if key in stated} or {"frame": "global"}
    else:
        facts = frame_facts(placement, frame_name)
        points, normals = to_local(points, normals, placement)
        axes = None if axes is None else to_local(np.zeros_like(axes), axes, placement)[1]
        travel = None if travel is None else [tuple(_local(p, placement) for p in pair) for pair in travel]
    facts.update(_radius_facts(total, contact_nominals))
    metadata = {key: value for key, value in stated.items() if key not in WRITTEN_KEYS}
    return PointSet(point_set.labels, points, normals, point_set.uv, point_set.deviation, metadata,
                    point_set.faces, axes, travel), facts


def _radius_facts(radius, contact_nominals):
    """The facts on the probe radius (mm) of written points: ball centres where it is added,
    else contact points (where the format takes contact points only, the ball's radius is stated
    alone: a probe radius of 0 beside it read as a contradiction of the radius asked for)."""
    if contact_nominals and radius > 0:
        return {"ball_radius_mm": radius,
                "points": f"contact points on the face (the CMM takes its {radius:g} mm ball radius off)"}
    if radius > 0:
        return {"probe_radius_mm": radius, "points": f"probe-ball centres (contact point + {radius:g} mm * normal)"}
    return {"probe_radius_mm": 0.0, "points": "contact points on the face"}


def _local(positions, placement):
    """Positions (M, 3) mm in the placement's frame."""
    return to_local(positions, np.zeros_like(positions), placement)[0]


def checked(point_set):
    """A copy of point_set with float arrays, str labels and normalised normals.

    ValueError naming the problem: no points, wrong shapes, NaN or infinite values, a normal whose
    length differs from 1 by more than 1e-3.
    """
    points = np.asarray(point_set.points, dtype=float)
    count = len(points)
    if count == 0:
        raise InputError("the point set has no points")
    if points.shape != (count, 3):
        raise InputError(f"points must be an (N, 3) array in mm, got shape {points.shape}")
    normals = np.asarray(point_set.normals, dtype=float)
    if normals.shape != (count, 3):
        raise InputError(
            f"normals must be an (N, 3) array like the points {points.shape}, got {normals.shape}"
        )
    if len(point_set.labels) != count:
        raise InputError(f"{len(point_set.labels)} labels for {count} points")
    labels = [str(label) for label in point_set.labels]
    _check_finite("points", points, labels)
    _check_finite("normals", normals, labels)
    lengths = np.linalg.norm(normals, axis=1)
    bad = np.flatnonzero(np.abs(lengths - 1.0) > UNIT_TOLERANCE)
    if bad.size:
        raise InputError(f"the normal of point {labels[bad[0]]} has length {lengths[bad[0]]:.6g}; "
                         "approach vectors must be unit vectors")
    uv = _optional(point_set.uv, (count, 2), "uv", labels)
    deviation = _optional(point_set.deviation, (count,), "deviation", labels)
    faces = None if point_set.faces is None else [str(face) for face in point_set.faces]
    if faces is not None and len(faces) != count:
        raise InputError(f"{len(faces)} face names for {count} points")
    axes = None if point_set.axes is None else np.asarray(point_set.axes, dtype=float)
    if axes is not None and (axes.shape != (count, 3) or not np.isfinite(axes).all()):
        axes = None
    return PointSet(labels, points, normals / lengths[:, None], uv, deviation, dict(point_set.metadata), faces,
                    axes, point_set.travel)


def spacing_by_face(settings):
    """{"edge_offset_mm": {face: mm}, "min_spacing_mm": {face: mm}} from each face's run settings
    ({face: settings}), as the runs used them (each face has its own where the plan left them
    automatic)."""
    return {f"{key}_mm": {face: float(values[key]) for face, values in settings.items() if key in values}
            for key in ("edge_offset", "min_spacing")}


def _check_finite(name, values, labels):
    """ValueError naming the first point whose row of values (N, k) is not finite."""
    bad = np.flatnonzero(~np.all(np.isfinite(values.reshape(len(labels), -1)), axis=1))
    if bad.size:
        raise InputError(
            f"{name} of point {labels[bad[0]]} contain NaN or infinite values ({bad.size} points)"
        )


def _optional(values, shape, name, labels):
    """values as a finite float array of shape, or None when None; ValueError otherwise."""
    if values is None:
        return None
    array = np.asarray(values, dtype=float)
    if array.shape != shape:
        raise InputError(f"{name} must have shape {shape}, got {array.shape}")
    _check_finite(name, array, labels)
    return array


def reordered(point_set, order):
    """point_set with its points, labels and per-point values in order (N,) int."""
    return PointSet([point_set.labels[i] for i in order], point_set.points[order], point_set.normals[order],
                    _taken(point_set.uv, order), _taken(point_set.deviation, order), point_set.metadata,
                    None if point_set.faces is None else [point_set.faces[i] for i in order],
                    _taken(point_set.axes, order))


def _taken(values, order):
    """values[order], or None for None."""
    return None if values is None else values[order]
