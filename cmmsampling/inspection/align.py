"""Aligning measured points to the CAD model: a rigid motion (measured -> CAD) found by least
squares or by min-max of the point-to-surface distances, some degrees of freedom locked.

A measured point p, moved by the rotation R about the points' centroid c and the shift t, lands
at q = R (p - c) + c + t. Its deviation is the signed distance d = n . (q - f) from f, its
closest point on the CAD face, along the face's outward normal n there (+ out of the material).
For a small further motion (rotation vector w about c, shift s) the deviation changes to first
order by ((q - c) x n) . w + n . s: the point-to-plane linearisation of ICP, solved for (w, s)
and iterated with exact closest points until the motion stops.

* ``best_fit``: minimises sum d^2 (Levenberg-Marquardt on the point-to-plane model);
* ``min_max``: minimises max |d| (Chebyshev), each step a linear programme (scipy's HiGHS) on
  the same model inside a trust region, started from the best fit;
* ``none``: the points are taken as they are (already in the part's frame).

Degrees of freedom: x, y, z (shifts) and rx, ry, rz (rotations about the centroid's axes);
``locked`` names those held fixed (each step holds them; steps about two axes compose to a
rotation about the third of their product's order, below 1e-4 rad for a degree's misplacement). Pure numpy/scipy: the closest points come from a callable.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from ..geometry.validation import InputError

DEGREES_OF_FREEDOM = ("rx", "ry", "rz", "x", "y", "z")
ALIGNMENTS = ("none", "best_fit", "min_max")
# Iterations stop once a step moves no point by more than this (mm), or after MAX_ITERATIONS.
STEP_TOLERANCE_MM = 1e-7
MAX_ITERATIONS = 200
# The least-squares damping (a multiple of the normal matrix's diagonal): its range, and how it
# falls after a step that lowers the sum of squares and rises after one that does not.
DAMPING = (1e-9, 1e9)
DAMPING_FALL = 0.3
DAMPING_RISE = 10.0
# A step taken with at most this damping (nearly a Gauss-Newton step) ends the search where it is
# tiny or lowers the sum of squares by less than COST_TOLERANCE of it. The damping of a motion
# the points hardly constrain (sliding along a plane) is at least SCALE_FLOOR of the largest.
CONVERGED_DAMPING = 1e-6
COST_TOLERANCE = 1e-12
# The search ends too where a Gauss-Newton step would lower the sum of squares by no more than
# COST_TOLERANCE of it plus GAIN_FLOOR_MM2 (mm^2): at the bottom of a flat valley (a blade the
# points may slide along a little), where rounding alone decides whether a step lowers the sum.
GAIN_FLOOR_MM2 = 1e-18
SCALE_FLOOR = 1e-6
# The min-max programme's trust region: the largest rotation (rad) and shift (mm) of one step,
# shrunk by TRUST_SHRINK where a step does not lower the largest deviation.
TRUST_ROTATION = 0.02
TRUST_SHIFT_MM = 1.0
TRUST_SHRINK = 0.25


@dataclass
class Alignment:
    """A rigid motion measured -> CAD and how it was found.

    matrix: (4, 4) homogeneous transform applied to measured points (mm); method: one of
    ALIGNMENTS; locked: the degrees of freedom held fixed; iterations: steps taken;
    moved_mm: the largest distance the motion moved a measured point; deviations: (N,) mm, the
    signed distances of the aligned points from the face (+ out of the material).
    """

    matrix: np.ndarray
    method: str
    locked: tuple
    iterations: int
    moved_mm: float
    deviations: np.ndarray

    def apply(self, points):
        """points (N, 3) mm moved by the alignment: (N, 3) mm."""
        return transform(self.matrix, points)


def transform(matrix, points):
    """points (N, 3) mm moved by a (4, 4) homogeneous transform: (N, 3) mm."""
    points = np.asarray(points, dtype=float)
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def rotation_matrix(vector):
    """The rotation by the rotation vector ``vector`` (3,) rad (axis times angle): (3, 3)."""
    angle = float(np.linalg.norm(vector))
    if angle == 0.0:
        return np.eye(3)
    x, y, z = np.asarray(vector, dtype=float) / angle
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross


def check_locked(locked):
    """The locked degrees of freedom as a tuple; InputError naming an unknown one (all six
    locked leaves the points as they are, as alignment 'none' does)."""
    locked = tuple(locked or ())
    unknown = [name for name in locked if name not in DEGREES_OF_FREEDOM]
    if unknown:
        raise InputError(f"locked: {unknown[0]!r} is no degree of freedom; choose from "
                         f"{', '.join(DEGREES_OF_FREEDOM)}")
    return locked


def align(points, closest, method="best_fit", locked=()):
    """The Alignment of measured points to the face that ``closest`` measures.

    points: (N, 3) mm, measured contact points; closest: callable (M, 3) mm -> (feet (M, 3) mm,
    outward unit normals (M, 3)) on the CAD face, for the points in order; method: one of
    ALIGNMENTS; locked: degrees of freedom (DEGREES_OF_FREEDOM) held fixed.
    """
    if method not in ALIGNMENTS:
        raise InputError(f"alignment must be one of {', '.join(ALIGNMENTS)}, got {method!r}")
    locked = check_locked(locked)
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if not len(points):
        raise InputError("there are no measured points to align; give the file or PointSet of the measurement")
    free = [index for index, name in enumerate(DEGREES_OF_FREEDOM) if name not in locked]
    needed = 3 if method == "best_fit" else 4
    if method != "none" and len(points) < max(needed, len(free)):
        raise InputError(f"{len(points)} measured points cannot fix {len(free)} degrees of freedom; measure at "
                         f"least {max(needed, len(free))} points or lock some (locked=...)")
    matrix, iterations = np.eye(4), 0
    if method != "none" and free:
        matrix, iterations = _least_squares(points, closest, free)
        if method == "min_max":
            matrix, more = _min_max(points, closest, free, matrix)
            iterations += more
    moved = transform(matrix, points)
    feet, normals = closest(moved)
    return Alignment(matrix, method, locked, iterations, float(np.linalg.norm(moved - points, axis=1).max()),
                     signed_distances(moved, feet, normals))


def signed_distances(points, feet, normals):
    """d = n . (p - f): (N,) mm for points, their feet and the outward normals there, (N, 3)."""
    return np.einsum("ij,ij->i", points - feet, normals)


def _model(points, closest, free):
    """The point-to-plane model at points (N, 3) mm: (deviations (N,) mm, Jacobian (N, F) of
    the deviations by the free degrees of freedom, centroid (3,) mm)."""
    feet, normals = closest(points)
    centre = points.mean(axis=0)
    jacobian = np.hstack([np.cross(points - centre, normals), normals])[:, free]
    return signed_distances(points, feet, normals), jacobian, centre


def _step_matrix(step, free, centre):
    """(4, 4): the motion by ``step`` (F,) over the free degrees of freedom, rotation about centre."""
    full = np.zeros(6)
    full[free] = step
    rotation = rotation_matrix(full[:3])
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    matrix[:3, 3] = centre - rotation @ centre + full[3:]
    return matrix


def _least_squares(points, closest, free):
    """Levenberg-Marquardt on sum d^2 (Gauss-Newton steps, damped where a step would not lower
    the sum, so that a weakly constrained motion, e.g. sliding along a nearly flat face, cannot
    make it oscillate), ended where a Gauss-Newton step could gain nothing: (matrix (4, 4),
    iterations)."""
    matrix, damping = np.eye(4), DAMPING[0]
    deviations, jacobian, centre = _model(points, closest, free)
    cost = float(deviations @ deviations)
    for iteration in range(1, MAX_ITERATIONS + 1):
        normal = jacobian.T @ jacobian
        scale = np.maximum(np.diag(normal), SCALE_FLOOR * np.diag(normal).max() + np.finfo(float).tiny)
        gradient = jacobian.T @ deviations
        if gradient @ np.linalg.solve(normal + DAMPING[0] * np.diag(scale), gradient) <= (
                COST_TOLERANCE * cost + GAIN_FLOOR_MM2):
            return matrix, iteration - 1
        step = np.linalg.solve(normal + damping * np.diag(scale), -gradient)
        motion = _step_matrix(step, free, centre)
        moved = transform(matrix, points)
        trial = motion @ matrix
        trial_deviations, trial_jacobian, trial_centre = _model(transform(trial, points), closest, free)
        trial_cost = float(trial_deviations @ trial_deviations)
        small = np.linalg.norm(transform(motion, moved) - moved, axis=1).max() < STEP_TOLERANCE_MM
        if trial_cost <= cost:
            if damping <= CONVERGED_DAMPING and (small or cost - trial_cost <= COST_TOLERANCE * cost):
                return trial, iteration
            matrix, cost, damping = trial, trial_cost, max(damping * DAMPING_FALL, DAMPING[0])
            deviations, jacobian, centre = trial_deviations, trial_jacobian, trial_centre
        elif damping >= DAMPING[1]:
            return matrix, iteration
        else:
            damping = min(damping * DAMPING_RISE, DAMPING[1])
    return matrix, MAX_ITERATIONS


def _min_max(points, closest, free, matrix):
    """Sequential linear programmes on max |d| from ``matrix``: (matrix (4, 4), iterations)."""
    radius = np.array([TRUST_ROTATION if DEGREES_OF_FREEDOM[i].startswith("r") else TRUST_SHIFT_MM for i in free])
    deviations, jacobian, centre = _model(transform(matrix, points), closest, free)
    worst = np.abs(deviations).max()
    for iteration in range(1, MAX_ITERATIONS + 1):
        step = _chebyshev_step(deviations, jacobian, radius)
        motion = _step_matrix(step, free, centre)
        before = transform(matrix, points)
        trial = motion @ matrix
        trial_deviations, trial_jacobian, trial_centre = _model(transform(trial, points), closest, free)
        if np.abs(trial_deviations).max() < worst:
            matrix, worst = trial, np.abs(trial_deviations).max()
            deviations, jacobian, centre = trial_deviations, trial_jacobian, trial_centre
        else:
            radius *= TRUST_SHRINK
        if np.linalg.norm(transform(motion, before) - before, axis=1).max() < STEP_TOLERANCE_MM:
            return matrix, iteration
    return matrix, MAX_ITERATIONS


def _chebyshev_step(deviations, jacobian, radius):
    """The step x (F,) within |x| <= radius minimising max |d + J x| (a linear programme in
    (x, s): minimise s with -s <= d + J x <= s)."""
    count, size = jacobian.shape
    cost = np.zeros(size + 1)
    cost[-1] = 1.0
    ones = np.ones((count, 1))
    upper = np.vstack([np.hstack([jacobian, -ones]), np.hstack([-jacobian, -ones])])
    bound = np.concatenate([-deviations, deviations])
    limits = [(-r, r) for r in radius] + [(0, None)]
    solved = linprog(cost, A_ub=upper, b_ub=bound, bounds=limits, method="highs")
    if not solved.success:
        return np.zeros(size)
    return solved.x[:size]
