"""Deviation of the substitute geometry from the CAD face: a distance in space, in mm.

The CAD face is represented by nodes F_g on it: the closest points on the face (the feet) of the
grid points S_ref(h) of a reference substitute, the fit to the face's points at every node h of a
regular raster of the parameter rectangle (what a fit to very many probe points tends to). They
cover the face about as evenly as the raster, up to its edges (the foot of a point beyond an
edge is on the edge), and their normals n_g point out of the material.
The deviation of a substitute S at a node is the signed closest-point distance from F_g to S:

    d(g) = sign(n_g . (S(p) - F_g)) |S(p) - F_g|,    p = argmin |S(p) - F_g|  (p in the range),

so |d| is OpenCASCADE's closest-point distance from the node to the substitute surface, and the
sign says on which side of the face the substitute runs. Nodes whose foot is not on the face
(outside its trimming loops) do not count. The substitute is taken with
its natural extension a little beyond its parameter rectangle (cmmsampling.fitting.substitute.FittedSurface),
so that where its parametrisation runs short of the face's edge the form is still measured.

The optimisers use an expansion of d about the raster: with e = S(h) - F_g,

    d2(g) = n_g . e - e^T K_g e / 2,

where K_g = P^T L P carries the face's second fundamental form L through the map P from an offset
to its foot's parameter shift (:func:`curvature_matrices`); it has rank two, and is applied as
its two principal terms. It is exact to first order (the
first term alone) and second order in the tangential drift of S(h) from F_g; evaluating it for a
whole swarm costs a few array operations on the raster. Every figure reported is the exact d.
Pure numpy: the objective can be shipped to a worker process.
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.bspline import design_matrices

DEFAULT_GRID = 60
# closest_squared compares all pairs of each point set up to this many pairs in all (32 MB of
# distances), and searches neighbours beyond.
PAIRWISE_LIMIT = 4_000_000
FOOT_ITERATIONS = 60
FOOT_STEP_TOLERANCE = 1e-10
SEARCH_SAMPLES = 48


class EvaluationGrid:
    """A regular (g_u x g_v) raster h of the parameter rectangle, where the substitute is expanded.

    uv: (g_u, g_v, 2) in the face's parameter range (the substitute spans the same range).
    """

    def __init__(self, model, size=DEFAULT_GRID):
        self.size = _grid_size(size)
        self.uv = model.raster(self.size)


def deviation_objective(model, space, grid, on_face=None):
    """The DeviationObjective on ``grid`` whose nodes are the feet of the reference fit's grid points.

    model: SurfaceModel or NurbsPatch of the face; space: SubstituteSpace; grid: EvaluationGrid;
    on_face: uv (..., 2) -> (...) bool, the face's trim test (None: the whole parameter range).
    """
    objective = DeviationObjective(model, space, grid, None)
    targets = np.moveaxis(objective.surface(objective.reference_poles()), 0, -1)
    inside = on_face if on_face is not None else (lambda uv: np.ones(uv.shape[:-1], dtype=bool))
    objective.expand(closest_feet(objective.model, inside, targets, grid.uv))
    return objective


def _grid_size(size):
    """(n_u, n_v) from an int or a pair."""
    pair = (size, size) if np.ndim(size) == 0 else tuple(size)
    return tuple(int(s) for s in pair)


@dataclass
class Feet:
    """Closest points on the CAD face of target points, all (g_u, g_v, ...): the deviation's nodes.

    uv: (..., 2) the feet's parameters on the face; points: (..., 3) F(uv) mm; normals: (..., 3)
    unit, out of the material; counted: (...) bool, the foot lies on the face.
    """

    uv: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    counted: np.ndarray


def closest_feet(model, on_face, targets, start):
    """Feet on the face of target points: the closest point of the surface to each, in the range.

    model: NurbsPatch of the face; on_face: uv (..., 2) -> (...) bool, the face's trim test;
    targets: (..., 3) mm; start: (..., 2) first guesses of the feet's parameters.
    Returns Feet, counted where the foot is on the face (a target beyond the parameter range has
    its foot on the range's edge: a point of the face's boundary, counted too). Damped
    Gauss-Newton on |F(u, v) - target|^2 inside the parameter box, every node at once; a step is
    kept only where it brings the foot closer.
    """
    shape = targets.shape[:-1]
    targets = targets.reshape(-1, 3)
    uv = _closest_parameters(model, targets, np.asarray(start, dtype=float).reshape(-1, 2))
    points = model.points(uv)
    normals = model.normals(uv)
    counted = on_face(uv) & np.isfinite(points).all(1) & np.isfinite(normals).all(1)
    return Feet(uv.reshape(shape + (2,)), points.reshape(shape + (3,)), normals.reshape(shape + (3,)),
                counted.reshape(shape))


def substitute_distances(surface, nodes, start):
    """Exact signed distances d (see the module docstring) from the nodes to a substitute.

    surface: FittedSurface; nodes: Feet (the face's nodes, (g_u, g_v, ...)); start: (g_u, g_v, 2)
    first guesses of the closest points' parameters on the substitute (where the search ends
    farther than the nearest of SEARCH_SAMPLES^2 points of the surface, stuck in a local minimum
    as on a closed face that comes back near itself, it starts again there). Returns (d (g_u, g_v) mm,
    NaN where the node does not count, p (g_u, g_v, 2) the closest points' parameters). The
    substitute is taken with its natural extension (``surface.bounds``); a node it does not reach
    even so is measured to the extension's boundary.
    """
    targets = nodes.points.reshape(-1, 3)
    uv = _closest_parameters(surface, targets, np.asarray(start, dtype=float).reshape(-1, 2))
    sample_uv, sample_distance = _nearest_samples(surface, targets)
    stuck = np.flatnonzero(np.linalg.norm(surface.points(uv) - targets, axis=1) > sample_distance)
    if len(stuck):
        again = _closest_parameters(surface, targets[stuck], sample_uv[stuck])
        better = (np.linalg.norm(surface.points(again) - targets[stuck], axis=1)
                  < np.linalg.norm(surface.points(uv[stuck]) - targets[stuck], axis=1))
        uv[stuck[better]] = again[better]
    offset = surface.points(uv) - targets
    side = np.where((offset * nodes.normals.reshape(-1, 3)).sum(1) < 0, -1.0, 1.0)
    signed = np.where(nodes.counted.ravel(), side * np.linalg.norm(offset, axis=1), np.nan)
    return signed.reshape(nodes.counted.shape), uv.reshape(start.shape)


def _nearest_samples(surface, targets):
    """The nearest of a SEARCH_SAMPLES^2 raster of the surface's range to each target (K, 3):
    (parameters (K, 2), distance (K,) mm)."""
    u0, u1, v0, v1 = surface.bounds
    grid = np.stack(np.meshgrid(np.linspace(u0, u1, SEARCH_SAMPLES), np.linspace(v0, v1, SEARCH_SAMPLES),
                                indexing="ij"), -1).reshape(-1, 2)
    distance, index = cKDTree(surface.points(grid)).query(targets)
    return grid[index], distance


def _closest_parameters(model, targets, uv):
    """Parameters (K, 2) of the closest points to targets (K, 3), from uv (K, 2), in the box.

    model: anything with ``bounds``, ``points(uv)`` and ``derivatives(uv, 1)`` (a NurbsPatch or a
    FittedSurface).
    """
    u0, u1, v0, v1 = model.bounds
    low, high = np.array([u0, v0]), np.array([u1, v1])
    uv = np.clip(uv, low, high)
    squared = ((model.points(uv) - targets) ** 2).sum(1)
    damping = np.full(len(uv), 1e-9)
    active = np.ones(len(uv), dtype=bool)
    for _ in range(FOOT_ITERATIONS):
        if not active.any():
            break
        index = np.flatnonzero(active)
        trial = np.clip(uv[index] + _gauss_newton_step(model, targets[index], uv[index], damping[index]),
                        low, high)
        trial_squared = ((model.points(trial) - targets[index]) ** 2).sum(1)
        better = trial_squared <= squared[index]
        moved = np.abs(trial - uv[index]).max(1) > FOOT_STEP_TOLERANCE * (high - low).max()
        uv[index[better]] = trial[better]
        squared[index[better]] = trial_squared[better]
        damping[index] = np.where(better, damping[index] * 0.1, damping[index] * 100.0)
        active[index] = (better & moved) | (~better & (damping[index] < 1e12))
    return uv


def _gauss_newton_step(model, targets, uv, damping):
    """Levenberg-Marquardt step (K, 2) towards the closest points, damping (K,) relative."""
    d = model.derivatives(uv, 1)
    residual = d[(0, 0)] - targets
    su, sv = d[(1, 0)], d[(0, 1)]
    a, b, c = (su * su).sum(1), (su * sv).sum(1), (sv * sv).sum(1)
    shift = damping * (a + c) + 1e-300
    a, c = a + shift, c + shift
    gu, gv = (residual * su).sum(1), (residual * sv).sum(1)
    det = a * c - b * b
    return -np.column_stack([c * gu - b * gv, a * gv - b * gu]) / det[:, None]


class DeviationObjective:
    """Maximum expanded deviation of the substitute fit, for whole swarms of point sets at once.

    model: the CAD truth (a SurfaceModel or NurbsPatch; only its NurbsPatch is kept, so the
    objective pickles without FreeCAD objects); space: SubstituteSpace; grid: EvaluationGrid;
    feet: Feet of a reference substitute (see :meth:`expand`), or None to expand later. Calling it
    with uv: (P, N, 2) returns (P,) maximum expanded deviations in mm.
    """

    def __init__(self, model, space, grid, feet):
        self.model = model.patch()
        self.space = space
        self.grid = grid
        u = grid.uv[:, 0, 0]
        v = grid.uv[0, :, 1]
        self.grid_u = design_matrices(space.uknots, space.degrees[0], u)[0]
        self.grid_v_t = design_matrices(space.vknots, space.degrees[1], v)[0].T.copy()
        self.evaluations = 0
        self.feet = None
        self._scratch = None
        self._last = (None, None)
        if feet is not None:
            self.expand(feet)

    def expand(self, feet):
        """Take the feet of a reference substitute's grid points as the nodes, and expand there.

        feet: Feet on this grid. Nodes it does not count leave the objective. Holds F_g, n_g and
        K_g, the latter as its two principal terms lambda_k t_k t_k^T (:func:`principal_terms`).
        """
        self.feet = feet
        halves, directions = principal_terms(curvature_matrices(
            self.model, feet.uv.reshape(-1, 2), feet.normals.reshape(-1, 3)))
        shape = feet.uv.shape[:2]
        arrays = (self.grid_u, self.grid_v_t, feet.points.transpose(2, 0, 1),
                  feet.normals.transpose(2, 0, 1), 0.5 * halves.T.reshape((2,) + shape),
                  directions.transpose(1, 2, 0).reshape((2, 3) + shape))
        self._exact = Expansion(arrays, np.float64)
        self._single = Expansion(arrays[:2] + tuple(np.where(feet.counted, array, 0.0) for array in arrays[2:]),
                                 np.float32)

    @property
    def counted(self):
        """(g_u, g_v) bool: the nodes the objective measures."""
        return self.feet.counted

    def fit(self, uv):
        """Substitute poles for point sets at uv: (..., N, 2) -> (..., n_u, n_v, 3).

        Points and basis rows are laid out coordinate (or basis) before the points, so that every
        elementwise step runs along the points, and each point set is computed the same way
        whatever the size of the batch.
        """
        uv = np.asarray(uv, dtype=float)
        return self._fit_points(uv, self.points(uv))

    def _fit_points(self, uv, points):
        """:meth:`fit` given the face points at uv, (..., 3, N) mm."""
        u, v = np.ascontiguousarray(uv[..., 0]), np.ascontiguousarray(uv[..., 1])
        return self.space.solve(self.space.u_basis.values(u), self.space.v_basis.values(v), points)

    def surface(self, poles):
        """Substitute points on the grid: poles (..., n_u, n_v, 3) -> (..., 3, g_u, g_v) mm."""
        by_coord = np.ascontiguousarray(np.moveaxis(np.asarray(poles), -1, -3))
        return np.matmul(np.matmul(self.grid_u, by_coord), self.grid_v_t)

    def expanded_field(self, poles):
        """Signed deviation on the grid's nodes, expanded about the raster.

        poles (..., n_u, n_v, 3) -> (..., g_u, g_v) mm: d2 = n . e - e^T K e / 2 with
        e = S(h) - F_g (see the module docstring).
        """
        poles = np.asarray(poles, dtype=float)
        return self._exact.field(poles, Scratch(poles.shape[:-3], poles.dtype, self.space.poles, self.grid.size))

    def _swarm_field(self, poles):
        """:meth:`expanded_field` for a swarm, in single precision in work arrays kept between calls
        (overwritten by the next call). A swarm's arrays are large: allocating them anew costs more
        than the arithmetic, and single precision halves their traffic; the swarm only compares
        values (1e-5 mm apart at worst), and every result is judged exactly in double precision.
        Nodes the objective does not count read 0 (their node, normal and curvatures are zeroed
        in these arrays), so a plain maximum of the field's magnitude skips them."""
        batch = poles.shape[:-3]
        if self._scratch is None or self._scratch.batch != batch:
            self._scratch = Scratch(batch, np.float32, self.space.poles, self.grid.size)
        return self._single.field(poles, self._scratch)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_scratch"] = None
        state["_last"] = (None, None)
        return state

    def grid_error(self, poles):
        """The expanded deviation of one substitute and its gradient, for the adjoint gradient.

        poles (n_u * n_v, 3) or (n_u, n_v, 3). Returns (error (3, g_u, g_v) = d2 times its gradient
        with respect to S(h), n - K e; distance (g_u, g_v) = |d2| mm; counted (g_u, g_v) bool).
        """
        poles = np.asarray(poles).reshape(self.space.poles + (3,))
        exact = self._exact
        error = self.surface(poles) - exact.foot_points
        field = self.expanded_field(poles)
        gradient = exact.normals.copy()
        for half, direction in zip(exact.halves, exact.directions):
            gradient -= 2.0 * half * (error * direction).sum(0) * direction
        return field * gradient, np.abs(field), self.feet.counted

    def grid_transpose(self, field):
        """G^T applied to a grid field (3, g_u, g_v): the (n_u * n_v, 3) pole-space result."""
        pulled = self.grid_u.T @ field @ self.grid_v_t.T
        return pulled.transpose(1, 2, 0).reshape(-1, 3)

    def __call__(self, uv):
        """Maximum expanded deviation of each point set's substitute: uv (P, N, 2) -> (P,) mm."""
        given, uv = uv, np.asarray(uv, dtype=float)
        points = self.points(uv)
        field = self._swarm_field(self._fit_points(uv, points)).reshape(uv.shape[0], -1)
        self._last = (given, points)
        self.evaluations += uv.shape[0]
        return np.abs(field, out=field).max(axis=1)

    def points(self, uv):
        """Face points of point sets, coordinate first: uv (..., N, 2) -> (..., 3, N) mm."""
        return self.model.points_by_coordinate(np.ascontiguousarray(uv[..., 0]), np.ascontiguousarray(uv[..., 1]))

    def spaced(self, uv, min_spacing, rows=None):
        """True for the point sets uv[rows] (uv: (P, N, 2)) whose points keep ``min_spacing`` mm:
        (len(rows),) bool, all of them when rows is None. When uv is the array of this objective's
        last call, the face points of that call are reused rather than evaluated again."""
        rows = slice(None) if rows is None else rows
        last_uv, last_points = self._last
        if uv is last_uv:
            points = last_points[rows]
        else:
            points = self.points(np.asarray(uv, dtype=float)[rows])
        return closest_squared(points) >= min_spacing ** 2

    def reference_poles(self):
        """The substitute fitted to the face's points at every grid node: (n_u, n_v, 3) mm.

        What a fit to very many probe points tends to; its feet start every exact evaluation.
        """
        return self.space.fit(self.grid.uv.reshape(-1, 2), self.model.points(self.grid.uv.reshape(-1, 2)))


def closest_squared(points):
    """Smallest squared distance between two points of each set: (P, 3, N) mm -> (P,) mm^2.

    Up to PAIRWISE_LIMIT pairs in all, from the sets' distance matrices; beyond, from one
    neighbour search over every set at once (memory linear in P N), the sets moved apart along x
    so that no point of one is near a point of another."""
    if points.shape[0] * points.shape[2] ** 2 > PAIRWISE_LIMIT:
        return _closest_squared_by_tree(points)
    lengths = np.einsum("pcn,pcn->pn", points, points)
    squared = np.matmul(np.swapaxes(points, 1, 2), points)
    squared *= -2.0
    squared += lengths[:, :, None]
    squared += lengths[:, None, :]
    count = points.shape[-1]
    squared[:, np.arange(count), np.arange(count)] = np.inf
    return squared.min(axis=(1, 2))


def _closest_squared_by_tree(points):
    """closest_squared by a k-d tree over all sets at once: (P, 3, N) mm -> (P,) mm^2."""
    sets, _, count = points.shape
    flat = np.swapaxes(points, 1, 2).copy()
    lower, upper = flat.min(axis=(0, 1)), flat.max(axis=(0, 1))
    stride = 3.0 * float(np.max(upper - lower)) + 1.0
    flat[:, :, 0] += stride * np.arange(sets)[:, None]
    flat = flat.reshape(-1, 3)
    distance = cKDTree(flat).query(flat, k=2)[0][:, 1].reshape(sets, count)
    return distance.min(axis=1) ** 2


def principal_terms(matrices):
    """The two principal terms of symmetric (M, 3, 3) matrices K whose third eigenvalue is 0.

    Returns (lambdas (M, 2), directions (M, 2, 3) unit), with K = sum_k lambda_k t_k t_k^T: the
    eigenpairs of largest magnitude (K's null direction is the normal).
    """
    values, vectors = np.linalg.eigh(matrices)
    order = np.argsort(np.abs(values), axis=1)[:, 1:]
    lambdas = np.take_along_axis(values, order, axis=1)
    directions = np.take_along_axis(vectors, order[:, None, :], axis=2)
    return lambdas, np.swapaxes(directions, 1, 2)


def curvature_matrices(model, uv, normals):
    """Per-point K = P^T L P: (M, 3, 3) in 1/mm, at uv (M, 2) with unit normals (M, 3).

    P = (J^T J)^-1 J^T maps a small offset e from F(uv) to the parameter shift of its foot (J =
    [F_u F_v]), and L = [[n.F_uu, n.F_uv], [n.F_uv, n.F_vv]] is the second fundamental form, so the
    foot rises by e^T K e / 2 along n. Zero where J^T J is singular (a collapsed edge).
    """
    d = model.derivatives(uv, 2)
    jacobian = np.stack([d[(1, 0)], d[(0, 1)]], axis=-1)
    metric = np.swapaxes(jacobian, -1, -2) @ jacobian
    det = np.linalg.det(metric)
    regular = det > 1e-12 * np.einsum("mii->m", metric) ** 2
    inverse = np.zeros_like(metric)
    inverse[regular] = np.linalg.inv(metric[regular])
    shift = inverse @ np.swapaxes(jacobian, -1, -2)
    second = np.stack([d[(2, 0)], d[(1, 1)], d[(1, 1)], d[(0, 2)]], axis=1).reshape(-1, 2, 2, 3)
    form = (second * normals[:, None, None, :]).sum(-1)
    return np.swapaxes(shift, -1, -2) @ form @ shift


class Scratch:
    """Work arrays of the expansion for one batch shape and precision."""

    def __init__(self, batch, dtype, poles, grid):
        self.batch = tuple(batch)
        self.along_u = np.empty(self.batch + (3, grid[0], poles[1]), dtype)
        self.surface = np.empty(self.batch + (3,) + tuple(grid), dtype)
        self.field = np.empty(self.batch + tuple(grid), dtype)
        self.along = np.empty(self.batch + tuple(grid), dtype)


class Expansion:
    """The arrays of a DeviationObjective's expansion in one precision, and its evaluation.

    arrays: the grid's bases along u (g_u, n_u) and v, transposed (n_v, g_v); the nodes F_g
    (3, g_u, g_v) mm; their normals (3, g_u, g_v); the halved principal curvatures of K_g
    (2, g_u, g_v) 1/mm and their directions (2, 3, g_u, g_v).
    """

    def __init__(self, arrays, dtype):
        self.dtype = dtype
        (self.grid_u, self.grid_v_t, self.foot_points, self.normals, self.halves,
         self.directions) = (np.ascontiguousarray(array, dtype=dtype) for array in arrays)

    def field(self, poles, scratch):
        """d2 of poles (..., n_u, n_v, 3) computed in ``scratch``: (..., g_u, g_v) mm."""
        by_coord = np.ascontiguousarray(np.moveaxis(poles, -1, -3), dtype=self.dtype)
        np.matmul(self.grid_u, by_coord, out=scratch.along_u)
        error = np.matmul(scratch.along_u, self.grid_v_t, out=scratch.surface)
        error -= self.foot_points
        field = np.einsum("...cij,cij->...ij", error, self.normals, out=scratch.field)
        for half, direction in zip(self.halves, self.directions):
            along = np.einsum("...cij,cij->...ij", error, direction, out=scratch.along)
            along *= along
            along *= half
            field -= along
        return field


class Linearisation:
    """The exact deviations linearised about one substitute S0, for a descent that moves it.

    objective: the DeviationObjective whose nodes are measured; poles: (n_u, n_v, 3) mm of S0;
    signed: (g_u, g_v) its exact deviations (NaN where not counted); closest: (g_u, g_v, 2) the
    parameters p_g of its closest points (cmmsampling.fitting.deviation.substitute_distances). With
    w_g = (S0(p_g) - F_g) / d_g, the direction each deviation is measured along (the face's normal
    where d_g = 0), a substitute S deviates at node g, to first order in S - S0,

        d_g + w_g . (S(p_g) - S0(p_g)),

    exact at S0 in value and gradient (the closest point moves only to second order). It has the
    interface the descent's surrogate uses: ``model``, ``space``, ``grid_error``, ``grid_transpose``.
    """

    def __init__(self, objective, poles, signed, closest):
        self.model, self.space = objective.model, objective.space
        counted = np.isfinite(signed).ravel()
        self._signed = signed.ravel()[counted]
        closest = closest.reshape(-1, 2)[counted]
        bu, bv = self.space.bases(closest)
        self._rows = (bu[0][:, :, None] * bv[0][:, None, :]).reshape(len(closest), -1)
        self._start = self._rows @ np.asarray(poles).reshape(-1, 3)
        offsets = self._start - objective.feet.points.reshape(-1, 3)[counted]
        directions = objective.feet.normals.reshape(-1, 3)[counted].copy()
        measured = np.abs(self._signed) > 1e-12 * max(1.0, float(np.abs(self._signed).max(initial=0.0)))
        directions[measured] = offsets[measured] / self._signed[measured, None]
        self._directions = directions

    def grid_error(self, poles):
        """As DeviationObjective.grid_error, over the counted nodes: poles (n_u n_v, 3) or
        (n_u, n_v, 3) -> (error (3, K) = d w, distance (K,) = |d| mm, counted (K,) all True)."""
        moved = self._rows @ np.asarray(poles).reshape(-1, 3) - self._start
        field = self._signed + (moved * self._directions).sum(1)
        return (field[:, None] * self._directions).T, np.abs(field), np.ones(len(field), dtype=bool)

    def grid_transpose(self, field):
        """B^T applied to a field (3, K) at the counted nodes: the (n_u * n_v, 3) pole-space result."""
        return self._rows.T @ field.T


@dataclass
class DeviationStats:
    """Deviation of a substitute surface from the CAD face, all in mm.

    maximum, mean, rms, std: of |d| over the counted nodes (see the module docstring).
    field: (g_u, g_v) |d| per node (NaN where a node does not count); signed: (g_u, g_v) d;
    grid_uv: (g_u, g_v, 2) the raster h the nodes come from (where the substitute runs next to
    them); nodes: (g_u, g_v, 3) the nodes on the face, mm;
    occ_maximum: OpenCASCADE's closest-point distance from the nodes to the substitute, the largest
    over the nodes of largest deviation (see cmmsampling.fitting.crosscheck).
    """

    maximum: float
    mean: float
    rms: float
    std: float
    field: np.ndarray
    signed: np.ndarray
    grid_uv: np.ndarray
    nodes: np.ndarray
    occ_maximum: float = float("nan")

    def figures(self):
        """The summary figures by their keys in reports and point files, mm: max_mm, mean_mm,
        rms_mm, std_mm and occ_max_mm."""
        return {"max_mm": self.maximum, "mean_mm": self.mean, "rms_mm": self.rms, "std_mm": self.std,
                "occ_max_mm": self.occ_maximum}

    @classmethod
    def from_signed(cls, signed, objective):
        """Statistics of signed deviations (g_u, g_v) mm, NaN where a node does not count, at the
        nodes of ``objective`` (a DeviationObjective)."""
        counted = signed[np.isfinite(signed)]
        magnitude = np.abs(counted)
        return cls(
            maximum=float(magnitude.max()),
            mean=float(magnitude.mean()),
            rms=float(np.sqrt(np.mean(counted ** 2))),
            std=float(magnitude.std()),
            field=np.abs(signed),
            signed=signed,
            grid_uv=objective.grid.uv,
            nodes=objective.feet.points,
        )
