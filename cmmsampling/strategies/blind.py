"""Blind and curvature-adaptive sampling strategies.

Every strategy has the signature ``strategy(problem, **options) -> StrategyOutcome`` where
``problem`` is a :class:`cmmsampling.strategies.problem.SamplingProblem` (face model, N, domain, seed) and
the outcome holds exactly N parameter pairs ``uv: (N, 2)`` inside the face's domain. Points and
normals follow from ``problem.model``. :data:`RECORDS` describes them to the rest of the project.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from scipy.spatial import cKDTree

from ..fitting.series import mm_per_parameter
from ..geometry.bspline import radical_inverse
from ..geometry.validation import InputError
from .registry import Runner, Strategy, StrategyOutcome

if TYPE_CHECKING:   # for the annotations only: problem's modules import this one
    from ..geometry.domain import FaceDomain
    from ..geometry.surface import SurfaceModel
    from .problem import SamplingProblem

CARTESIAN_RASTER = 121
NEWTON_STEPS = 30
NEWTON_TOLERANCE = 1e-9
COINCIDENT = 1e-9
COVERAGE = 1.6
# The largest layout a strategy grows before it gives up placing N points (a thin feasible strip
# can keep almost none of a layout's points).
MAX_LAYOUT = 250_000
# ... and it gives up sooner once STALL_ROUNDS layouts in a row, together STALL_GROWTH times the
# size of the last one that added a feasible, spaced point, added none: the points it finds crowd
# onto the same few places, which finer layouts find again (a sliver of a face left by the edge
# offset, seen along a steep axis).
STALL_ROUNDS = 3
STALL_GROWTH = 256


def grid_shape(n: int, aspect: float = 1.0) -> tuple[int, int]:
    """(rows, cols) with rows * cols >= n and cols / rows close to ``aspect`` (width / height).

    A perfect fit (e.g. 9 x 9 for 81 on a square) is used when there is one.
    """
    rows = max(1, int(round(np.sqrt(n / aspect))))
    best = None
    for r in range(max(1, rows - 2), rows + 3):
        c = int(np.ceil(n / r))
        score = (r * c - n, abs(np.log(c / r / aspect)))
        if best is None or score < best[0]:
            best = (score, (r, c))
    assert best is not None   # the range above holds at least three rows
    return best[1]


# Points thinned at a time by spaced(): about SPACING_BLOCK^2 / 2 pairs at most in memory.
SPACING_BLOCK = 2048


def thin_evenly(uv: np.ndarray, n: int) -> np.ndarray:
    """Keep n of the M >= n points, spread evenly along their order: (M, 2) -> (n, 2)."""
    if len(uv) == n:
        return uv
    keep = np.round(np.linspace(0, len(uv) - 1, n)).astype(int)
    return uv[keep]


def _unit_grid(rows: int, cols: int) -> np.ndarray:
    """Regular rows x cols grid of the unit square, corners included: (rows * cols, 2)."""
    u = np.linspace(0.0, 1.0, rows) if rows > 1 else np.array([0.5])
    v = np.linspace(0.0, 1.0, cols) if cols > 1 else np.array([0.5])
    return np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1).reshape(-1, 2)


def spaced(points: np.ndarray, min_spacing: float, block: int = SPACING_BLOCK) -> np.ndarray:
    """Indices of a greedy subset of points (M, 3) mm, in their order, at least min_spacing apart.

    Point i is kept unless an earlier kept point lies within min_spacing. The points go in
    blocks of ``block``: those near a point kept in an earlier block go at once (a tree query),
    then the rest of the block is thinned among itself, so that memory stays bounded (about
    block^2 pairs) even where most points crowd, e.g. a footprint grid seen along a cylinder.
    """
    if min_spacing <= 0 or len(points) < 2:
        return np.arange(len(points))
    kept = np.zeros(len(points), dtype=bool)
    for first in range(0, len(points), block):
        rows = np.arange(first, min(first + block, len(points)))
        if kept.any():
            distance = cKDTree(points[kept]).query(points[rows], distance_upper_bound=min_spacing)[0]
            rows = rows[distance >= min_spacing]
        kept[rows[_spaced_among(points[rows], min_spacing)]] = True
    return np.flatnonzero(kept)


def _spaced_among(points: np.ndarray, min_spacing: float) -> np.ndarray:
    """Indices of the greedy subset of points (B, 3) mm, in their order, at least min_spacing apart."""
    if len(points) < 2:
        return np.arange(len(points))
    pairs = cKDTree(points).query_pairs(min_spacing, output_type="ndarray")
    pairs = pairs[np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1) < min_spacing]
    later, earlier = pairs.max(axis=1), pairs.min(axis=1)
    by_later = np.argsort(later, kind="stable")
    crowding, starts = np.unique(later[by_later], return_index=True)
    kept = np.ones(len(points), dtype=bool)
    for i, neighbours in zip(crowding, np.split(earlier[by_later], starts[1:])):
        kept[i] = not kept[neighbours].any()
    return np.flatnonzero(kept)


def onto_face(problem: SamplingProblem, uv: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """uv (N, 2) with the points OCC finds off the face moved onto it, and notes (list of str)
    saying what was moved (none where nothing was).

    Points moved onto the same stretch of boundary (two grid points past a trimmed corner) can
    land closer than min_spacing: those are moved to free places (:func:`respace`), and checked
    on the face again."""
    uv, moved, off = problem.model.onto_face(uv)
    if not moved.any():
        return uv, []
    notes = [f"{moved.sum()} point(s) lay up to {off[moved].max():.2g} mm off the face at its boundary "
             "and were moved onto it"]
    uv, crowded = respace(problem, uv)
    if crowded:
        uv = problem.model.onto_face(uv)[0]
        notes.append(f"{crowded} point(s) then lay closer than min_spacing to others and were moved to "
                     "free places")
    return uv, notes


def respace(problem: SamplingProblem, uv: np.ndarray) -> tuple[np.ndarray, int]:
    """Move the points of uv (N, 2) that crowd others (closer than problem.min_spacing) to free places.

    The points are kept greedily in their order; each crowded one goes to the feasible candidate
    (a dense Halton set of the domain) nearest to it in 3D that keeps min_spacing from the others.
    Returns (uv (N, 2), number of points moved). ValueError when no free place is left.
    """
    points = problem.model.points(uv)
    kept = spaced(points, problem.min_spacing)
    if len(kept) == len(uv):
        return uv, 0
    spacing = problem.min_spacing
    candidates = feasible_candidates(problem, 64 * len(uv))
    places = problem.model.points(candidates)
    uv = uv.copy()
    free = cKDTree(points[kept]).query(places, distance_upper_bound=spacing)[0] >= spacing
    nearby = cKDTree(places)
    for i in np.setdiff1d(np.arange(len(uv)), kept):
        if not free.any():
            raise InputError(f"no room to keep {len(uv)} points {spacing:g} mm apart; "
                             f"{problem.spacing_advice()}")
        choice = np.flatnonzero(free)[np.argmin(np.linalg.norm(places[free] - points[i], axis=1))]
        uv[i] = candidates[choice]
        free[nearby.query_ball_point(places[choice], spacing)] = False
    return uv, len(uv) - len(kept)


def feasible_candidates(problem: SamplingProblem, count: int) -> np.ndarray:
    """About ``count`` feasible (u, v) of the domain from a Halton set: (M, 2)."""
    index = np.arange(1, 4 * count + 1)
    uv = problem.domain.from_unit(np.column_stack([radical_inverse(index, 2), radical_inverse(index, 3)]))
    return uv[problem.domain.contains(uv)][:count]


def _dense_enough(make_candidates: Callable[[int], np.ndarray], problem: SamplingProblem, start: int,
                  keep_first: bool = False, with_layout: bool = False) -> Any:
    """Grow a candidate layout until N of its points are feasible and spaced, then thin it.

    make_candidates(m) -> (M, 2) uv for a layout of about m points; start: first m to try;
    keep_first: keep the first N (for a sequence) instead of N spread evenly over the layout.
    Gives up (ValueError) past MAX_LAYOUT candidates, or once STALL_ROUNDS layouts in a row, the
    last of them at least STALL_GROWTH times the size of the last layout that held more feasible,
    spaced points (at least one), held no more.
    Feasible: on the face and at least edge_offset from its edges; spaced: greedily, in the
    layout's order, at least problem.min_spacing mm apart, and never coincident (closer than
    COINCIDENT times the face's size: several (u, v) of a degenerate edge, e.g. a sphere's pole).
    with_layout: also return the whole layout's feasible, spaced points (M, 2) it was thinned from.
    """
    n = problem.n
    m = start
    spacing = max(problem.min_spacing, COINCIDENT * problem.model.diagonal)
    most, grown_from, stalled = 0, m, 0
    while m <= MAX_LAYOUT:
        uv = make_candidates(m)
        inside = uv[problem.domain.contains(uv)]
        inside = inside[spaced(problem.model.points(inside), spacing)]
        if len(inside) >= n:
            chosen = inside[:n] if keep_first else thin_evenly(inside, n)
            return (chosen, inside) if with_layout else chosen
        if len(inside) > most:
            most, grown_from, stalled = len(inside), m, 0
        else:
            stalled += 1
        if most and stalled >= STALL_ROUNDS and m >= STALL_GROWTH * grown_from:
            break
        m = int(np.ceil(m * max(1.1, n / max(len(inside), 1))))
    raise InputError(
        f"could not place {n} points on the face at least {problem.min_spacing:g} mm apart and "
        f"{problem.domain.edge_offset:g} mm from its edges; lower edge_offset, or "
        f"{problem.spacing_advice()}"
    )


def snap_near_misses(domain: FaceDomain, uv: np.ndarray, cell: np.ndarray) -> np.ndarray:
    """Move grid nodes that just miss the feasible domain onto it: (M, 2) -> (M, 2).

    A node is moved to its nearest feasible point when that is at most one grid cell ``cell``
    (2,) away in (u, v), as next to an edge offset; nodes deep in a hole stay where they are
    (and are dropped as infeasible). Keeps a grid whole instead of losing a row to thinning.
    """
    moved = domain.project(uv)
    near = np.all(np.abs(moved - uv) <= cell, axis=1) & ~domain.contains(uv)
    return np.where(near[:, None], moved, uv)


def uniform_parametric(problem: SamplingProblem) -> StrategyOutcome:
    """Regular grid in (u, v) (paper eq. 5-6), corners included.

    The grid has rows x cols >= N nodes with rows / cols following the face's aspect (its mean
    lengths along u and v in space, so that a cylinder's circumference gets as many points per mm
    as its height); nodes that just miss the feasible domain (next to an edge offset) are moved
    onto it; rows that fall onto one another (a seam, a collapsed edge) keep one point per place;
    surplus nodes, and nodes off a trimmed face, are dropped evenly so that exactly N remain.
    """
    aspect = spatial_aspect(problem.model)

    def candidates(m: int) -> np.ndarray:
        rows, cols = grid_shape(m, aspect)
        cell = (problem.domain.upper - problem.domain.lower) / [max(rows - 1, 1), max(cols - 1, 1)]
        return snap_near_misses(problem.domain, problem.domain.from_unit(_unit_grid(rows, cols)), cell)

    return StrategyOutcome(_dense_enough(candidates, problem, problem.n))


def spatial_aspect(model: SurfaceModel, raster: int = 9) -> float:
    """Mean length of the face along v over its mean length along u (both in mm)."""
    along_u, along_v = mm_per_parameter(model, raster) * model.span
    return along_v / along_u if along_u > 0 and along_v > 0 else 1.0


def projection_frame(model: SurfaceModel, raster: int = CARTESIAN_RASTER) -> np.ndarray:
    """Axes of the Cartesian footprint: (e1, e2, e3) rows of a (3, 3) array.

    e3 is the machine axis (X, Y or Z) closest to the face's mean normal, and e1, e2 are the
    other two machine axes in cyclic order, so a face seen from +Z gets its grid in X and Y,
    as on a CMM table.
    """
    uv = model.raster((raster, raster)).reshape(-1, 2)
    normals = model.normals(uv)
    mean_normal = np.nanmean(normals, axis=0)
    axis = int(np.argmax(np.abs(mean_normal)))
    return np.eye(3)[[(axis + 1) % 3, (axis + 2) % 3, axis]]


def _solve_footprint(model: SurfaceModel, frame: np.ndarray, targets: np.ndarray,
                     seeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton solve of (P(u, v) . e1, P(u, v) . e2) = targets.

    targets: (M, 2) footprint coordinates in mm; seeds: (M, 2) starting uv.
    Returns (uv (M, 2), residual (M,) mm); uv is kept inside the parameter rectangle.
    """
    lower = np.array([model.bounds[0], model.bounds[2]])
    upper = np.array([model.bounds[1], model.bounds[3]])
    uv = seeds.copy()
    for _ in range(NEWTON_STEPS):
        d = model.derivatives(uv, 1)
        gap = d[(0, 0)] @ frame[:2].T - targets
        jac = np.stack([d[(1, 0)] @ frame[:2].T, d[(0, 1)] @ frame[:2].T], axis=-1)
        det = jac[:, 0, 0] * jac[:, 1, 1] - jac[:, 0, 1] * jac[:, 1, 0]
        safe = np.abs(det) > 1e-300
        step = np.zeros_like(uv)
        step[safe, 0] = (jac[safe, 1, 1] * gap[safe, 0] - jac[safe, 0, 1] * gap[safe, 1]) / det[safe]
        step[safe, 1] = (-jac[safe, 1, 0] * gap[safe, 0] + jac[safe, 0, 0] * gap[safe, 1]) / det[safe]
        uv = np.clip(uv - step, lower, upper)
    residual = np.linalg.norm(model.points(uv) @ frame[:2].T - targets, axis=1)
    return uv, residual


def uniform_cartesian(problem: SamplingProblem) -> StrategyOutcome:
    """Regular grid in machine coordinates over the face's footprint (paper eq. 3-4).

    The footprint is the face seen along the machine axis closest to its mean normal
    (:func:`projection_frame`); a rows x cols grid spans its bounding box, and each node's height
    is taken from the face (the (u, v) whose point projects onto the node, by Newton's method).
    Nodes that miss the face (outside a non-rectangular footprint or in a hole) are dropped, the
    grid is refined until at least N nodes hit, and the surplus is dropped evenly.
    """
    model = problem.model
    frame = projection_frame(model)
    raster_uv = model.raster((CARTESIAN_RASTER, CARTESIAN_RASTER)).reshape(-1, 2)
    raster_uv = raster_uv[problem.domain.contains(raster_uv)]
    foot = model.points(raster_uv) @ frame[:2].T
    low, high = foot.min(axis=0), foot.max(axis=0)
    extent = np.maximum(high - low, 1e-12)
    tree = cKDTree(foot)
    tolerance = NEWTON_TOLERANCE * max(1.0, float(extent.max()))

    def candidates(m: int) -> np.ndarray:
        rows, cols = grid_shape(m, extent[1] / extent[0])
        targets = low + _unit_grid(rows, cols) * extent
        seeds = raster_uv[tree.query(targets)[1]]
        uv, residual = _solve_footprint(model, frame, targets, seeds)
        cell = (problem.domain.upper - problem.domain.lower) / [max(rows - 1, 1), max(cols - 1, 1)]
        uv = snap_near_misses(problem.domain, uv, cell)
        return np.where((residual <= tolerance)[:, None], uv, np.nan)

    uv, layout = _dense_enough(candidates, problem, problem.n, with_layout=True)
    _check_coverage(problem, model.points(raster_uv), model.points(layout), "xyz"[int(np.argmax(frame[2]))],
                    len(layout))
    return StrategyOutcome(uv)


def _check_coverage(problem: SamplingProblem, face_points: np.ndarray, points: np.ndarray, axis: str,
                    count: int) -> None:
    """ValueError when some of the face lies farther than COVERAGE times the even spacing from
    every node of the footprint grid: the grid missed a steep part, where a fit would extrapolate.

    face_points: (M, 3) mm spread over the feasible face; points: (count, 3) mm the grid's nodes on
    the face (before the surplus is dropped); axis: the machine axis the footprint is seen along.
    """
    even = float(np.sqrt(cast(float, problem.domain.feasible_area) / count))
    gap = float(cKDTree(points).query(face_points)[0].max())
    if gap > COVERAGE * even:
        raise InputError(
            f"uniform_cartesian leaves part of the face without points: a spot {gap:.3g} mm from the "
            f"nearest node of its grid, where {count} points spread evenly are {even:.3g} mm apart (the face is "
            f"steep as seen along the machine {axis.upper()} axis, so the footprint grid misses it, and "
            "a fit there would extrapolate); use uniform_parametric, halton or an optimiser for this face")


def random_uniform(problem: SamplingProblem) -> StrategyOutcome:
    """Independent uniform random (u, v), seeded by ``problem.seed``; off-face draws are redrawn."""
    rng = np.random.default_rng(problem.seed)
    return StrategyOutcome(_dense_enough(lambda m: problem.domain.from_unit(rng.random((m, 2))),
                                         problem, problem.n))


def hammersley(problem: SamplingProblem) -> StrategyOutcome:
    """Hammersley set in (u, v): (i / M, radical inverse base 2 of i), i = 0..M-1 (Woo et al. 1995).

    M = N on an untrimmed face; on a trimmed face M grows until N points fall inside.
    """
    def candidates(m: int) -> np.ndarray:
        i = np.arange(m)
        return problem.domain.from_unit(np.column_stack([(i + 0.5) / m, radical_inverse(i, 2)]))

    return StrategyOutcome(_dense_enough(candidates, problem, problem.n))


def halton(problem: SamplingProblem) -> StrategyOutcome:
    """Halton sequence in (u, v), bases 2 and 3, starting at index 1: its first N feasible, spaced points."""
    def candidates(m: int) -> np.ndarray:
        i = np.arange(1, m + 1)
        return problem.domain.from_unit(np.column_stack([radical_inverse(i, 2), radical_inverse(i, 3)]))

    return StrategyOutcome(_dense_enough(candidates, problem, 4 * problem.n + 16, keep_first=True))


def _patch_scores(model: SurfaceModel, domain: FaceDomain, patches: tuple[int, int], curvature: str,
                  raster_per_patch: int = 8) -> np.ndarray:
    """Integral of |curvature| over each patch plus a share of its area: (rows, cols).

    curvature: "mean" uses |H| (1/mm), "gaussian" uses sqrt|K| (1/mm), so both weigh alike.
    The area share (20% of the face's average) keeps flat patches from getting no points; a face
    without that curvature (a plane, or a cylinder for "gaussian") is weighted by area alone.
    Only feasible samples count, unless none is (a feasible strip narrower than the samples'
    spacing): then every sample does.
    """
    rows, cols = patches
    size_u, size_v = rows * raster_per_patch, cols * raster_per_patch
    unit = np.stack(np.meshgrid((np.arange(size_u) + 0.5) / size_u, (np.arange(size_v) + 0.5) / size_v,
                                indexing="ij"), axis=-1)
    flat = domain.from_unit(unit.reshape(-1, 2))
    d = model.derivatives(flat, 1)
    area = np.linalg.norm(np.cross(d[(1, 0)], d[(0, 1)]), axis=1)
    mean, gauss = model.curvatures(flat)
    bend = np.abs(mean) if curvature == "mean" else np.sqrt(np.abs(gauss))
    bend = np.nan_to_num(bend)
    inside = domain.contains(flat)
    area = np.where(inside, np.nan_to_num(area), 0.0) if inside.any() else np.nan_to_num(area)
    average_bend = (bend * area).sum() / max(area.sum(), 1e-300)
    weight = bend * area + area * (0.2 * average_bend if average_bend > 0 else 1.0)
    return weight.reshape(rows, raster_per_patch, cols, raster_per_patch).sum(axis=(1, 3))


def allocate(scores: np.ndarray, n: int) -> np.ndarray:
    """Split n points over patches in proportion to scores (largest remainder): (P,) -> (P,) ints."""
    share = scores / scores.sum() * n
    counts = np.floor(share).astype(int)
    remainder = n - counts.sum()
    counts[np.argsort(share - counts)[::-1][:remainder]] += 1
    return counts


def _points_in_patches(counts: np.ndarray, patches: tuple[int, int]) -> np.ndarray:
    """Unit-square points: counts[p] Hammersley points in each patch of a rows x cols split."""
    rows, cols = patches
    flat_counts = counts.ravel()
    patch = np.repeat(np.arange(flat_counts.size), flat_counts)
    start = np.cumsum(flat_counts) - flat_counts
    rank = np.arange(patch.size) - start[patch]
    m = flat_counts[patch]
    local = np.column_stack([(rank + 0.5) / m, (radical_inverse(rank, 2) + 0.5 / m) % 1.0])
    corner = np.column_stack([patch // cols, patch % cols])
    return (corner + local) / np.array([rows, cols])


def curvature_adaptive(problem: SamplingProblem, curvature: str = "mean") -> StrategyOutcome:
    """More points where the face bends (Elkott et al. 2002; Obeidat & Raman 2009).

    The domain is split into patches (about N / 4 of them); each gets points in proportion to the
    integral of its curvature over its area (``curvature`` = "mean" or "gaussian"), plus an area
    share, and the points are spread inside each patch as a Hammersley set. Points off the
    feasible domain are dropped and the allocation grown until N remain.
    """
    if curvature not in ("mean", "gaussian"):
        raise InputError(f"curvature must be 'mean' or 'gaussian', got {curvature!r}")
    model, n = problem.model, problem.n
    du, dv = model.span
    patches = grid_shape(max(1, n // 4), dv / du if du > 0 else 1.0)
    scores = _patch_scores(model, problem.domain, patches, curvature).ravel()

    def candidates(m: int) -> np.ndarray:
        counts = allocate(scores, m).reshape(patches)
        return problem.domain.from_unit(_points_in_patches(counts, patches))

    return StrategyOutcome(_dense_enough(candidates, problem, n))


def curvature_gaussian(problem: SamplingProblem) -> StrategyOutcome:
    """:func:`curvature_adaptive` weighted by Gaussian curvature."""
    return curvature_adaptive(problem, curvature="gaussian")


def _blind(function: Callable[[SamplingProblem], StrategyOutcome]) -> Runner:
    """Adapter: a blind strategy ignores progress and takes no options."""
    return lambda problem, progress: function(problem)


RECORDS = (
    Strategy("uniform_cartesian", _blind(uniform_cartesian),
             "regular grid over the face's footprint in machine X/Y/Z (paper eq. 3-4)",
             "uniform Cartesian", figures=True, reference=True),
    Strategy("uniform_parametric", _blind(uniform_parametric),
             "regular grid in the face's (u, v) (paper eq. 5-6)", "uniform parametric",
             figures=True, reference=True, baseline=True),
    Strategy("random", _blind(random_uniform), "uniform random (u, v), seeded", "random",
             seeded=True),
    Strategy("hammersley", _blind(hammersley), "Hammersley set in (u, v)", "Hammersley"),
    Strategy("halton", _blind(halton), "Halton sequence in (u, v), bases 2 and 3", "Halton"),
    Strategy("curvature_mean", _blind(curvature_adaptive),
             "more points on patches of high mean curvature", "mean curvature"),
    Strategy("curvature_gaussian", _blind(curvature_gaussian),
             "more points on patches of high Gaussian curvature", "Gaussian curvature"),
)
