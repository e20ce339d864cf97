"""Measured points back in: paired with the planned ones, aligned to the CAD model and judged
against a profile tolerance (ISO 1101, form only: a zone of width t centred on the nominal, or
on a surface offset from it by o, ISO 1101's UZ: o = +-t/2 makes the zone unilateral).

The deviation of an aligned measured point is its signed distance from the CAD face it was
planned on, the face bounded by its edges (+ out of the material): along the face's outward
normal, or, for a point beyond an edge, to its foot on the edge (cmmsampling.inspection.closest). The profile is the width
of the smallest zone centred where the tolerance's zone is that holds every point:
2 max |d - o|. A point passes where |d - o| <= t / 2, a face (or the part) where its profile is
at most t.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, cast

import numpy as np

from ..formats.exporting import as_point_set
from ..formats.pointset import PointSet
from ..geometry.freecad_env import import_part
from ..geometry.surface import as_face
from ..geometry.validation import InputError, InputTypeError, check_real
from ..measurement import check_extent, stated_radius
from ..strategies.face_setup import reused
from ..planning.part_plan import PartPlan
from ..strategies.result import SamplingResult
from .align import ALIGNMENTS, Alignment, AlignmentCancelled, Closest, align, check_locked, kabsch
from .datums import (Datum, DatumFit, DatumMeasurement, Frame, Stage, align_on_datums, as_datums, check_datum_forms,
                     floating_frame)
from .uncertainty import profile_uncertainty
from .closest import OCC_AGREEMENT_MM, OCC_CONFIRMED, FaceCloser, confirm_with_occ, dense_nodes
from .measured import read_measured
from .result import Inspection

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()

# progress(message, None after a step of the alignment) -> True to cancel the inspection.
Progress = Callable[[str | None], bool | None]


@dataclass
class Planned:
    """What was planned: labels N (None for a bare face), nominal points (N, 3) mm (or None), the
    faces (Part.Face), their names and owner (N,) int, the index of each point's face (or None)."""

    labels: list | None
    points: np.ndarray | None
    faces: list
    names: list
    owner: np.ndarray | None


class InspectionCancelled(Exception):
    """The inspection was cancelled (its progress callback returned True); nothing was judged."""


def inspect(source: object, measured: str | os.PathLike | PointSet, alignment: str = "min_max",
            tolerance: float | None = None, locked: Sequence[str] = (), part: Part.Shape | None = None,
            probe_radius: float | None = None, zone_offset: float = 0.0,
            progress: Progress | None = None,
            datums: Datum | str | Sequence[Datum | str] | None = (), uncertainty: float | None = None,
            seed: int = 0, location_free: bool = False) -> Inspection:
    """Judge measured points against the CAD model they were planned on.

    source: a Part.Face (the measured points are taken as they come), a SamplingResult, a
    PartPlan (with part=, the shape the plan was made of: its faces by name), a Planned, or a
    document object whose Proxy has planned(obj) (the workbench's probe points and part plans);
    the measured points pair with the planned ones by label, else by order when the counts
    agree. measured: a path (DMIS output with FA(label) actuals, the project's CSV or XYZIJK,
    labelled x y z text: cmmsampling.inspection.measured) or a PointSet of contact points (a
    file's stated probe radius, or probe_radius mm, is taken off along its vectors).
    alignment: 'min_max' (ISO 1101's minimum zone, the default), 'best_fit' (least squares) or
    'none' (cmmsampling.inspection.align), started from the
    measured points' rigid match to their planned nominals (unless a degree of freedom is
    locked), the motions the points do not hold kept there (``free_motions``); locked: degrees
    of freedom held fixed (rx, ry, rz, x, y, z); tolerance: the profile tolerance t, mm
    (default: a PartPlan's own, or a part plan's group's in a document, as its programs state it);
    zone_offset: o, mm, the zone's centre from the nominal (ISO 1101's UZ, + out of the material;
    +-t/2 a unilateral zone outside or inside), which the alignment centres the points on and
    the profile and the verdict are taken from.
    datums: the datum reference frame (default: the source's own, a plan made with datums=, in the
    console or in a document),
    Datums (cmmsampling.inspection.datums) or face names
    ('Face3', a tangent datum labelled A, B, C in order), primary first: the part is aligned on
    them and the other points are judged in their frame, floated by ``alignment`` only in the
    motions the datums leave free (the profile is location and form); a datum's points are
    those planned on its face (taken out of the toleranced ones) unless it brings its own.
    uncertainty: u, mm, the CMM's probing standard uncertainty per point (MPE_P / sqrt(3)):
    the profile's expanded uncertainty by Monte Carlo (cmmsampling.inspection.uncertainty,
    seeded by ``seed``) and ISO 14253-1's decision (``Inspection.decision``).
    location_free: the datums fix the zone's orientation only (ISO 1101's orientation
    tolerances: perpendicularity, parallelism, angularity), its location floats.
    One alignment for all the points (a plan: the whole part). progress: callable(message) before
    each phase and after each step of the alignment (message None), returning True to cancel
    (InspectionCancelled). Returns an Inspection.
    """

    def told(message: str) -> None:
        if progress is not None and progress(message):
            raise InspectionCancelled

    if alignment not in ALIGNMENTS:
        raise InputError(f"alignment must be one of {', '.join(ALIGNMENTS)}, got {alignment!r}")
    locked = check_locked(locked)
    stated_datums, stated_tolerance = stated(source)
    tolerance = stated_tolerance if tolerance is None else tolerance
    tolerance = None if tolerance is None else check_real("tolerance", tolerance, above=0.0)
    zone_offset = check_real("zone_offset", zone_offset)
    uncertainty = None if uncertainty is None else check_real("uncertainty", uncertainty, above=0.0)
    wanted = as_datums(datums if datums else stated_datums or None)
    told("reading the measured points")
    planned = _planned(source, part)
    read = _measured_point_set(measured)
    contact = _contact_points(read, probe_radius)
    order, notes = pair(planned, read)
    notes = ([read.metadata["units_read"]] if "units_read" in read.metadata else []) + notes
    owner = np.zeros(len(order[0]), dtype=int) if planned.owner is None else planned.owner[order[1]]
    nominal = planned.points[order[1]] if planned.points is not None else np.full((len(order[0]), 3), np.nan)
    sources, kept = datum_points(wanted, planned, order, owner, contact, part, probe_radius, read.labels)
    order, owner, nominal = (order[0][kept], order[1][kept]), owner[kept], nominal[kept]
    if not len(order[0]):
        raise InputError("every measured point lies on a datum face: measure the toleranced face too, or give "
                         "fewer datums")
    points = contact[order[0]]

    told("preparing the faces")
    with reused():
        closers = [FaceCloser(face) if np.any(owner == index) else None for index, face in enumerate(planned.faces)]
        stages = [_datum_stage(source) for source in sources]

    def closest(where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _closest(closers, owner, where)

    told(f"aligning {len(points)} points" + (f" on datums {'|'.join(d.label for d in wanted)}" if wanted else ""))
    start = None if locked else _start([source.points for source in sources] + [points],
                                       [source.nominal for source in sources] + [nominal])
    found, frame = _aligned(points, closest, alignment, locked, start, zone_offset, stages, progress,
                            uncertainty is not None, location_free)
    check_datum_forms([] if frame is None else frame.datums, tolerance)
    told("confirming the decisive points with OCC")
    aligned = found.apply(points)
    _, normals, on_edge = _closest_on_edges(closers, owner, aligned)
    deviations, disagreement = confirm_with_occ(planned.faces, owner, aligned, found.deviations, zone_offset)
    if disagreement > OCC_AGREEMENT_MM:
        notes.append(f"OCC's distances at the {OCC_CONFIRMED} points farthest from the zone's centre differ from the "
                     f"alignment's by up to {disagreement:.2g} mm; OCC's are reported")
    inspection = Inspection([read.labels[i] for i in order[0]], nominal, points, aligned,
                            deviations, found.matrix, found, tolerance, [planned.names[i] for i in owner], notes,
                            measured_file=os.fspath(measured) if isinstance(measured, (str, os.PathLike)) else "",
                            zone_offset=zone_offset, normals=normals,
                            datums=[] if frame is None else _measured_datums(frame.datums, sources, stages, found),
                            planned_faces=dict(zip(planned.names, planned.faces)),
                            beyond_edges=[read.labels[i] for i in order[0][on_edge]], location_free=location_free)
    if len(set(owner.tolist())) > 1 and alignment != "none":
        told("aligning each face alone")
        inspection.face_forms = _face_forms(points, owner, closers, planned.names, found, locked, zone_offset, notes)
    if uncertainty is not None:
        assert frame is not None   # _aligned gives the Frame where an uncertainty is asked for (linear)
        again = Again(points, closest, alignment, locked, start, zone_offset, stages, owner, len(planned.names),
                      found.matrix, location_free)
        inspection.uncertainty = profile_uncertainty(
            frame, owner, planned.names, uncertainty, seed,
            lambda trials: told(f"propagating the probing uncertainty (Monte Carlo): {trials} trials"), again)
    if isinstance(source, SamplingResult):
        rebuild(inspection, source, order[1])
    return inspection


def stated(source: object) -> tuple[list, float | None]:
    """(datum faces' names, primary first; tolerance in mm or None): what a source states for its
    inspection: a PartPlan's datums and tolerance, a document object's (its Proxy's ``stated(obj)``,
    a part plan's group), nothing for any other."""
    if isinstance(source, PartPlan):
        return list(source.datums), source.tolerance
    method = getattr(getattr(source, "Proxy", None), "stated", None)
    return method(source) if callable(method) else ([], None)


def _start(points: list[np.ndarray], nominals: list[np.ndarray]) -> np.ndarray | None:
    """The (4, 4) motion the fit starts from: the rigid match of the points (a list of (M, 3)
    mm, datum points included) to their nominals (a list of (M, 3) mm, NaN where unknown), or
    None where no point has a nominal."""
    every, targets = np.vstack(points), np.vstack(nominals)
    labelled = np.isfinite(targets).all(axis=1)
    return kabsch(every[labelled], targets[labelled]) if labelled.any() else None


@dataclass
class DatumSource:
    """Where a datum's points come from: datum (a Datum), name: its face's name (its faces'
    joined by '+'), faces: its Part.Faces, points: (M, 3) mm contact points (measured frame),
    nominal: (M, 3) mm planned (NaN where it brings its own points), labels: M, the points'
    labels, owner: (M,) the index in faces of each point's face."""

    datum: Datum
    name: str
    faces: list
    points: np.ndarray
    nominal: np.ndarray
    labels: list
    owner: np.ndarray


def datum_points(datums: Sequence[Datum], planned: Planned, order: tuple[np.ndarray, np.ndarray], owner: np.ndarray,
                 contact: np.ndarray, part: Part.Shape | None, probe_radius: float | None,
                 labels: Sequence[str]) -> tuple[list[DatumSource], np.ndarray]:
    """(DatumSources, kept (N,) bool): each datum's points, and which of the paired points
    (order: (measured rows (N,) into contact (P, 3) mm and labels (P,), planned rows (N,)),
    owner (N,) their planned faces) stay toleranced (those of a datum's face that brings no
    points of its own go to the datum)."""
    kept, sources = np.ones(len(order[0]), dtype=bool), []
    for datum in datums:
        several = isinstance(datum.face, tuple)
        name = datum.face if isinstance(datum.face, str) else f"datum {datum.label}"
        if datum.points is not None:
            if several:
                raise InputError(f"datum {datum.label}: a datum of several faces takes its points from the plan; "
                                 "give it without points=, or one face with its points")
            face = _datum_face(datum, planned, part)
            given = _datum_point_set(datum)
            own = _contact_points(given, probe_radius)
            sources.append(DatumSource(datum, name, [face], own, np.full_like(own, np.nan), list(given.labels),
                                       np.zeros(len(own), dtype=int)))
            continue
        faces = datum.face if isinstance(datum.face, tuple) else (name,)
        indices = [_planned_datum_face(datum, planned, face) for face in faces]
        names = [planned.names[index] for index in indices]
        rows = np.isin(owner, indices)
        if not rows.any():
            raise InputError(f"datum {datum.label}: none of the measured points lies on {' or '.join(names)}; "
                             f"measure it or give Datum({datum.label!r}, face, points=...)")
        kept &= ~rows
        nominal = planned.points[order[1][rows]] if planned.points is not None else None
        sources.append(DatumSource(datum, "+".join(names), [planned.faces[index] for index in indices],
                                   contact[order[0][rows]],
                                   np.full((int(rows.sum()), 3), np.nan) if nominal is None else nominal,
                                   [labels[row] for row in order[0][rows]], _positions(indices)[owner[rows]]))
    return sources, kept


def _positions(indices: list[int]) -> np.ndarray:
    """(max + 1,) int: at each of the face indices its position in the list (-1 elsewhere)."""
    positions = np.full(max(indices, default=-1) + 1, -1)
    positions[indices] = np.arange(len(indices))
    return positions


def _planned_datum_face(datum: Datum, planned: Planned, name: str) -> int:
    """The index among the planned faces of datum's face ``name``; InputError where it has no
    planned points."""
    index = planned_face(planned, name)
    if index is None:
        raise InputError(f"datum {datum.label}: {name} has no planned points here; plan it with the toleranced "
                         f"faces (plan(part, faces=[...])) or give Datum({datum.label!r}, face, points=...)")
    return index


def _measured_datums(fits: Sequence[DatumFit], sources: Sequence[DatumSource], stages: Sequence[Stage],
                     found: Alignment) -> list[DatumFit]:
    """The DatumFits of a frame with the points each was associated on (a DatumMeasurement: its
    source's labels, contact points and nominals, and its face's outward normals at the points
    aligned by ``found``), for the results' record."""
    return [replace(fit, measurement=DatumMeasurement(source.labels, source.points, source.nominal,
                                                      stage.closest(found.apply(source.points))[1]))
            for fit, source, stage in zip(fits, sources, stages)]


@dataclass
class Again:
    """The whole alignment of an inspection, to run again on its points with errors added (the
    Monte Carlo's check of its linear model, uncertainty.Recheck): points (N, 3) mm, the toleranced
    measured points; closest, alignment, locked, start, offset and stages as the inspection had
    them; owner (N,) each point's face, faces: how many; matrix (4, 4): the inspection's motion,
    which turns the errors (drawn along the CAD axes) into the measured frame."""

    points: np.ndarray
    closest: Closest
    alignment: str
    locked: tuple[str, ...]
    start: np.ndarray | None
    offset: float
    stages: list[Stage]
    owner: np.ndarray
    faces: int
    matrix: np.ndarray
    location_free: bool = False

    def __call__(self, errors: np.ndarray) -> np.ndarray:
        """(F,) mm: each face's profile 2 max |d - o| (0 for a face without toleranced points) of
        the inspection run again with errors (P, 3) mm added to its points, the datums' first."""
        moved, first, stages = errors @ self.matrix[:3, :3], 0, []
        for stage in self.stages:
            stages.append(replace(stage, points=stage.points + moved[first:first + len(stage.points)]))
            first += len(stage.points)
        found, _ = _aligned(self.points + moved[first:], self.closest, self.alignment, self.locked, self.start,
                            self.offset, stages, None, False, self.location_free)
        off = np.abs(found.deviations - self.offset)
        return np.array([2.0 * float(off[self.owner == face].max()) if np.any(self.owner == face) else 0.0
                         for face in range(self.faces)])


def _datum_stage(source: DatumSource) -> Stage:
    """The Stage of a datum: its points on their faces' surfaces extended past the edges (ISO
    5459's unlimited ideal feature; a datum of several faces associated as one), the faces'
    rasters standing for what its geometry could fix."""
    closers = [FaceCloser(face, bounded=False) for face in source.faces]
    nodes = [dense_nodes(closer) for closer in closers]
    surface = (np.concatenate([points for points, _ in nodes]), np.concatenate([normals for _, normals in nodes]))
    if len(closers) == 1:
        return Stage(source.datum.label, source.name, source.datum.criterion, source.points, closers[0], surface)

    def closest(where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        feet, normals = np.empty_like(where), np.empty_like(where)
        for index, closer in enumerate(closers):
            rows = source.owner == index
            if rows.any():
                feet[rows], normals[rows] = closer(where[rows])
        return feet, normals

    return Stage(source.datum.label, source.name, source.datum.criterion, source.points, closest, surface)


def _aligned(points: np.ndarray, closest: Closest, alignment: str, locked: tuple[str, ...], start: np.ndarray | None,
             offset: float, stages: list[Stage], progress: Progress | None,
             linear: bool, location_free: bool = False) -> tuple[Alignment, Frame | None]:
    """(Alignment, Frame) of the toleranced points: on the datum stages where there are any
    (location_free: they fix orientation only), else the floating fit of :func:`align` (its
    Frame, the one link of its solution, only where ``linear``: the Monte Carlo needs it; else
    None)."""
    toleranced = Stage("", "toleranced", alignment, points, closest)
    if stages:
        frame = align_on_datums(stages, toleranced, np.eye(4) if start is None else start, locked, offset,
                                location_free)
        return frame.alignment, frame
    try:
        found = align(points, closest, alignment, locked, start, offset,
                      None if progress is None else lambda step: cast(Progress, progress)(None))
    except AlignmentCancelled:
        raise InspectionCancelled from None
    return found, floating_frame(toleranced, found, locked, offset) if linear else None


def _face_forms(points: np.ndarray, owner: np.ndarray, closers: Sequence[FaceCloser | None], names: list[str],
                found: Alignment, locked: tuple[str, ...], offset: float, notes: list[str]) -> dict[str, float | None]:
    """{face name: its form profile, mm}: each face's points aligned alone (the same method and
    locked motions, from the part's alignment), the profile 2 max |d - offset| of that fit; None
    where a face's points cannot be aligned alone (too few for the motions they hold), the reason
    in notes."""
    forms: dict[str, float | None] = {}
    for index in sorted(set(owner.tolist())):
        rows = np.flatnonzero(owner == index)

        def closest(where: np.ndarray, rows: np.ndarray = rows) -> tuple[np.ndarray, np.ndarray]:
            return _closest(closers, owner[rows], where)

        try:
            alone = align(points[rows], closest, found.method, locked, found.matrix, offset)
        except InputError as exc:
            forms[names[index]] = None
            notes.append(f"{names[index]} has no form profile of its own: {exc}")
            continue
        forms[names[index]] = 2.0 * float(np.abs(alone.deviations - offset).max())
    return forms


def rebuild(inspection: Inspection, result: SamplingResult, planned_rows: np.ndarray) -> None:
    """The paper's step: the substitute fitted to the aligned measured points at their planned
    (u, v) in the result's space, and its exact deviation from the CAD face, into inspection."""
    poles = result.space.fit(result.uv[planned_rows], inspection.points)
    inspection.substitute_poles, inspection.space = poles, result.space
    if result.problem is not None:
        inspection.substitute_deviation = result.problem.deviation(poles)


def _planned(source: object, part: Part.Shape | None) -> Planned:
    """The Planned of a face, a SamplingResult, a PartPlan (with its part), a Planned or a document
    object whose Proxy has planned(obj)."""
    if isinstance(source, Planned):
        return source
    method = getattr(getattr(source, "Proxy", None), "planned", None)
    if callable(method):
        return method(source)
    if isinstance(source, SamplingResult):
        labels = PointSet.from_result(source).labels
        return Planned(labels, source.points, [source.face], ["face"], np.zeros(source.n, dtype=int))
    if isinstance(source, PartPlan):
        if part is None:
            raise InputError("a plan is inspected on its part: give part=<the part's shape> (e.g. obj.Shape)")
        point_set = as_point_set(source)
        names = [face.name for face in source.placed]
        faces = [_face_of(part, name) for name in names]
        owner = np.array([names.index(name) for name in point_set.faces])
        return Planned(point_set.labels, point_set.points, faces, names, owner)
    if isinstance(source, Part.Face) or isinstance(source, Part.Shape):
        return Planned(None, None, [as_face(source)], ["face"], None)
    raise InputTypeError(f"cannot inspect against a {type(source).__name__}; give a Part.Face, a SamplingResult, "
                         "a PartPlan or the workbench's probe points in a document")


def planned_face(planned: Planned, name: str) -> int | None:
    """The index of face ``name`` among the planned faces: its own name, or the one name of the
    form '<object>:<name>' (a plan in a document names its faces 'Block:Face1'); None if none."""
    if name in planned.names:
        return planned.names.index(name)
    ends = [index for index, planned_name in enumerate(planned.names) if planned_name.split(":")[-1] == name]
    return ends[0] if len(ends) == 1 else None


def _datum_face(datum: Datum, planned: Planned, part: Part.Shape | None) -> Part.Face:
    """The Part.Face of a datum that brings its own points: its face given, a face of the plan
    by name, or of part=; InputError where none is found."""
    if not isinstance(datum.face, str):
        return as_face(datum.face)
    index = planned_face(planned, datum.face)
    if index is not None:
        return planned.faces[index]
    if part is None:
        raise InputError(f"datum {datum.label}: {datum.face} is no face of the plan; give part= the shape it is a "
                         "face of, or the Part.Face itself")
    return _face_of(part, datum.face)


def _datum_point_set(datum: Datum) -> PointSet:
    """A datum's own points as a PointSet: a path or PointSet as measured, an (M, 3) array of
    contact points (mm) labelled by order."""
    if isinstance(datum.points, (str, bytes, os.PathLike, PointSet)):
        return _measured_point_set(datum.points)
    points = np.asarray(datum.points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or not len(points):
        raise InputError(f"datum {datum.label}: points= takes an (M, 3) array of contact points in mm, a PointSet "
                         f"or a measured-points file, got shape {points.shape}")
    return PointSet([f"{datum.label}{index}" for index in range(1, len(points) + 1)], points,
                    np.full_like(points, np.nan))


def _face_of(part: Part.Shape, name: str) -> Part.Face:
    """The face ``name`` ('Face3') of the plan's part; InputError where the part has none."""
    try:
        return part.getElement(name)
    except Exception:
        raise InputError(f"the part given has no {name}: give part= the shape the plan was made of") from None


def _measured_point_set(measured: str | os.PathLike | PointSet) -> PointSet:
    """The PointSet of ``measured``: a file's path (str, pathlib.Path) read by read_measured, or
    points already in hand (a PointSet); InputTypeError naming what was given otherwise."""
    if isinstance(measured, (str, bytes, os.PathLike)):
        return read_measured(measured)
    try:
        return as_point_set(measured)
    except InputTypeError:
        raise InputTypeError(f"measured= takes the path of a measured-points file (a str or pathlib.Path) or a "
                             f"PointSet, got {type(measured).__name__}") from None


def _contact_points(point_set: PointSet, probe_radius: float | None) -> np.ndarray:
    """The measured contact points (N, 3) mm: ball centres moved back by the probe radius along
    their vectors (probe_radius mm, else the radius the file states, except for DMIS actuals,
    which a CMM reports as contact points already; 0 for contact points)."""
    actual = point_set.metadata.get("dmis_features") == "actual"
    if probe_radius is not None:
        radius = check_real("probe_radius", probe_radius, minimum=0.0)
    else:
        radius = 0.0 if actual else stated_radius(point_set)
    points = np.asarray(point_set.points, dtype=float)
    normals = np.asarray(point_set.normals, dtype=float)
    if radius > 0 and not np.isfinite(normals).all():
        raise InputError(f"the measured points are ball centres (probe radius {radius:g} mm) but carry no vectors "
                         "to take the radius off along; give contact points, or the file with i, j, k")
    if not np.isfinite(points).all():
        row = int(np.flatnonzero(~np.isfinite(points).all(axis=1))[0])
        raise InputError(f"measured point {point_set.labels[row]} has no finite coordinates; measure it again or "
                         "leave it out of the file")
    check_extent(points, point_set.labels)
    return points - radius * np.nan_to_num(normals)


def pair(planned: Planned, measured: PointSet) -> tuple[tuple[np.ndarray, np.ndarray], list[str]]:
    """((measured rows, planned rows), notes): the measured points paired with the planned ones
    by label (as DMIS, regardless of case) where the measured labels are planned ones, else by
    order when the counts agree; labels a file did not give (P1..PN by order, metadata
    ``labels: by order``) pair by order only.
    InputError for a label given twice, a measured label not planned (when the others pair by
    label), or counts that differ with labels that do not pair."""
    labels = list(measured.labels)
    seen = set()
    for label in labels:
        if label.casefold() in seen:
            raise InputError(f"measured point {label} is given twice; keep one measurement per point")
        seen.add(label.casefold())
    if planned.labels is None:
        rows = np.arange(len(labels))
        return (rows, rows), []
    where = {label.casefold(): index for index, label in enumerate(planned.labels)}
    known = [label.casefold() in where for label in labels]
    if measured.metadata.get("labels") != "by order" and any(known):
        if not all(known):
            stranger = labels[known.index(False)]
            raise InputError(f"measured point {stranger} was not planned (planned: {planned.labels[0]} .. "
                             f"{planned.labels[-1]}); correct its label or leave it out")
        measured_names = {label.casefold() for label in labels}
        missing = [label for label in planned.labels if label.casefold() not in measured_names]
        notes = [f"{len(missing)} planned points were not measured: {', '.join(missing[:8])}"
                 f"{' ...' if len(missing) > 8 else ''}"] if missing else []
        return (np.arange(len(labels)), np.array([where[label.casefold()] for label in labels])), notes
    if len(labels) != len(planned.labels):
        raise InputError(f"the {len(labels)} measured points carry no planned label and there are "
                         f"{len(planned.labels)} planned points, so they cannot be paired by order; "
                         "label them as planned (e.g. P1) or measure every planned point")
    rows = np.arange(len(labels))
    why = ("the file has no labels" if measured.metadata.get("labels") == "by order"
           else "the measured labels are not the planned ones")
    return (rows, rows), [f"paired by order: {why}"]


def _closest_on_edges(closers: Sequence[FaceCloser | None], owner: np.ndarray,
                      points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Feet (N, 3) mm, the directions the distances grow in (N, 3: the outward normals, or from
    an edge, FaceCloser.edges) and on_edge (N,) bool of points (N, 3) on their own faces
    (closers: a FaceCloser per face, None for a face without points; owner (N,) the face of each
    point)."""
    feet, normals, on_edge = np.empty_like(points), np.empty_like(points), np.zeros(len(points), dtype=bool)
    for index, closer in enumerate(closers):
        rows = np.flatnonzero(owner == index)
        if rows.size:
            assert closer is not None   # a face with points has its FaceCloser
            feet[rows], normals[rows], on_edge[rows] = closer.edges(points[rows])
    return feet, normals, on_edge


def _closest(closers: Sequence[FaceCloser | None], owner: np.ndarray,
             points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Feet (N, 3) mm and outward normals (N, 3) of points (N, 3) on their own faces, as
    :func:`_closest_on_edges` finds them."""
    feet, normals, _ = _closest_on_edges(closers, owner, points)
    return feet, normals
