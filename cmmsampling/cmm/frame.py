"""The datum reference frame of a run until decided: its datum faces are measured first, and the
face is judged in their frame (ISO 5459, ISO 1101: the profile is then location and form).

Each datum face gets the points a plan gives it (:func:`cmmsampling.planning.datum_points.
plan_datums`: spread to hold the motions it fixes in its place of the frame), unless the datum
brings its own measured points (``Datum(..., points=...)``). The motions the frame leaves free
(none for a full A | B | C frame of planes) are the only ones the belief floats; the measured
points are brought into the frame by cmmsampling.inspect's association of the datums.
"""
from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np

from ..access.probe import Probe
from ..access.reach import Access
from ..formats.pointset import PointSet
from ..geometry.motions import split_motions, twist_jacobian
from ..geometry.surface import as_face
from ..geometry.validation import InputError
from ..inspection.datums import Datum, as_datums
from ..planning.datum_points import DatumPoints, plan_datums

# The label of a datum's k-th point (from 1) in the run's file: 'DA1', 'DA2', ... for datum A.
DATUM_PREFIX = "D"


@dataclass
class RunFrame:
    """A run's datum reference frame: datums (in precedence order, each face a Part.Face),
    planned (each datum's DatumPoints: its points measured first where it brings none, and the
    motions it fixes), own (per datum: whether it brought its own points), free (6, k) the
    twists about pivot (3,) mm the frame leaves free (rotation vector, shift)."""

    datums: tuple[Datum, ...]
    planned: list[DatumPoints]
    own: list[bool]
    free: np.ndarray
    pivot: np.ndarray

    @functools.cached_property
    def lead(self) -> PointSet:
        """The points the run measures first: each datum's that brings none, labelled 'DA1' ..."""
        chosen = [(datum, points) for datum, points, own in zip(self.datums, self.planned, self.own) if not own]
        labels = [f"{DATUM_PREFIX}{datum.label}{k}" for datum, points in chosen
                  for k in range(1, len(points.points) + 1)]
        stacked = [points for _, points in chosen]
        return PointSet(labels, np.vstack([p.points for p in stacked] or [np.empty((0, 3))]),
                        np.vstack([p.normals for p in stacked] or [np.empty((0, 3))]))

    def axes(self) -> np.ndarray:
        """(D, 3) unit: the probe's axis at each of :attr:`lead`'s points (NaN without a probe)."""
        rows = [np.full((len(points.points), 3), np.nan) if points.access is None
                else np.asarray(cast(Access, points.access).axes)
                for points, own in zip(self.planned, self.own) if not own]
        return np.vstack(rows or [np.empty((0, 3))])

    def motions(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(M, k): the deviation of points (M, 3) mm with outward normals (M, 3) per unit of each
        motion the frame leaves free."""
        return twist_jacobian(points, normals, self.pivot) @ self.free

    def measured(self, measured: PointSet) -> tuple[PointSet, tuple[Datum, ...]]:
        """(the toleranced face's points of a run's measured PointSet, the datums with their
        points: those measured in the run, by label, or their own)."""
        labels = list(measured.labels)
        taken = [label.startswith(DATUM_PREFIX) for label in labels]
        datums = []
        for datum, own in zip(self.datums, self.own):
            if own:
                datums.append(datum)
                continue
            rows = [k for k, label in enumerate(labels) if label.startswith(f"{DATUM_PREFIX}{datum.label}")]
            if not rows:
                raise InputError(f"datum {datum.label} has no measured points: the run ended before its face was "
                                 "measured")
            datums.append(replace(datum, points=PointSet([labels[k] for k in rows], measured.points[rows],
                                                         measured.normals[rows])))
        kept = [k for k, datum in enumerate(taken) if not datum]
        toleranced = PointSet([labels[k] for k in kept], measured.points[kept], measured.normals[kept],
                              metadata=dict(measured.metadata))
        return toleranced, tuple(datums)


def run_frame(datums: Sequence[Datum | str | Any] | None, part: Any, probe: Probe | None,
              pivot: np.ndarray) -> RunFrame | None:
    """The RunFrame of datums= (Datums, or faces: Part.Faces or names of part's faces, labelled
    A, B, C in order; None or empty: no frame), their points planned with the probe on the part
    where both are given; pivot: (3,) mm the free twists are taken about. InputError naming a
    datum whose face cannot be found or that fixes nothing new."""
    if not datums:
        return None
    given = [datum if isinstance(datum, (Datum, str)) else Datum(chr(ord("A") + k), as_face(datum))
             for k, datum in enumerate(datums)]
    found = tuple(replace(datum, face=_datum_face(datum, part)) for datum in as_datums(given))
    named = [(_name(datum, given[k]), datum.face) for k, datum in enumerate(found)]
    planned = plan_datums(named, probe if part is not None else None, part)
    free = np.eye(6)
    for points in planned:
        free = split_motions(points.points, points.normals, free, pivot)[1]
    return RunFrame(found, planned, [datum.points is not None for datum in found], free, np.asarray(pivot, float))


def _name(datum: Datum, given: Datum | str) -> str:
    """The name a datum's face goes by in messages: the face's name where given by name, else
    'datum A'."""
    face = given.face if isinstance(given, Datum) else given
    return face if isinstance(face, str) else f"datum {datum.label}"


def _datum_face(datum: Datum, part: Any) -> Any:
    """The Part.Face of a datum: its face given, or part's face of that name."""
    if not isinstance(datum.face, str):
        return as_face(datum.face)
    if part is None:
        raise InputError(f"datum {datum.label}: {datum.face} names a face of the part; give part= the solid, or the "
                         "Part.Face itself")
    try:
        return part.getElement(datum.face)
    except Exception:
        raise InputError(f"datum {datum.label}: the part has no {datum.face}") from None
