"""Datum reference frames (ISO 5459): the part aligned on its datum features in order, the
toleranced surface then judged in that frame (ISO 1101's profile relative to datums: location
and form together).

Each datum is associated with its nominal face in turn and fixes only the motions the datums
before it leave free: a primary plane fixes three (its normal shift and two tilts), a secondary
plane square to it two, a tertiary one. Which motions a datum fixes is found from its points,
not assumed from its type: the motions left free, as a basis of small rigid motions (twists:
a rotation vector about a fixed pivot and a shift), are split by how strongly they move the
datum's points off its face (the generalised eigenvalues of the point-to-plane normal matrix
against the motions' own size; the weak ones, below motions.WEAK_SENSITIVITY, stay free for
the next datum). A free-form datum surface fixes whatever it holds.

A datum is associated by one of DATUM_CRITERIA: 'tangent' (ISO 5459's default: the face laid
on the outside of the points, as near to them as it goes: min max distance, every point in the
material) or 'least_squares'. Motions no datum fixes are floated by the toleranced surface's
own fit (ISO 1101: the zone is free in them) with the inspection's alignment method, or kept
where the start put them and named. Pure numpy/scipy: the closest points come from callables.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, cast

import numpy as np

from ..formats.pointset import PointSet
from ..geometry.validation import InputError
from ..geometry.motions import split_motions, twist_jacobian
from .align import (DEGREES_OF_FREEDOM, Alignment, Closest, _least_squares, _min_max, _motion_names, _offset_by,
                    _step_matrix, signed_distances, tangent, tangent_choice, tangent_extent, transform)

DATUM_CRITERIA = ("tangent", "least_squares")
# A datum's points spread more than DATUM_FORM_SHARE times the profile tolerance about its
# associated face (DATUM_FORM_MM without a tolerance) are not taken: points of another face, or
# a datum too rough to judge a profile from.
DATUM_FORM_SHARE = 5.0
DATUM_FORM_MM = 1.0
# A tangent datum whose equally good associations (align.TANGENT_TIE_MM) move its points more
# than this (mm RMS) is named not unique: 0.1 um, what a CMM's probing begins to resolve.
ROCKING_MM = 1e-4


@dataclass(frozen=True)
class Datum:
    """A datum feature of a datum reference frame, given in precedence order (primary first).

    label: its letter on the drawing ('A'); face: the name of a face of the plan's part
    ('Face3'), a tuple of such names for a datum feature of several faces (('Face43', 'Face44'):
    a bore's two halves, a pattern of holes, coplanar faces; associated as one feature), or a
    Part.Face; points: where its measured contact points come from: None (the
    measured file's points planned on that face, by label), a measured-points path, a PointSet
    or an (M, 3) array, mm, in the measured frame; criterion: one of DATUM_CRITERIA.
    """

    label: str
    face: str | tuple[str, ...] | object
    points: str | os.PathLike | PointSet | np.ndarray | None = None
    criterion: str = "tangent"


@dataclass
class DatumMeasurement:
    """The points a datum was associated on, as an inspection took them: labels (M,); measured:
    (M, 3) mm, contact points in the measured frame; nominal: (M, 3) mm, where they were planned
    (NaN rows: the datum brought its own points, Datum.points); normals: (M, 3) unit, its face's
    outward normals (the face extended past its edges) at the points' feet once aligned."""

    labels: list
    measured: np.ndarray
    nominal: np.ndarray
    normals: np.ndarray

    @property
    def own(self) -> bool:
        """True where the datum brought its own points (none of them was planned)."""
        return bool(np.isnan(self.nominal).all())

    def as_record(self) -> dict[str, Any]:
        """The points as a JSON-friendly dict (lists; NaN as JSON's NaN, which json reads back)."""
        return {"labels": list(self.labels), **{name: getattr(self, name).tolist()
                                                 for name in ("measured", "nominal", "normals")}}

    @classmethod
    def from_record(cls, record: dict[str, Any]) -> DatumMeasurement:
        """The DatumMeasurement of :meth:`as_record`'s dict."""
        arrays = [np.array(record[name], dtype=float).reshape(-1, 3) for name in ("measured", "nominal", "normals")]
        return cls(list(record["labels"]), *arrays)


@dataclass
class DatumFit:
    """One datum as associated: label; face: its name; criterion; count: its points; held: the
    motions it fixed (0 .. 6); deviations: (M,) mm, its points' signed distances from its face
    in the frame (+ out of the material); form: mm, their spread (max - min); rocking: mm, how
    far the tangent associations as good as the one chosen move its points (0: one only; more
    than ROCKING_MM: not unique, the least squares among them chosen, align.tangent_choice);
    measurement: its points (a DatumMeasurement; None where they were not kept: an inspection
    saved before they were)."""

    label: str
    face: str
    criterion: str
    count: int
    held: int
    deviations: np.ndarray
    rocking: float = 0.0
    measurement: DatumMeasurement | None = field(default=None, repr=False)

    @property
    def form(self) -> float:
        """mm, the spread of the datum's points about its associated face."""
        return float(self.deviations.max() - self.deviations.min())

    def as_record(self) -> dict[str, Any]:
        """The fit as a JSON-friendly dict."""
        return {"label": self.label, "face": self.face, "criterion": self.criterion, "count": self.count,
                "held": self.held, "deviations": [float(value) for value in self.deviations],
                "measurement": None if self.measurement is None else self.measurement.as_record()}

    @classmethod
    def from_record(cls, record: dict[str, Any]) -> DatumFit:
        """The DatumFit of :meth:`as_record`'s dict (one saved without its points: measurement None)."""
        measurement = record.get("measurement")
        return cls(**cast("dict[str, Any]", {**record, "deviations": np.array(record["deviations"], dtype=float),
                                             "measurement": None if measurement is None
                                             else DatumMeasurement.from_record(measurement)}))

    def text(self) -> str:
        """'A (Face1, tangent, 3 motions, 12 points, form 0.0012 mm)'."""
        rocking = (f", not unique: tangent solutions {1000 * self.rocking:.2f} um apart, the least squares among "
                   "them taken" if self.rocking > ROCKING_MM else "")
        return (f"{self.label} ({self.face}, {self.criterion.replace('_', ' ')}, {self.held} motion"
                f"{'' if self.held == 1 else 's'}, {self.count} points, form {self.form:.4f} mm{rocking})")


@dataclass
class Stage:
    """Points aligned in one step of a frame: label and face (names), criterion (one of
    DATUM_CRITERIA, or an alignment method for the toleranced surface), points (M, 3) mm
    (measured), closest: callable (M, 3) -> (feet, outward normals), each (M, 3); surface:
    (points (K, 3) mm, outward normals (K, 3)) spread over the nominal face in the CAD frame,
    from which the motions its geometry could fix are found (None: from its points alone)."""

    label: str
    face: str
    criterion: str
    points: np.ndarray
    closest: Closest
    surface: tuple[np.ndarray, np.ndarray] | None = None


@dataclass
class Link:
    """A step of the frame as the linear model at its solution sees it, for the Monte Carlo:
    rows: the step's rows in all the points; jacobian: (M, 6) the deviations' change per twist
    (rotation vector rad about the pivot, shift mm); held: (6, H) the twists the step fitted;
    criterion: how (DATUM_CRITERIA, 'best_fit', 'min_max', or 'none' for no fit); deviations:
    (M,) mm at the solution, from the zone's centre."""

    rows: np.ndarray
    jacobian: np.ndarray
    held: np.ndarray
    criterion: str
    deviations: np.ndarray


@dataclass
class Frame:
    """A datum reference frame found: alignment (of the toleranced points: its matrix maps the
    measured frame to the CAD one), datums: a DatumFit each, links: the Links of every step
    (datums, then the toleranced surface)."""

    alignment: Alignment
    datums: list
    links: list


def free_twists(locked: Sequence[str]) -> np.ndarray:
    """(6, K): the unit twists of the degrees of freedom not locked (DEGREES_OF_FREEDOM order)."""
    return np.eye(6)[:, [index for index, name in enumerate(DEGREES_OF_FREEDOM) if name not in locked]]


def motion_names(twists: np.ndarray, length: float) -> tuple[str, ...]:
    """The names of the motions twists (6, K) span (align._motion_names: 'x', 'rz', 'slide
    along (...)'), rotations weighed by length mm, the points' RMS distance from the pivot."""
    if not twists.shape[1]:
        return ()
    scaled = twists * np.r_[np.full(3, length), np.ones(3)][:, None]
    return _motion_names(np.linalg.svd(scaled, full_matrices=False)[0][:, :twists.shape[1]])


def align_on_datums(datums: Sequence[Stage], toleranced: Stage, start: np.ndarray, locked: Sequence[str] = (),
                    offset: float = 0.0, location_free: bool = False) -> Frame:
    """The Frame of the Stages ``datums`` (precedence order) and of ``toleranced`` (the
    toleranced surface's Stage, its criterion the inspection's alignment method), from the
    motion start (4, 4) measured -> CAD; locked: degrees of freedom no step moves; offset: mm,
    the toleranced zone's centre from its face (+ out of the material); location_free: the
    datums fix orientation only (ISO 1101's orientation tolerances): the toleranced surface's
    fit floats every shift not locked as well as the turns the datums leave free.
    InputError for a datum that fixes nothing the ones before it left free, or has fewer points
    than the motions it fixes."""
    matrix = np.asarray(start, dtype=float)
    pivot = transform(matrix, toleranced.points).mean(axis=0)
    allowed = free_twists(locked)
    fits, links, first = [], [], 0
    for stage in datums:
        moved = transform(matrix, stage.points)
        held, weak = split_motions(moved, stage.closest(moved)[1], allowed, pivot)
        could = split_motions(*stage.surface, allowed, pivot)[0] if stage.surface is not None else held
        _check_datum(stage, held.shape[1], could)
        fit = tangent if stage.criterion == "tangent" else _least_squares
        matrix, rocking = fit(stage.points, stage.closest, held, matrix, pivot)[0], 0.0
        if stage.criterion == "tangent":
            matrix, rocking = _tangent_chosen(stage, matrix, held, pivot)
        link = _link(stage, matrix, held, pivot, first)
        fits.append(DatumFit(stage.label, stage.face, stage.criterion, len(stage.points), held.shape[1],
                             link.deviations, rocking))
        links.append(link)
        first, allowed = first + len(stage.points), weak
    if location_free:
        allowed = with_shifts(allowed, locked)
    zone = _offset_by(toleranced.closest, offset)
    moved = transform(matrix, toleranced.points)
    held, weak = (split_motions(moved, zone(moved)[1], allowed, pivot) if toleranced.criterion != "none"
                  else (allowed[:, :0], allowed))
    iterations = 0
    if held.shape[1]:
        matrix, iterations, _ = _least_squares(toleranced.points, zone, held, matrix, pivot)
        if toleranced.criterion == "min_max":
            matrix, more, _ = _min_max(toleranced.points, zone, held, matrix, pivot)
            iterations += more
    last = _link(replace(toleranced, closest=zone), matrix, held, pivot, first)
    moved = transform(matrix, toleranced.points)
    length = float(np.sqrt(((moved - pivot) ** 2).sum(axis=1).mean())) or 1.0
    alignment = Alignment(matrix, toleranced.criterion, tuple(locked), iterations,
                          float(np.linalg.norm(moved - toleranced.points, axis=1).max()),
                          last.deviations + offset, motion_names(weak, length), False)
    return Frame(alignment, fits, links + [last])


def with_shifts(twists: np.ndarray, locked: Sequence[str] = ()) -> np.ndarray:
    """(6, K') an orthonormal basis of the span of twists (6, K) and the shifts not locked."""
    shifts = free_twists(locked)[:, [name in DEGREES_OF_FREEDOM[3:] for name in DEGREES_OF_FREEDOM
                                     if name not in locked]]
    basis, weights, _ = np.linalg.svd(np.hstack([twists, shifts]), full_matrices=False)
    return basis[:, weights > 1e-9]


def _tangent_chosen(stage: Stage, matrix: np.ndarray, held: np.ndarray,
                    pivot: np.ndarray) -> tuple[np.ndarray, float]:
    """(matrix (4, 4), rocking mm): a tangent datum's association ``matrix`` moved to the least
    squares among the tangent solutions on its linear model (exact for a plane), and how far
    those solutions move its points (align.tangent_extent)."""
    link = _link(stage, matrix, held, pivot, 0)
    jacobian = link.jacobian @ held
    step = tangent_choice(link.deviations, jacobian)
    return _step_matrix(step, held, pivot) @ matrix, tangent_extent(link.deviations, jacobian)


def _check_datum(stage: Stage, held: int, could: np.ndarray) -> None:
    """InputError where a datum's face fixes none of the motions left free (could (6, C): those
    its geometry could fix), where it has fewer points than those motions (a plane 3 as primary,
    a cylinder 4), or where its points fix fewer of them than its face could (points on one line
    of a plane): the next datum would take over motions this one should fix."""
    count, needed = len(stage.points), could.shape[1]
    if needed == 0:
        raise InputError(f"datum {stage.label} ({stage.face}) fixes none of the motions the datums before it leave "
                         "free; give another face as this datum or leave it out")
    if count < needed:
        raise InputError(f"datum {stage.label} ({stage.face}) has {count} measured point{'s' * (count != 1)}; its "
                         f"face fixes {needed} motions the datums before it leave free: measure at least {needed} "
                         "points on it")
    if held < needed:
        raise InputError(f"datum {stage.label} ({stage.face}): its {count} points fix {held} of the {needed} motions "
                         "its face fixes; spread them over the face (not along one line)")


def check_datum_forms(fits: Sequence[DatumFit], tolerance: float | None) -> None:
    """InputError naming the first datum whose points spread (DatumFit.form, mm) more than
    DATUM_FORM_SHARE times the profile tolerance (mm; None: DATUM_FORM_MM) about its face."""
    limit = DATUM_FORM_MM if tolerance is None else DATUM_FORM_SHARE * tolerance
    for fit in fits:
        if fit.form > limit:
            bound = (f"{DATUM_FORM_SHARE:g} times the tolerance, {limit:g} mm" if tolerance is not None
                     else f"{limit:g} mm, the limit without a tolerance")
            raise InputError(f"datum {fit.label} ({fit.face}): its {fit.count} points spread {fit.form:.4g} mm about "
                             f"the associated face, more than {bound}; are they points of another face? measure the "
                             "datum again or name its face")


def _link(stage: Stage, matrix: np.ndarray, held: np.ndarray, pivot: np.ndarray, first: int) -> Link:
    """The Link of a stage solved to ``matrix`` (its rows from ``first`` in all the points)."""
    moved = transform(matrix, stage.points)
    feet, normals = stage.closest(moved)
    return Link(np.arange(first, first + len(moved)), twist_jacobian(moved, normals, pivot), held, stage.criterion,
                signed_distances(moved, feet, normals))


def as_datums(datums: Datum | str | Sequence[Datum | str] | None) -> tuple[Datum, ...]:
    """The Datums of inspect()'s datums=: None or () for none, a Datum or a face name ('Face3')
    or a sequence of them in precedence order (names become tangent datums A, B, C ...).
    InputError for an unknown criterion or a label given twice."""
    if datums is None:
        return ()
    if isinstance(datums, (str, Datum)):
        datums = (datums,)
    found = tuple(datum if isinstance(datum, Datum) else Datum(chr(ord("A") + index), datum)
                  for index, datum in enumerate(datums))
    for datum in found:
        if datum.criterion not in DATUM_CRITERIA:
            raise InputError(f"datum {datum.label}: criterion must be one of {', '.join(DATUM_CRITERIA)}, "
                             f"got {datum.criterion!r}")
    labels = [datum.label for datum in found]
    twice = [label for label in labels if labels.count(label) > 1]
    if twice:
        raise InputError(f"datum {twice[0]} is given twice; give each datum feature once, primary first")
    return found


def floating_frame(toleranced: Stage, alignment: Alignment, locked: Sequence[str] = (),
                   offset: float = 0.0) -> Frame:
    """The Frame of a fit with no datums: the toleranced Stage aligned alone (an Alignment from
    align.align), its one Link the linear model at that solution."""
    zone = _offset_by(toleranced.closest, offset)
    moved = alignment.apply(toleranced.points)
    pivot = moved.mean(axis=0)
    allowed = free_twists(locked)
    held = (split_motions(moved, zone(moved)[1], allowed, pivot)[0] if alignment.method != "none"
            else allowed[:, :0])
    stage = replace(toleranced, criterion=alignment.method, closest=zone)
    return Frame(alignment, [], [_link(stage, alignment.matrix, held, pivot, 0)])
