"""A series' error from inspections: the series model of one face and a part's error map.

The numbers are cmmsampling.fitting.series's (kriging of one part; the series' systematic error
and scatter); this module finds each inspection's points on the face and their parameters.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..fitting.exact import NearestParameters
from ..fitting.series import SeriesModel, error_map
from ..geometry.validation import InputError, InputTypeError
from ..strategies.face_setup import setup_of

if TYPE_CHECKING:   # FreeCAD ships no type stubs
    import Part


class Inspected(Protocol):
    """What the series reads of an inspection (cmmsampling.inspection.result.Inspection, which
    imports this module): faces, the face's name of each of its N points (None: one face);
    points (N, 3) mm, aligned to the CAD model; deviations (N,) mm, signed."""

    faces: list | None
    points: np.ndarray
    deviations: np.ndarray


def face_rows(inspection: Inspected, name: str | None = None) -> tuple[np.ndarray, str]:
    """(rows (M,) int, the face's name) of an inspection's points on the face called ``name``
    (None: the inspection's only face; InputError when it has several)."""
    names = list(dict.fromkeys(inspection.faces or [""]))
    if name is None:
        if len(names) > 1:
            raise InputError(f"the inspection covers faces {', '.join(names)}: name the face, e.g. name={names[0]!r}")
        name = names[0]
    rows = np.flatnonzero(np.asarray(inspection.faces or [""] * len(inspection.deviations)) == name)
    if not rows.size:
        raise InputError(f"the inspection has no points on {name!r}; its faces are {', '.join(names)}")
    return rows, name


def nearest_parameters(face: Part.Face) -> NearestParameters:
    """The NearestParameters (cmmsampling.fitting.exact) of ``face`` (a Part.Face): points (M, 3)
    mm -> the parameters (M, 2) of their closest points on it, inside its trim."""
    setup = setup_of(face)
    return NearestParameters(setup.model, setup.domain().on_face if setup.model.trimmed else None)


def measured_parameters(face: Part.Face, inspection: Inspected, name: str | None = None,
                        nearest: NearestParameters | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(uv (M, 2) on face, signed deviations (M,) mm) of the inspection's points on ``face`` (a
    Part.Face; name: the face's name in the inspection, None for its only face; nearest: the
    face's :func:`nearest_parameters` where already built)."""
    rows, _ = face_rows(inspection, name)
    if nearest is None:
        nearest = nearest_parameters(face)
    return nearest(inspection.points[rows]), inspection.deviations[rows]


def series_model(face: Part.Face, prior: Sequence[Inspected] | SeriesModel, name: str | None = None) -> SeriesModel:
    """The series model of ``face`` (a Part.Face) from the inspections of earlier parts.

    prior: a list of Inspections (cmmsampling.inspect), at least one, each with points on the
    face (name: its name in them, None where each covers that face only). Returns a SeriesModel
    (cmmsampling.fitting.series): ``systematic(uv)``, ``predict(uv, deviations, query)``; it is
    what ``sample(face, n, 'part_error', prior=...)`` and ``Inspection.deviation_map`` take.
    """
    return _series_model(face, prior, name)


def _series_model(face: Part.Face, prior: Sequence[Inspected] | SeriesModel, name: str | None,
                  nearest: NearestParameters | None = None) -> SeriesModel:
    """:func:`series_model`, with the face's :func:`nearest_parameters` where already built."""
    if isinstance(prior, SeriesModel):
        return prior
    parts = list(prior) if isinstance(prior, (list, tuple)) else None
    if not parts:
        raise InputTypeError("prior takes a list of Inspections of earlier parts (cmmsampling.inspect), at least one")
    if nearest is None:
        nearest = nearest_parameters(face)
    return SeriesModel(nearest.model, [measured_parameters(face, inspection, name, nearest) for inspection in parts])


def deviation_map(inspection: Inspected, face: Part.Face, uv: np.ndarray,
                  prior: Sequence[Inspected] | SeriesModel | None = None, name: str | None = None) -> np.ndarray:
    """The measured part's signed deviation from the CAD face at uv (M, 2) of its parameter
    range: (M,) mm, from the inspection's points on ``face`` alone (prior None: kriging,
    cmmsampling.fitting.series.fit_field) or with the series model of ``prior`` (a list of
    earlier parts' Inspections or a SeriesModel: its posterior mean)."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    nearest = nearest_parameters(face)
    measured, deviations = measured_parameters(face, inspection, name, nearest)
    if prior is None:
        return error_map(nearest.model, measured, deviations, uv)
    return _series_model(face, prior, name, nearest).predict(measured, deviations, uv)[0]
