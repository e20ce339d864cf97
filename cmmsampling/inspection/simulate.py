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
from dataclasses import dataclass, replace

import numpy as np

from ..formats.dmis import DMIS_VERSION, dmis_program_name, dmis_statement
from ..formats.exporting import as_point_set, export
from ..formats.files import write_atomically
from ..formats.text import COORDINATE_DECIMALS, VECTOR_DECIMALS, fixed
from ..geometry.validation import InputError, check_real
from .align import rotation_matrix, transform

# The form error's waves: their number and wavelengths as fractions of the points' extent.
WAVES = 3
WAVELENGTHS = (0.6, 1.4)
FORMATS = {".dmi": "dmis", ".dmis": "dmis", ".csv": "csv"}


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

    def matrix(self, centre):
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


def form_field(points, amplitude, seed=0):
    """A smooth form error at points (N, 3) mm: (N,) mm within +-amplitude, a sum of WAVES plane
    waves across the points' extent with random directions, lengths and phases (seeded)."""
    return form_waves(points, amplitude, seed)(points)


def form_waves(points, amplitude, seed=0):
    """The form error of :func:`form_field` as a function of any points (M, 3) mm -> (M,) mm, its
    waves sized by the extent of points (N, 3) mm."""
    points = np.asarray(points, dtype=float)
    rng = np.random.default_rng(seed)
    extent = float(np.ptp(points, axis=0).max()) or 1.0
    directions = rng.normal(size=(WAVES, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    lengths = extent * rng.uniform(*WAVELENGTHS, WAVES)
    phases = rng.uniform(0, 2 * np.pi, WAVES)

    def waves(where):
        where = np.asarray(where, dtype=float).reshape(-1, 3)
        if amplitude == 0:
            return np.zeros(len(where))
        return amplitude * np.sin(2 * np.pi * (where @ directions.T) / lengths + phases).sum(axis=1) / WAVES

    return waves


def simulate_measurement(source, path, *, form_error=0.0, noise=0.0, misplacement=None, seed=0):
    """Measure the planned points of ``source`` on a virtual part and write what the CMM reports.

    source: a SamplingResult, PartPlan, PointSet or probe-points object (the nominal points and
    their approach vectors); path: the file, DMIS output (.dmi, .dmis) or CSV (.csv);
    form_error: mm, the largest form error; noise: mm, the probing error's standard deviation;
    misplacement: a Misplacement, or a dict of its fields (deg and mm); seed: the random form
    error's and noise's seed. Returns a SimulatedMeasurement.
    """
    extension = os.path.splitext(os.fspath(path))[1].lower()
    if extension not in FORMATS:
        raise InputError(f"{path}: a measurement is written as DMIS output (.dmi, .dmis) or CSV (.csv)")
    form_error = check_real("form_error", form_error, minimum=0.0)
    noise = check_real("noise", noise, minimum=0.0)
    placed = misplacement if isinstance(misplacement, Misplacement) else Misplacement(**(misplacement or {}))
    nominal = as_point_set(source)
    form = form_field(nominal.points, form_error, seed)
    touched = nominal.points + (form + np.random.default_rng(seed + 1).normal(0.0, 1.0, len(form)) * noise
                                )[:, None] * nominal.normals
    matrix = placed.matrix(nominal.points.mean(axis=0))
    actual = transform(matrix, touched)
    if FORMATS[extension] == "dmis":
        write_atomically(path, dmis_output(nominal, actual, os.path.splitext(os.path.basename(path))[0]), "ascii")
    else:
        export(replace(nominal, points=actual, uv=None, deviation=None, travel=None), path)
    return SimulatedMeasurement(os.fspath(path), list(nominal.labels), nominal.points, actual, form, matrix)


def dmis_output(nominal, actual, name):
    """DMIS output text: for each point its nominal F(label)=FEAT/POINT and the measured actual
    FA(label)=FEAT/POINT (with the nominal vector), as a CMM writes them after a run.
    nominal: PointSet; actual: (N, 3) mm; name: the program's name."""
    lines = [f"DMISMN/'{dmis_program_name(name)}',{DMIS_VERSION}", "$$ measured by cmmsampling's virtual CMM",
             "UNITS/MM,ANGDEC"]
    vectors = fixed(nominal.normals, VECTOR_DECIMALS).tolist()
    for label, planned, measured, vector in zip(nominal.labels, fixed(nominal.points, COORDINATE_DECIMALS).tolist(),
                                                fixed(actual, COORDINATE_DECIMALS).tolist(), vectors):
        lines += dmis_statement([f"F({label})=FEAT/POINT", "CART", *planned], vector)
        lines += dmis_statement([f"FA({label})=FEAT/POINT", "CART", *measured], vector)
    lines.append("ENDFIL")
    return "\n".join(lines) + "\n"
