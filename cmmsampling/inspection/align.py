"""Aligning measured points to the CAD model: a rigid motion (measured -> CAD) found by least
squares or by min-max of the point-to-surface distances, some degrees of freedom locked.

A measured point p, moved by the rotation R about the points' centroid c and the shift t, lands
at q = R (p - c) + c + t. Its deviation is the signed distance d = n . (q - f) from f, its
closest point on the CAD face, along the face's outward normal n there (+ out of the material).
For a small further motion (rotation vector w about c, shift s) the deviation changes to first
order by ((q - c) x n) . w + n . s: the point-to-plane linearisation of ICP, solved for (w, s)
and iterated with exact closest points until the motion stops.

* ``min_max`` (the default): minimises max |d| (Chebyshev), each step a linear programme
  (scipy's HiGHS) on the same model inside a trust region, started from the best fit: the
  minimum zone by which ISO 1101 judges the form profile of a surface without datums;
* ``best_fit``: minimises sum d^2 (Levenberg-Marquardt on the point-to-plane model); its
  profile is never narrower than the minimum zone's (up to a third wider was seen);
* ``none``: the points are taken as they are (already in the part's frame).

Degrees of freedom: x, y, z (shifts) and rx, ry, rz (rotations about the centroid's axes);
``locked`` names those held fixed (each step holds them; steps about two axes compose to a
rotation about the third of their product's order, below 1e-4 rad for a degree's misplacement).

The fit starts from ``start`` (the labelled points' rigid match to their nominals, Kabsch's
solution: :func:`kabsch`), so a part put on the table anywhere is judged as one put exactly. The
motions the points hardly hold (:func:`held_motions`: a plane's turn about its normal and its two
slides, a cylinder's axis, a blade's slide) are not fitted at all: they stay where the start put
them, and the Alignment names them (``free_motions``); before, the fit let the points slide along
them until the sum of squares could not tell (a blade's 36 exact points slid 0.98 mm). Pure
numpy/scipy: the closest points come from a callable.
"""
from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog, nnls

from ..geometry.motions import WEAK_SENSITIVITY, twist_jacobian
from ..geometry.validation import InputError

# closest(points (M, 3) mm) -> (feet (M, 3) mm, outward unit normals (M, 3)) on a CAD face.
Closest = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
DEGREES_OF_FREEDOM = ("rx", "ry", "rz", "x", "y", "z")
ALIGNMENTS = ("none", "best_fit", "min_max")
# What each alignment's profile is, in the summary's words.
PROFILE_KINDS = {"min_max": "minimum zone, ISO 1101",
                 "best_fit": "after a least-squares fit, not ISO 1101's minimum zone",
                 "none": "as measured, no alignment"}
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
# A degree of freedom (rx .. z) is named free where at most this share of it (by length, in mm
# of motion) lies outside the weakly held motions.
NAMED_SHARE = 0.1
# The min-max programme's trust region: the largest step (mm of the points' motion) along each
# held motion, shrunk by TRUST_SHRINK where a step does not lower the largest deviation.
TRUST_SHIFT_MM = 1.0
TRUST_SHRINK = 0.25
# A tangent datum's fit weighs a point left out of the material this many times its distance.
TANGENT_PENALTY = 10.0
# Tangent associations whose largest distance is within TANGENT_TIE_MM (mm) of the least, every
# point in the material (to ROUNDING_MM), are all tangent solutions: ISO 5459's criterion does not
# choose among them (a plane rocking on two points in line with its deepest one). 10 nm, far below
# what a CMM resolves, and far above what a micrometre of probing error across the plane does to
# the largest distance of a plane rocking on a line (its deepest point off the line by 1 um, the
# plane turned by 1e-4 rad: 1e-7 mm), so that a family of tangent planes stays one family whatever
# the points' errors along the face.
TANGENT_TIE_MM = 1e-5
ROUNDING_MM = 1e-9


@dataclass
class Alignment:
    """A rigid motion measured -> CAD and how it was found.

    matrix: (4, 4) homogeneous transform applied to measured points (mm); method: one of
    ALIGNMENTS; locked: the degrees of freedom held fixed; iterations: steps taken;
    moved_mm: the largest distance the motion moved a measured point; deviations: (N,) mm, the
    signed distances of the aligned points from the face (+ out of the material); free_motions:
    the motions the points do not hold, kept where the start put them (:func:`held_motions`);
    capped: the fit ran into MAX_ITERATIONS without settling.
    """

    matrix: np.ndarray
    method: str
    locked: tuple
    iterations: int
    moved_mm: float
    deviations: np.ndarray
    free_motions: tuple = ()
    capped: bool = False

    def apply(self, points: np.ndarray) -> np.ndarray:
        """points (N, 3) mm moved by the alignment: (N, 3) mm."""
        return transform(self.matrix, points)


def transform(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """points (N, 3) mm moved by a (4, 4) homogeneous transform: (N, 3) mm."""
    points = np.asarray(points, dtype=float)
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def rotation_matrix(vector: np.ndarray | Sequence[float]) -> np.ndarray:
    """The rotation by the rotation vector ``vector`` (3,) rad (axis times angle): (3, 3)."""
    angle = float(np.linalg.norm(vector))
    if angle == 0.0:
        return np.eye(3)
    x, y, z = np.asarray(vector, dtype=float) / angle
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross


def check_locked(locked: Sequence[str] | None) -> tuple[str, ...]:
    """The locked degrees of freedom as a tuple; InputError naming an unknown one (all six
    locked leaves the points as they are, as alignment 'none' does)."""
    locked = tuple(locked or ())
    unknown = [name for name in locked if name not in DEGREES_OF_FREEDOM]
    if unknown:
        raise InputError(f"locked: {unknown[0]!r} is no degree of freedom; choose from "
                         f"{', '.join(DEGREES_OF_FREEDOM)}")
    return locked


class AlignmentCancelled(Exception):
    """The progress callback asked the alignment to stop."""


def align(points: np.ndarray, closest: Closest, method: str = "min_max", locked: Sequence[str] = (),
          start: np.ndarray | None = None, offset: float = 0.0,
          progress: Callable[[int], bool | None] | None = None) -> Alignment:
    """The Alignment of measured points to the face that ``closest`` measures.

    points: (N, 3) mm, measured contact points; closest: callable (M, 3) mm -> (feet (M, 3) mm,
    outward unit normals (M, 3)) on the CAD face, for the points in order; method: one of
    ALIGNMENTS; locked: degrees of freedom (DEGREES_OF_FREEDOM) held fixed; start: (4, 4) the
    motion the fit starts from (None: none), where the motions the points do not hold stay;
    offset: mm, the zone's centre from the face (+ out of the material), which the fit centres
    the points on (ISO 1101's UZ: the zone the verdict uses is the one fitted); progress:
    callable(step) after each step of the fit, returning True to stop it (AlignmentCancelled).
    InputError where the points leave nothing to judge: no more of them than the motions they hold.
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
    matrix = np.eye(4) if start is None or method == "none" else np.asarray(start, dtype=float)
    free_motions: tuple[str, ...]
    iterations, free_motions, capped = 0, (), False
    if method != "none" and free:
        basis, free_motions = held_motions(transform(matrix, points), closest, free)
        _check_redundancy(len(points), basis.shape[1], free_motions, method)
        if basis.shape[1]:
            zone = _offset_by(_asking(closest, progress), offset)
            matrix, iterations, capped = _least_squares(points, zone, basis, matrix)
            if method == "min_max":
                matrix, more, capped = _min_max(points, zone, basis, matrix)
                iterations += more
    moved = transform(matrix, points)
    feet, normals = closest(moved)
    return Alignment(matrix, method, locked, iterations, float(np.linalg.norm(moved - points, axis=1).max()),
                     signed_distances(moved, feet, normals), free_motions, capped)


def _asking(closest: Closest, progress: Callable[[int], bool | None] | None) -> Closest:
    """``closest`` that calls progress(step) before each of its passes (one a step of the fit)
    and raises AlignmentCancelled where it returns True."""
    if progress is None:
        return closest
    passes = itertools.count(1)

    def asked(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        assert progress is not None   # the closure is made only for a progress callback
        if progress(next(passes)):
            raise AlignmentCancelled
        return closest(points)

    return asked


def _offset_by(closest: Closest, offset: float) -> Closest:
    """``closest`` with the feet moved by ``offset`` mm along the normals: the signed distances
    become d - offset, measured from the zone's centre."""
    if offset == 0:
        return closest

    def shifted(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        feet, normals = closest(points)
        return feet + offset * normals, normals

    return shifted


def kabsch(points: np.ndarray, targets: np.ndarray) -> np.ndarray | None:
    """(4, 4) the rigid motion that takes points (N, 3) mm nearest to targets (N, 3) mm in least
    squares (Kabsch's solution; for targets on a line, the least turn that lays the points' line
    on theirs), or None where the targets fix none (fewer than two, or all at one place)."""
    points, targets = np.asarray(points, dtype=float), np.asarray(targets, dtype=float)
    if len(points) < 2 or not np.isfinite(targets).all():
        return None
    centre, target_centre = points.mean(axis=0), targets.mean(axis=0)
    spread = np.linalg.svd(targets - target_centre, compute_uv=False)
    if spread[0] == 0.0:
        return None
    if len(points) < 3 or spread[1] <= 1e-6 * spread[0]:
        turn = _line_turn(points - centre, targets - target_centre)
    else:
        u, _, vt = np.linalg.svd((points - centre).T @ (targets - target_centre))
        turn = vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = turn, target_centre - turn @ centre
    return matrix


def _line_turn(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """(3, 3) the least rotation taking the main direction of points (N, 3) (centred) to that of
    targets (N, 3) (centred), the two directions signed alike along the points' order."""
    first = np.linalg.svd(points, full_matrices=False)[2][0]
    second = np.linalg.svd(targets, full_matrices=False)[2][0]
    second = second if (points @ first) @ (targets @ second) >= 0 else -second
    axis, cosine = np.cross(first, second), float(np.clip(first @ second, -1.0, 1.0))
    if np.linalg.norm(axis) < 1e-12:
        if cosine > 0:
            return np.eye(3)
        axis = np.cross(first, np.eye(3)[np.argmin(np.abs(first))])
    return rotation_matrix(axis / np.linalg.norm(axis) * np.arccos(cosine))


def held_motions(points: np.ndarray, closest: Closest, free: list[int]) -> tuple[np.ndarray, tuple[str, ...]]:
    """(basis (6, H), free_motions): the motions the points (N, 3) mm hold, as columns over the
    six degrees of freedom (a unit of each moves the points about 1 mm RMS), and the names of
    those they do not (fewer than WEAK_SENSITIVITY mm of RMS deviation per mm of motion, from the
    eigenvalues of the point-to-plane normal matrix over the ``free`` degrees of freedom): a
    degree of freedom lying in them by its name (e.g. ('rz', 'x', 'y') for a plane z = const),
    others as 'turn about (a, b, c)' or 'slide along (a, b, c)', in the part's axes."""
    _, jacobian, centre = _model(points, closest, np.eye(6)[:, free])
    length = float(np.sqrt(((points - centre) ** 2).sum(axis=1).mean())) or 1.0
    scale = np.r_[np.full(3, 1.0 / length), np.ones(3)][free]
    jacobian = jacobian * scale
    values, vectors = np.linalg.eigh(jacobian.T @ jacobian / len(points))
    weak = np.sqrt(np.maximum(values, 0.0)) < WEAK_SENSITIVITY
    basis = np.zeros((6, int((~weak).sum())))
    basis[free] = scale[:, None] * vectors[:, ~weak]
    weak_vectors = np.zeros((6, int(weak.sum())))
    weak_vectors[free] = vectors[:, weak]
    return basis, _motion_names(weak_vectors)


def _motion_names(weak: np.ndarray) -> tuple[str, ...]:
    """The names of the weakly held motions, weak (6, K) orthonormal columns (rotations scaled
    to mm): the degrees of freedom that lie in them, then the rest described by direction."""
    names, named = [], []
    for index, name in enumerate(DEGREES_OF_FREEDOM):
        unit = np.eye(6)[index]
        if weak.shape[1] and np.linalg.norm(unit - weak @ (weak.T @ unit)) <= NAMED_SHARE:
            names.append(name)
            named.append(weak @ (weak.T @ unit))
    left = weak.shape[1] - len(names)
    if left > 0:
        rest = weak if not named else weak - np.column_stack(named) @ np.linalg.lstsq(
            np.column_stack(named), weak, rcond=None)[0]
        for vector in np.linalg.svd(rest, full_matrices=False)[0][:, :left].T:
            turn, slide = vector[:3], vector[3:]
            turning = np.linalg.norm(turn) >= np.linalg.norm(slide)
            axis, word = (turn, "turn about") if turning else (slide, "slide along")
            axis = axis / np.linalg.norm(axis) * np.sign(axis[np.argmax(np.abs(axis))])
            names.append(f"{word} ({', '.join(f'{c:.2f}' for c in axis + 0.0)})")
    return tuple(names)


def _check_redundancy(count: int, held: int, free_motions: tuple[str, ...], method: str) -> None:
    """InputError where ``count`` points leave nothing to judge once they have fixed the ``held``
    motions (min-max needs one more point: its zone is set by held + 1 of them)."""
    needed = held + (2 if method == "min_max" else 1)
    if count < needed:
        weak = f" (the others, {', '.join(free_motions)}, they do not hold)" if free_motions else ""
        raise InputError(f"{count} measured points fix the {held} motions they hold{weak} with none to spare, so "
                         f"any part would pass; measure at least {needed} points, or lock motions (locked=...)")


def signed_distances(points: np.ndarray, feet: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """d = n . (p - f): (N,) mm for points, their feet and the outward normals there, (N, 3)."""
    return np.einsum("ij,ij->i", points - feet, normals)


def _model(points: np.ndarray, closest: Closest, basis: np.ndarray,
           pivot: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The point-to-plane model at points (N, 3) mm: (deviations (N,) mm, Jacobian (N, H) of
    the deviations by the held motions, basis (6, H), the centre (3,) mm the rotations turn
    about: pivot (3,) mm where given, else the points' centroid)."""
    feet, normals = closest(points)
    centre = points.mean(axis=0) if pivot is None else pivot
    return signed_distances(points, feet, normals), twist_jacobian(points, normals, centre) @ basis, centre


def _step_matrix(step: np.ndarray, basis: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(4, 4): the motion by ``step`` (H,) along the held motions basis (6, H), rotation about centre."""
    full = basis @ step
    rotation = rotation_matrix(full[:3])
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    matrix[:3, 3] = centre - rotation @ centre + full[3:]
    return matrix


def _least_squares(points: np.ndarray, closest: Closest, basis: np.ndarray, start: np.ndarray,
                   pivot: np.ndarray | None = None) -> tuple[np.ndarray, int, bool]:
    """Levenberg-Marquardt on sum d^2 from the motion ``start`` (4, 4) along the held motions
    basis (6, H) (Gauss-Newton steps, damped where a step would not lower the sum), ended where
    the Gauss-Newton step could gain nothing or would move no point by STEP_TOLERANCE_MM (where
    rounding alone decides whether a step lowers the sum), or a converged step is that small:
    (matrix (4, 4), iterations, capped: MAX_ITERATIONS reached). pivot: (3,) mm, the fixed
    centre of the basis's rotations (None: the moved points' centroid)."""
    matrix, damping = start, DAMPING[0]
    deviations, jacobian, centre = _model(transform(matrix, points), closest, basis, pivot)
    cost = float(deviations @ deviations)
    for iteration in range(1, MAX_ITERATIONS + 1):
        normal = jacobian.T @ jacobian
        scale = np.maximum(np.diag(normal), SCALE_FLOOR * np.diag(normal).max() + np.finfo(float).tiny)
        gradient = jacobian.T @ deviations
        newton = np.linalg.solve(normal + DAMPING[0] * np.diag(scale), -gradient)
        moved = transform(matrix, points)
        if -gradient @ newton <= COST_TOLERANCE * cost + GAIN_FLOOR_MM2 or _largest_move(
                _step_matrix(newton, basis, centre), moved) < STEP_TOLERANCE_MM:
            return matrix, iteration - 1, False
        step = np.linalg.solve(normal + damping * np.diag(scale), -gradient)
        motion = _step_matrix(step, basis, centre)
        trial = motion @ matrix
        trial_deviations, trial_jacobian, trial_centre = _model(transform(trial, points), closest, basis, pivot)
        trial_cost = float(trial_deviations @ trial_deviations)
        small = _largest_move(motion, moved) < STEP_TOLERANCE_MM
        if trial_cost <= cost:
            if damping <= CONVERGED_DAMPING and (small or cost - trial_cost <= COST_TOLERANCE * cost):
                return trial, iteration, False
            matrix, cost, damping = trial, trial_cost, max(damping * DAMPING_FALL, DAMPING[0])
            deviations, jacobian, centre = trial_deviations, trial_jacobian, trial_centre
        elif damping >= DAMPING[1]:
            return matrix, iteration, False
        else:
            damping = min(damping * DAMPING_RISE, DAMPING[1])
    return matrix, MAX_ITERATIONS, True


def _largest_move(motion: np.ndarray, points: np.ndarray) -> float:
    """mm, the farthest a motion (4, 4) moves any of the points (N, 3) mm."""
    return float(np.linalg.norm(transform(motion, points) - points, axis=1).max())


def _min_max(points: np.ndarray, closest: Closest, basis: np.ndarray, matrix: np.ndarray,
             pivot: np.ndarray | None = None) -> tuple[np.ndarray, int, bool]:
    """Sequential linear programmes on max |d| from ``matrix`` along the held motions basis (6,
    H), whose units move the points about 1 mm: (matrix (4, 4), iterations, capped)."""
    return _linear_programmes(points, closest, basis, matrix, pivot, _chebyshev_step, lambda d: np.abs(d).max())


def tangent(points: np.ndarray, closest: Closest, basis: np.ndarray, matrix: np.ndarray,
            pivot: np.ndarray | None = None) -> tuple[np.ndarray, int, bool]:
    """ISO 5459's association of a datum: the motion along basis (6, H) (rotations about pivot
    (3,) mm) that lays the face on the outside of the points (every d <= 0: the points in the
    material) as near to them as it can (min max -d), from ``matrix`` (4, 4): (matrix,
    iterations, capped). A point left outside counts TANGENT_PENALTY times its distance."""
    return _linear_programmes(points, closest, basis, matrix, pivot, _tangent_step, tangent_merit)


def tangent_merit(deviations: np.ndarray) -> float:
    """mm, how far deviations (N,) mm are from a tangent datum's: max -d, plus TANGENT_PENALTY
    times the farthest point out of the material (d > 0)."""
    return max(-float(deviations.min()), 0.0) + TANGENT_PENALTY * max(float(deviations.max()), 0.0)


def tangent_set(deviations: np.ndarray, jacobian: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A (2M, H), b (2M,)): the steps x with A x <= b that keep the linear model d + J x of a
    tangent solution (deviations d (M,) mm, jacobian J (M, H)) tangent: every point in the
    material (no farther out than the farthest is now, to ROUNDING_MM) and the largest distance
    at most max(-d) + TANGENT_TIE_MM."""
    deepest = max(-float(deviations.min()), 0.0)
    outside = max(float(deviations.max()), 0.0) + ROUNDING_MM
    return (np.vstack([jacobian, -jacobian]),
            np.concatenate([outside - deviations, deepest + TANGENT_TIE_MM + deviations]))


def tangent_choice(deviations: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """The step x (H,) to the tangent solution whose distances' sum of squares is least, among
    those of :func:`tangent_set` (the constrained L2 secondary criterion; unique, where the
    tangent criterion alone may leave a family; J (M, H) of full column rank): with J = Q R and
    z = R x + Q^T d, min |z| subject to the set's constraints, a least distance programme solved
    exactly through non-negative least squares (Lawson and Hanson, ch. 23); no step where the set
    is empty."""
    upper, bound = tangent_set(deviations, jacobian)
    orthogonal, triangle = np.linalg.qr(jacobian)
    inverse = np.linalg.inv(triangle)
    base = orthogonal.T @ deviations
    rows = -(upper @ inverse)
    floor = -(bound + upper @ inverse @ base)
    stacked = np.vstack([rows.T, floor[None, :]])
    target = np.r_[np.zeros(jacobian.shape[1]), 1.0]
    residual = stacked @ nnls(stacked, target, maxiter=50 * stacked.shape[1])[0] - target
    if abs(residual[-1]) <= 1e-15:
        return np.zeros(jacobian.shape[1])
    return inverse @ (-residual[:-1] / residual[-1] - base)


def tangent_extent(deviations: np.ndarray, jacobian: np.ndarray) -> float:
    """mm: how far the tangent solutions of :func:`tangent_set` move the points at most, along any
    one column of J (units that move the points about 1 mm RMS): max - min of each coordinate by
    a linear programme each; 0 for a unique solution."""
    upper, bound = tangent_set(deviations, jacobian)
    size, reach = jacobian.shape[1], 0.0
    for column in range(size):
        ends = [linprog(sign * np.eye(size)[column], A_ub=upper, b_ub=bound, bounds=[(None, None)] * size,
                        method="highs") for sign in (1.0, -1.0)]
        if all(end.success for end in ends):
            reach = max(reach, float(ends[1].x[column] - ends[0].x[column]))
    return reach


def _linear_programmes(points: np.ndarray, closest: Closest, basis: np.ndarray, matrix: np.ndarray,
                       pivot: np.ndarray | None, step_of: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
                       merit: Callable[[np.ndarray], float]) -> tuple[np.ndarray, int, bool]:
    """Sequential linear programmes: each step step_of(deviations, jacobian, radius) inside a
    trust region, kept where it lowers merit(deviations) (mm), the trust region shrunk by
    TRUST_SHRINK where it does not: (matrix (4, 4), iterations, capped)."""
    radius = np.full(basis.shape[1], TRUST_SHIFT_MM)
    deviations, jacobian, centre = _model(transform(matrix, points), closest, basis, pivot)
    worst = merit(deviations)
    for iteration in range(1, MAX_ITERATIONS + 1):
        step = step_of(deviations, jacobian, radius)
        motion = _step_matrix(step, basis, centre)
        before = transform(matrix, points)
        trial = motion @ matrix
        trial_deviations, trial_jacobian, trial_centre = _model(transform(trial, points), closest, basis, pivot)
        if merit(trial_deviations) < worst:
            matrix, worst = trial, merit(trial_deviations)
            deviations, jacobian, centre = trial_deviations, trial_jacobian, trial_centre
        else:
            radius *= TRUST_SHRINK
        if _largest_move(motion, before) < STEP_TOLERANCE_MM:
            return matrix, iteration, False
    return matrix, MAX_ITERATIONS, True


def _chebyshev_step(deviations: np.ndarray, jacobian: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The step x (F,) within |x| <= radius minimising max |d + J x|; no step where the
    programme has no solution."""
    found = chebyshev_programme(deviations, jacobian, [(-r, r) for r in radius])
    return np.zeros(jacobian.shape[1]) if found is None else found


def chebyshev_programme(deviations: np.ndarray, jacobian: np.ndarray,
                        limits: Sequence[tuple[float | None, float | None]]) -> np.ndarray | None:
    """The x (F,) within limits (F pairs (low, high), None: unbounded) minimising max |d + J x|
    for deviations d (M,) mm and jacobian J (M, F): a linear programme in (x, s), minimise s
    with -s <= d + J x <= s; None where it has no solution."""
    count, size = jacobian.shape
    cost = np.zeros(size + 1)
    cost[-1] = 1.0
    ones = np.ones((count, 1))
    upper = np.vstack([np.hstack([jacobian, -ones]), np.hstack([-jacobian, -ones])])
    bound = np.concatenate([-deviations, deviations])
    solved = linprog(cost, A_ub=upper, b_ub=bound, bounds=list(limits) + [(0, None)], method="highs")
    return solved.x[:size] if solved.success else None


def _tangent_step(deviations: np.ndarray, jacobian: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The step x (F,) within |x| <= radius minimising the linearised tangent_merit of d + J x:
    a linear programme in (x, s, v): minimise s + TANGENT_PENALTY v with -s <= d + J x <= v,
    s, v >= 0 (always feasible: v takes what the trust region cannot bring in)."""
    count, size = jacobian.shape
    cost = np.zeros(size + 2)
    cost[-2:] = 1.0, TANGENT_PENALTY
    ones, zeros = np.ones((count, 1)), np.zeros((count, 1))
    upper = np.vstack([np.hstack([jacobian, zeros, -ones]), np.hstack([-jacobian, -ones, zeros])])
    bound = np.concatenate([-deviations, deviations])
    limits = [(-r, r) for r in radius] + [(0, None), (0, None)]
    solved = linprog(cost, A_ub=upper, b_ub=bound, bounds=limits, method="highs")
    if not solved.success:
        return np.zeros(size)
    return solved.x[:size]
