"""A QIF 3.0 MBD model: its shape (built from the file's B-rep, or a STEP file's shape matched
to it) with its characteristics and datums on the shape's faces (FaceN, as FreeCAD names them).

With a shape given (``read_mbd(path, shape=Part.read("part.stp"))``), each face the QIF file
describes is matched to the shape's face it lies on: points inside the QIF face are measured to
every shape face whose box holds them, and the nearest face within MATCH_MM (and within a
thousandth of the face's size) is its counterpart. A model's STEP and QIF files may split faces
differently (several QIF faces then lie on one STEP face) and may be revisions apart: a QIF face
with no counterpart is named in ``unmatched``, and the characteristics keep the faces that have
one.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any


from ...geometry.validation import InputError
from .brep import boxes_holding, build_model, face_boxes, inner_points
from .mbd import Characteristic, CharacteristicList, DatumRecord, parsed_file, records_of

# A QIF face lies on a shape face when its points are this close to it, mm (and within
# MATCH_SHARE of the QIF face's diagonal).
MATCH_MM = 0.01
MATCH_SHARE = 1e-3


@dataclass
class FaceMatch:
    """A QIF face (its id) and the shape faces it lies on (FaceN: one, or several where the
    shape splits it; () for none) with the largest distance of its points to them, mm."""

    face_id: str
    faces: tuple[str, ...]
    distance: float


@dataclass
class MbdModel(CharacteristicList):
    """A QIF MBD model (:func:`read_mbd`): ``shape`` (a Part.Shape), ``characteristics`` (one
    Characteristic per nominal, its ``faces`` the shape's FaceN), ``datums`` (DatumRecord by
    label, with ``faces``), the file's units (``linear``, ``pmi``, ``mm_per_unit``), the QIF id
    of each face the file describes and the shape face it lies on (``matches``; built from the
    file: FaceN in the file's order), ``unmatched``: QIF faces with no counterpart in a given
    shape, and ``failed``: faces of the file that could not be built (QIF id, why)."""

    path: str
    shape: Any
    characteristics: list[Characteristic]
    datums: dict[str, DatumRecord]
    matches: list[FaceMatch]
    linear: str
    pmi: str
    mm_per_unit: dict[str, float] = field(default_factory=dict)
    failed: list[tuple[str, str]] = field(default_factory=list)
    built_from_file: bool = True

    @property
    def unmatched(self) -> list[str]:
        """QIF ids of the faces with no counterpart on the shape."""
        return [match.face_id for match in self.matches if not match.faces]

    def match_report(self) -> str:
        """The face match as lines: the shape's source, faces matched, the largest distance,
        and each QIF face with no counterpart."""
        matched = [m for m in self.matches if m.faces]
        split = sum(len(m.faces) > 1 for m in matched)
        source = "built from the file" if self.built_from_file else "given"
        lines = [f"{self.path}: {len(self.matches)} QIF faces, {len(matched)} on faces of the {source} shape "
                 f"({len(self.shape.Faces)} faces" + (f"; {split} QIF faces span several of them" if split else "")
                 + ")" + (f", at most {max(m.distance for m in matched):.2g} mm from them" if matched else "")]
        lines += [f"QIF face {m.face_id}: no counterpart on the shape (its points lie up to {m.distance:.3g} mm from "
                  f"the shape's faces; the match takes {MATCH_MM} mm)" for m in self.matches if not m.faces]
        return "\n".join(lines)

    def summary(self) -> str:
        """Counts: characteristics judged and not, datums, faces; the units (both where the
        file's are not mm)."""
        units = self.pmi if self.pmi == "mm" else f"{self.pmi}, converted to mm"
        return (f"{len(self.characteristics)} characteristics ({len(self.judged())} judged by this tool), "
                f"{len(self.datums)} datums, {len(self.shape.Faces)} faces; tolerances in {units}")


def read_mbd(path: str, shape: Any = None) -> MbdModel:
    """The QIF 3.0 MBD model at ``path``: its characteristics and datums on the faces of its
    shape, built from the file's B-rep (a valid solid where the file describes one, in mm) or,
    where ``shape`` (a Part.Shape, e.g. the same model read from STEP) is given, on that shape's
    faces, matched geometrically (:class:`FaceMatch`). InputError naming the file and the
    problem, before any work, for a file that is no QIF MBD document."""
    if shape is not None and not getattr(shape, "Faces", None):
        raise InputError(f"shape: a {type(shape).__name__} with no faces; give the model as a Part.Shape, e.g. "
                         "Part.read('part.stp')")
    root = parsed_file(path)
    records = records_of(root, path)
    built = build_model(root, records.mm_per_unit[records.linear], path)
    if shape is None:
        matches = [FaceMatch(ident, (f"Face{k + 1}",), 0.0) for k, ident in enumerate(built.face_ids)]
    else:
        matches = match_faces(built.shape, built.face_ids, shape)
    on_shape = {match.face_id: match.faces for match in matches}

    def faces_of(face_ids):
        names = []
        for ident in face_ids:
            names += [name for name in on_shape.get(ident, ()) if name not in names]
        return tuple(names)

    characteristics = [dataclasses.replace(c, faces=faces_of(c.face_ids)) for c in records.characteristics]
    datums = {label: dataclasses.replace(d, faces=faces_of(d.face_ids)) for label, d in records.datums.items()}
    return MbdModel(path, built.shape if shape is None else shape, characteristics, datums, matches, records.linear,
                    records.pmi, records.mm_per_unit, built.failed, shape is None)


def match_faces(built, face_ids, shape) -> list[FaceMatch]:
    """Each face of ``built`` (a Part.Shape; face_ids: the QIF id of each of its faces) matched
    to the faces of ``shape`` its points lie on (see the module's doc): each point to the
    nearest face whose box holds it; a match where every point lies within the limit."""
    import Part

    targets = shape.Faces
    boxes = face_boxes(targets)
    matches = []
    for ident, face in zip(face_ids, built.Faces):
        limit = min(MATCH_MM, MATCH_SHARE * face.BoundBox.DiagonalLength)
        points = inner_points(face)
        near = [_distances(targets, boxes, point) for point in points]
        worst = max(min(found.values(), default=float("inf")) for found in near)
        if worst <= limit:
            matches.append(FaceMatch(ident, _fewest_faces([{k for k, d in found.items() if d <= limit}
                                                           for found in near]), float(worst)))
        else:
            worst = max(shape.distToShape(Part.Vertex(*point))[0] for point in points)
            matches.append(FaceMatch(ident, (), float(worst)))
    return matches


def _distances(targets, boxes, point) -> dict[int, float]:
    """{k: mm} the distance of point (3,) to each face ``targets[k]`` whose box ((F, 6) boxes)
    holds it within MATCH_MM."""
    import Part

    vertex = Part.Vertex(*point)
    return {int(k): targets[k].distToShape(vertex)[0] for k in boxes_holding(boxes, point, MATCH_MM)}


def _fewest_faces(holding: list[set[int]]) -> tuple[str, ...]:
    """FaceN of the fewest faces that hold every point (holding: per point, the faces it lies
    on; a point on an edge lies on both its faces), the face holding most points first."""
    left, chosen = list(range(len(holding))), []
    while left:
        counts: dict[int, int] = {}
        for point in left:
            for k in holding[point]:
                counts[k] = counts.get(k, 0) + 1
        best = min(counts, key=lambda k: (-counts[k], k))
        chosen.append(best)
        left = [point for point in left if best not in holding[point]]
    return tuple(f"Face{k + 1}" for k in chosen)
