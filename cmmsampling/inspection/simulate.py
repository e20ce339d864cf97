"""A virtual CMM: the file a CMM would write after measuring planned probe points on a real part.

The real part departs from the CAD model by a smooth form error (a sum of a few waves across the
points' extent, ``form_error`` mm at most) and lies misplaced on the table (rotated and shifted
about the points' centroid); the probe touches each planned point's surface along its approach
vector and reads it with a random error (``noise`` mm, standard deviation, along the normal).
The file holds the nominal points and the touched (actual) ones in the part's nominal frame as
the CMM sees it: DMIS output (``F(label)`` nominals and ``FA(label)`` actuals) or the project's CSV
(the actual points with the nominal vectors).
"""
from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..formats.exporting import as_point_set, export
from ..formats.files import write_atomically
from ..formats.pointset import PointSet
from ..formats.registry import FileFormat, measured_records
from ..geometry.validation import InputError, check_real
from ..strategies.face_setup import setup_of
from .align import rotation_matrix, transform

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

# The form error's waves: their number and wavelengths as fractions of the points' extent.
WAVES = 3
WAVELENGTHS = (0.6, 1.4)


@dataclass
class Misplacement:
    """How the part lies on the table: rotations (deg) about the x, y and z axes through the
    points' centroid, then a shift (mm)."""

    rx: float = 0.0
    ry: float = 0.0
    rz: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0

    def matrix(self, centre: np.ndarray) -> np.ndarray:
        """(4, 4) the motion nominal -> table about centre (3,) mm."""
        angles = np.radians([self.rx, self.ry, self.rz])
        rotation = rotation_matrix([0.0, 0.0, angles[2]]) @ rotation_matrix([0.0, angles[1], 0.0]) \
            @ rotation_matrix([angles[0], 0.0, 0.0])
        matrix = np.eye(4)
        matrix[:3, :3] = rotation
        matrix[:3, 3] = centre - rotation @ centre + [self.x, self.y, self.z]
        return matrix


@dataclass
class SimulatedMeasurement:
    """What the virtual CMM did: path: the file written; labels: N; nominal: (N, 3) mm; actual:
    (N, 3) mm as written; form: (N,) mm, the form error at each point (+ out of the material);
    misplacement: (4, 4), nominal -> table."""

    path: str
    labels: list
    nominal: np.ndarray
    actual: np.ndarray
    form: np.ndarray
    misplacement: np.ndarray


def form_field(points: np.ndarray, amplitude: float, seed: int = 0) -> np.ndarray:
    """A smooth form error at points (N, 3) mm: (N,) mm within +-amplitude, a sum of WAVES plane
    waves across the points' extent with random directions, lengths and phases (seeded)."""
    return form_waves(points, amplitude, seed)(points)


def form_waves(points: np.ndarray, amplitude: float, seed: int = 0) -> Callable[[np.ndarray], np.ndarray]:
    """The form error of :func:`form_field` as a function of any points (M, 3) mm -> (M,) mm, its
    waves sized by the extent of points (N, 3) mm."""
    points = np.asarray(points, dtype=float)
    rng = np.random.default_rng(seed)
    extent = float(np.ptp(points, axis=0).max()) or 1.0
    directions = rng.normal(size=(WAVES, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    lengths = extent * rng.uniform(*WAVELENGTHS, WAVES)
    phases = rng.uniform(0, 2 * np.pi, WAVES)

    def waves(where: np.ndarray) -> np.ndarray:
        where = np.asarray(where, dtype=float).reshape(-1, 3)
        if amplitude == 0:
            return np.zeros(len(where))
        return amplitude * np.sin(2 * np.pi * (where @ directions.T) / lengths + phases).sum(axis=1) / WAVES

    return waves


def _measured_format(path: str | os.PathLike) -> FileFormat:
    """The FileFormat (registered, ``measured``) a measurement is written in, by path's extension;
    InputError naming those there are."""
    extension = os.path.splitext(os.fspath(path))[1].lower()
    records = measured_records()
    found = [record for record in records if extension in record.extensions]
    if not found:
        kinds = " or ".join(f"{record.title} ({', '.join(record.extensions)})" for record in records)
        raise InputError(f"{path}: a measurement is written as {kinds}")
    return found[0]


def simulate_measurement(source: object, path: str | os.PathLike, *, form_error: float = 0.0, noise: float = 0.0,
                         misplacement: Misplacement | dict[str, float] | None = None,
                         seed: int = 0) -> SimulatedMeasurement:
    """Measure the planned points of ``source`` on a virtual part and write what the CMM reports.

    source: a SamplingResult, PartPlan, PointSet or probe-points object (the nominal points and
    their approach vectors); path: the file, in a format a measurement is read back from
    (DMIS output: .dmi, .dmis, .dmo, .dms; CSV: .csv; cmmsampling.formats.registry.measured_records);
    form_error: mm, the largest form error; noise: mm, the probing error's standard deviation;
    misplacement: a Misplacement, or a dict of its fields (deg and mm); seed: the random form
    error's and noise's seed. Returns a SimulatedMeasurement.
    """
    record = _measured_format(path)
    form_error = check_real("form_error", form_error, minimum=0.0)
    noise = check_real("noise", noise, minimum=0.0)
    placed = misplacement if isinstance(misplacement, Misplacement) else Misplacement(**(misplacement or {}))
    nominal = as_point_set(source)
    form = form_field(nominal.points, form_error, seed)
    touched = nominal.points + (form + np.random.default_rng(seed + 1).normal(0.0, 1.0, len(form)) * noise
                                )[:, None] * nominal.normals
    matrix = placed.matrix(nominal.points.mean(axis=0))
    actual = transform(matrix, touched)
    if record.write_measured is not None:
        text = record.write_measured(nominal, actual, os.path.splitext(os.path.basename(path))[0])
        write_atomically(path, text, record.encoding)
    else:
        export(replace(nominal, points=actual, uv=None, deviation=None, travel=None), path)
    return SimulatedMeasurement(os.fspath(path), list(nominal.labels), nominal.points, actual, form, matrix)


# The errors a series of parts may carry (simulated_series): a smooth wave across the face, a
# bump near one of its edges (a worn tool's), a twist; each part's sizes scatter about the
# series' by SIZE_SPREAD (relative), its face is offset and tilted by SETUP_SPREAD times the size.
SERIES_KINDS = ("wave", "edge_bump", "twist")
SIZE_SPREAD = 0.2
SETUP_SPREAD = 0.15
BUMP_WIDTH = 0.12


@dataclass
class SeriesPart:
    """One simulated part of a series on a face: ``error(uv)`` its true signed deviation from
    the CAD face at uv (M, 2) in the face's parameter range, mm (+ out of the material)."""

    kind: str
    sizes: np.ndarray
    setup: np.ndarray
    lower: np.ndarray
    span: np.ndarray

    def error(self, uv: np.ndarray) -> np.ndarray:
        """(M,) mm at uv (M, 2)."""
        s, t = ((np.asarray(uv, float).reshape(-1, 2) - self.lower) / self.span).T
        shapes = {"wave": np.sin(2 * np.pi * (0.9 * s + 0.4 * t) + 0.5) * np.cos(np.pi * (t - 0.3)),
                  "edge_bump": np.exp(-((s - 0.92) ** 2 + (t - 0.55) ** 2) / (2 * BUMP_WIDTH ** 2)),
                  "twist": 4.0 * (s - 0.5) * (t - 0.5)}
        kinds = SERIES_KINDS if self.kind == "all" else (self.kind,)
        field = sum(size * shapes[kind] for size, kind in zip(self.sizes, kinds))
        return field + self.setup[0] + self.setup[1] * (s - 0.5) + self.setup[2] * (t - 0.5)


def simulated_series(face: Part.Face, count: int, kind: str = "all", size: float = 0.02,
                     seed: int = 0) -> list[SeriesPart]:
    """``count`` SeriesParts of a series on face (a Part.Face): error kind one of SERIES_KINDS
    or 'all' (their sum), of ``size`` mm (each part's sizes scattered by SIZE_SPREAD), each part
    offset and tilted (SETUP_SPREAD x size, standard deviation); seeded."""
    if kind != "all" and kind not in SERIES_KINDS:
        raise InputError(f"kind must be one of {', '.join(SERIES_KINDS)} or 'all', got {kind!r}")
    u0, u1, v0, v1 = face.ParameterRange
    rng = np.random.default_rng(seed)
    kinds = len(SERIES_KINDS) if kind == "all" else 1
    return [SeriesPart(kind, size * (1.0 + SIZE_SPREAD * rng.standard_normal(kinds)),
                       SETUP_SPREAD * size * rng.standard_normal(3), np.array([u0, v0]), np.array([u1 - u0, v1 - v0]))
            for _ in range(count)]


def measured_part(face: Part.Face, uv: np.ndarray, part: SeriesPart, noise: float = 0.0,
                  seed: int = 0) -> PointSet:
    """What a CMM reads on ``part`` (a SeriesPart) at the face's parameters uv (M, 2): a PointSet
    of contact points, the face's points moved by the part's error along its normals plus a
    probing error (``noise`` mm, standard deviation), with the face's normals."""
    uv = np.asarray(uv, float).reshape(-1, 2)
    model = setup_of(face).model
    points, normals = model.points(uv), model.normals(uv)
    touched = part.error(uv) + noise * np.random.default_rng(seed).standard_normal(len(uv))
    return PointSet([f"P{i + 1}" for i in range(len(uv))], points + touched[:, None] * normals, normals)
