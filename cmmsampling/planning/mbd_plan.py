"""A QIF MBD model's inspection planned from its own tolerances (``plan(read_mbd(path))``).

Every characteristic the model states and this tool judges (``Characteristic.judged``) is
planned: its faces get the points their tolerance asks (a face several characteristics share
gets the smallest of their tolerances: :func:`cmmsampling.planning.part_plan.plan` with a
tolerance per face), and the faces of the datums its reference frame names get points spread to
hold every motion each can fix (:func:`cmmsampling.planning.datum_points.plan_datums`), since a
model's characteristics use several frames (A|B|C, D|B|C, A alone ...). The datum points come
first in the plan and so in its program; one plan, one program, one probe path. A judged
characteristic that cannot be planned (a datum with no face on the part, a datum the probe
cannot reach, a face without points) is listed with the reason (``unplanned``), never dropped.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from ..access.probe import Probe
from ..formats.dmis_datums import datum_feature
from ..formats.pointset import PointSet
from ..geometry.validation import InputError
from .datum_points import DatumPoints, plan_datums
from .part_plan import PartPlan, plan, with_datums
from .plan_points import share_orientations


@dataclass
class ModelCharacteristics:
    """What a plan of a QIF MBD model judges: model (cmmsampling.formats.qif.model.MbdModel);
    characteristics: the judged characteristics planned; unplanned: (Characteristic, why) for
    judged ones that could not be; datum_faces: {label: its faces (FaceN)} of the datums the
    planned characteristics name; program_frame: {label: its faces} of the datum reference frame
    a program sets its frame on (:func:`program_frame`), primary first ({} for none)."""

    model: Any = None
    characteristics: list = field(default_factory=list)
    unplanned: list = field(default_factory=list)
    datum_faces: dict = field(default_factory=dict)
    program_frame: dict = field(default_factory=dict)

    def stated(self) -> dict[str, str]:
        """{id: 'Flatness 0.2 mm on Face36'} each characteristic planned: kind, tolerance, datums
        and faces."""
        return {c.id: f"{c.kind} {c.tolerance:.6g} mm" + (f" to {'|'.join(c.datums)}" if c.datums else "")
                + f" on {' '.join(c.faces)}" for c in self.characteristics}

    def not_planned(self) -> list[str]:
        """One line per characteristic of the model this plan does not judge, and why: the
        kinds this tool does not judge, then the judged ones that could not be planned."""
        return self.model.not_judged() + [f"{c.id} {c.name or c.kind} ({c.kind}): {why}" for c, why in self.unplanned]


@dataclass
class MbdPlan(ModelCharacteristics, PartPlan):
    """The plan of a QIF MBD model: a PartPlan of its faces (the datum-only faces first, each
    with its datum's label; ``face_tolerances`` each face's) with what it judges
    (ModelCharacteristics: the model, the characteristics planned and not, the datums' faces)."""

    def point_set(self) -> PointSet:
        """The plan's points (PartPlan.point_set), the model's file and each planned
        characteristic (its id, kind, tolerance, datums and faces) in its metadata."""
        points = super().point_set()
        metadata = {**points.metadata, "mbd": self.model.path, "characteristics": self.stated(),
                    "datum_faces": {label: list(faces) for label, faces in self.datum_faces.items()}}
        if self.program_frame:
            metadata["datums"] = {label: list(faces) for label, faces in self.program_frame.items()}
        return replace(points, metadata=metadata)

    def table(self) -> str:
        """The characteristics planned (id, kind, tolerance, datums, faces, points), then those not
        planned, then the part plan's table."""
        counts = {face.name: face.n for face in self.faces}
        lines = [f"{'id':>6} {'kind':<18} {'tol mm':>8} {'datums':<8} {'points':>6}  faces"]
        lines += [f"{c.id:>6} {c.kind:<18} {c.tolerance:>8.4g} {'|'.join(c.datums) or '-':<8} "
                  f"{sum(counts.get(name, 0) for name in c.faces):>6}  {' '.join(c.faces)}"
                  for c in self.characteristics]
        lines += [f"not judged: {line}" for line in self.not_planned()]
        return "\n".join(lines + [super().table()])


def plan_mbd(model: Any, strategy: str, *, probe: Probe | None = None, edge_offset: float | None = None,
             progress: Callable | None = None, **options: Any) -> MbdPlan:
    """The MbdPlan of a QIF MBD model (cmmsampling.read_mbd): each judged characteristic's faces
    to its own tolerance, its datums' faces spread to hold the frames (see the module's doc);
    strategy, probe, edge_offset, progress and options (n_max, processes, scheduler, the
    strategy's arguments) as :func:`cmmsampling.planning.part_plan.plan` takes them.
    InputError where no judged characteristic can be planned."""
    shape = model.shape
    unplanned: list[tuple[Any, str]] = []
    datum_points: dict[str, DatumPoints | str] = {}
    wanted = [c for c in model.judged() if _plannable(c, model, unplanned)]
    datum_faces = {label: tuple(model.datums[label].faces) for c in wanted for label in c.datums}
    toleranced = {name for c in wanted for name in c.faces}
    for label, faces in sorted(datum_faces.items()):
        for name in faces:
            if name not in toleranced and name not in datum_points:
                datum_points[name] = _datum_plan(label, name, shape, probe, edge_offset)
    refused = {label for label, faces in datum_faces.items()
               if any(isinstance(datum_points.get(name), str) for name in faces)}
    for c in [c for c in wanted if refused & set(c.datums)]:
        wanted.remove(c)
        label = sorted(refused & set(c.datums))[0]
        unplanned.append((c, next(str(datum_points[name]) for name in datum_faces[label]
                                  if isinstance(datum_points.get(name), str))))
    if not wanted:
        raise InputError(f"{model.path}: none of its characteristics can be planned here: "
                         + "; ".join(f"{c.id}: {why}" for c, why in unplanned)
                         if unplanned else f"{model.path}: it states no characteristic this tool judges")
    return _planned(model, wanted, unplanned, datum_points, strategy, probe, edge_offset, progress, options)


def _planned(model: Any, wanted: list, unplanned: list, datum_points: dict, strategy: str, probe: Probe | None,
             edge_offset: float | None, progress: Callable | None, options: dict) -> MbdPlan:
    """The MbdPlan of the characteristics wanted (see plan_mbd), the faces run to their
    tolerances and the datum-only faces' points (datum_points: {face: DatumPoints}) put first."""
    datum_faces = {label: tuple(model.datums[label].faces) for c in wanted for label in c.datums}
    tolerances: dict[str, float] = {}
    for c in wanted:
        for name in c.faces:
            tolerances[name] = min(tolerances.get(name, c.tolerance), c.tolerance)
    numbers = [int(name[4:]) for name in tolerances]
    result = plan(model.shape, tolerance=tolerances, strategy=strategy, faces=numbers, probe=probe,
                  edge_offset=edge_offset, progress=progress, **options)
    kept = [points for _, faces in sorted(datum_faces.items()) for name in faces
            if isinstance(points := datum_points.get(name), DatumPoints)]
    with_datums(result, kept, {points.face: model.shape.getElement(points.face) for points in kept})
    # The model's datums serve several frames: inspect() builds each characteristic's own from
    # the points; a program sets its frame on one of them, its faces measured first.
    result.datums = []
    result.shapes.update({points.face: model.shape.getElement(points.face) for points in kept})
    if not result.cancelled and probe is not None:
        share_orientations(result)
    empty = {face.name: face.reason for face in result.faces if not face.placed}
    stated = {item.name: getattr(result, item.name) for item in fields(PartPlan) if item.init}
    planned = []
    for c in wanted:
        missing = [name for name in c.faces if name in empty]
        missing_datums = [(label, name) for label in c.datums for name in datum_faces[label] if name in empty]
        if missing:
            unplanned.append((c, f"{missing[0]} holds no points: {empty[missing[0]]}"))
        elif missing_datums:
            label, name = missing_datums[0]
            unplanned.append((c, f"datum {label}'s {name} holds no points: {empty[name]}"))
        else:
            planned.append(c)
    if not planned:
        raise InputError(f"{model.path}: none of its characteristics can be planned here: "
                         + "; ".join(f"{c.id}: {why}" for c, why in unplanned))
    frame = program_frame(planned, datum_faces, {face.name: face for face in result.placed})
    order = [name for faces in frame.values() for name in faces]
    stated["faces"] = sorted(result.faces, key=lambda face: order.index(face.name) if face.name in order else len(order))
    return MbdPlan(**stated, model=model, characteristics=planned, unplanned=unplanned, datum_faces=datum_faces,
                   program_frame=frame)


def program_frame(planned: list, datum_faces: dict, placed: dict) -> dict[str, tuple[str, ...]]:
    """{label: its faces} of the datum reference frame a program sets the part's frame on, primary
    first: of the planned characteristics' frames whose datums' faces all hold points (placed:
    {name: FacePlan}), one whose datums are each a plane or a cylinder (a DMIS datum feature),
    then the one of most datums, then the one most characteristics use, then the first; {} where
    none holds points. Every characteristic is still judged on its own frame (inspect builds each)."""
    frames = [tuple(c.datums) for c in planned
              if c.datums and all(name in placed for label in c.datums for name in datum_faces[label])]
    if not frames:
        return {}

    def settable(labels: tuple) -> bool:
        faces = [[placed[name] for name in datum_faces[label]] for label in labels]
        return all(any(part is not None for part in datum_feature(np.concatenate([f.points for f in plans]),
                                                                   np.concatenate([f.normals for f in plans])))
                   for plans in faces)

    chosen = max(frames, key=lambda labels: (settable(labels), len(labels), frames.count(labels),
                                             -frames.index(labels)))
    return {label: tuple(datum_faces[label]) for label in chosen}


def _plannable(c: Any, model: Any, unplanned: list) -> bool:
    """True where characteristic c has faces on the model's shape and every datum it names has
    faces; else (c, why) goes to unplanned."""
    if not c.faces:
        unplanned.append((c, "its faces have no counterpart on the part's shape"))
        return False
    for label in c.datums:
        datum = model.datums.get(label)
        if datum is None or not datum.faces:
            unplanned.append((c, f"datum {label} has no face on the part: its frame cannot be built from points"))
            return False
    return True


def _datum_plan(label: str, name: str, shape: Any, probe: Probe | None,
                edge_offset: float | None) -> DatumPoints | str:
    """The DatumPoints of datum ``label``'s face ``name`` on its own, or why it has none (str,
    naming the datum)."""
    try:
        return plan_datums([(name, shape.getElement(name))], probe, shape if probe is not None else None,
                           edge_offset, labels=[label])[0]
    except InputError as exc:
        return str(exc)
