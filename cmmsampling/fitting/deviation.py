"""The optimisers' deviation of a substitute from the CAD face, and the statistics reported.

The deviation a result reports is exact and two-sided (cmmsampling.fitting.exact), measured at
nodes on the face itself (cmmsampling.fitting.nodes): a raster F(h) of the face's domain and
points along its edges. For a swarm, whose every particle needs a fit and a deviation, this module
expands it about the raster: with e = S(h) - F(h) the substitute's offset from the face at the
same parameters,

    d2(h) = n(h) . e - e^T K(h) e / 2,  kept within [-|e|, |e|],

where K = P^T L P carries the face's second fundamental form L through the map P from an offset
to its foot's parameter shift (:func:`curvature_matrices`); it has rank two, and is applied as its
two principal terms. d2 is the distance from S(h) to the face to second order in the tangential
part of e, and the distance from F(h) to S to first order. Far from the face (a tangential
offset near the face's radius of curvature) the quadratic term outgrows both distances, which
never exceed |e| (F(h) lies on the face, S(h) on the substitute): there d2 is held to |e| (on
surf114's Face4 at N = 49, the paper's swarm measured 303,296 mm for a layout 99.9 mm off, and
ended on a layout the expansion ranked best and that lies 425 mm off). At the edge nodes the tangential part
matters to first order: a substitute whose edge drifts inside the face leaves the face's edge
uncovered, one that drifts beyond it reaches past the face. There the swarm measures

    d_edge = sign(n . e) sqrt((n . e)^2 + (a_1 . e)^2 + (a_2 . e)^2),

with a_1 the edge's outward conormal (a_2 = 0), or the whole offset at a collapsed edge. Every
figure reported is the exact deviation. Pure numpy: the objective can be shipped to a worker
process.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.bspline import design_matrices, kron_rows
from .lattice import LATTICE_LIMIT_BYTES, LatticeFit
from .nodes import DEFAULT_GRID, FaceNodes, face_nodes, grid_size, length_raster

if TYPE_CHECKING:
    from .exact import ExactDeviation
    from .substitute import SubstituteSpace

# closest_squared compares all pairs of each point set up to this many pairs in all (32 MB of
# distances), and searches neighbours beyond.
PAIRWISE_LIMIT = 4_000_000


class EvaluationGrid:
    """The (g_u x g_v) raster h of the face's parameter rectangle the deviation is measured on,
    at equal steps of the face's length along each direction (cmmsampling.fitting.nodes).

    uv: (g_u, g_v, 2) in the face's parameter range (the substitute spans the same range).
    """

    def __init__(self, model: Any, size: int | Sequence[int] = DEFAULT_GRID) -> None:
        self.size = grid_size(size)
        self.uv = length_raster(model, self.size)


def deviation_objective(model: Any, space: SubstituteSpace, grid: EvaluationGrid,
                        on_face: Callable[[np.ndarray], np.ndarray] | None = None,
                        reached: Callable[[np.ndarray], np.ndarray] | None = None) -> DeviationObjective:
    """The DeviationObjective on ``grid``'s nodes of the face.

    model: SurfaceModel of the face; space: SubstituteSpace; grid: EvaluationGrid; on_face: uv
    (..., 2) -> (...) bool, the face's trim test (None: the whole parameter range); reached: uv
    (..., 2) -> (...) bool, where a probe reaches the face (None: everywhere), the only nodes
    that count.
    """
    return DeviationObjective(model, space, grid, face_nodes(model, grid.size, on_face, reached))


class DeviationObjective:
    """Maximum expanded deviation of the substitute fit, for whole swarms of point sets at once.

    model: the CAD truth (a SurfaceModel or NurbsPatch; only its NurbsPatch is kept, so the
    objective pickles without FreeCAD objects); space: SubstituteSpace; grid: EvaluationGrid;
    nodes: FaceNodes on that grid. Calling it with uv: (P, N, 2) returns (P,) maximum expanded
    deviations in mm over the raster and the edge nodes (see the module docstring); with the
    personal bests to beat as well, it skips the point sets that cannot (``beats``).
    """

    beats = True

    def __init__(self, model: Any, space: SubstituteSpace, grid: EvaluationGrid, nodes: FaceNodes) -> None:
        self.model = model.patch()
        self.space = space
        self.grid = grid
        self.nodes = nodes
        u = grid.uv[:, 0, 0]
        v = grid.uv[0, :, 1]
        self.grid_u = design_matrices(space.uknots, space.degrees[0], u)[0]
        self.grid_v_t = design_matrices(space.vknots, space.degrees[1], v)[0].T.copy()
        self.evaluations = 0
        self._scratch: Scratch | None = None
        self._last: tuple[Any, Any, float] = (None, None, 0.0)
        self._lattice: LatticeFit | Literal[False] | None = None
        halves, directions = nodes_principal_terms(self.model, nodes)
        shape = nodes.uv.shape[:2]
        arrays = (nodes.points.transpose(2, 0, 1), nodes.normals.transpose(2, 0, 1),
                  0.5 * halves.T.reshape((2,) + shape), directions.transpose(1, 2, 0).reshape((2, 3) + shape))
        counted = tuple(np.where(nodes.counted, np.nan_to_num(array), 0.0) for array in arrays)
        bu, bv = space.bases(nodes.edge_uv)
        edges = (bu[0], bv[0], nodes.edge_points,
                 np.concatenate([nodes.edge_normals[:, None, :], nodes.edge_across], axis=1)
                 * nodes.edge_weights[:, None, None])
        self._exact = Expansion((self.grid_u, self.grid_v_t) + counted, edges, np.float64)
        self._single = Expansion((self.grid_u, self.grid_v_t) + counted, edges, np.float32)
        self._screen = NodeScreen(self._exact, single_rounding(nodes))

    @property
    def counted(self) -> np.ndarray:
        """(g_u, g_v) bool: the raster nodes the objective measures."""
        return self.nodes.counted

    def fit(self, uv: np.ndarray) -> np.ndarray:
        """Substitute poles for point sets at uv: (..., N, 2) -> (..., n_u, n_v, 3).

        Points and basis rows are laid out coordinate (or basis) before the points, so that every
        elementwise step runs along the points, and each point set is computed the same way
        whatever the size of the batch.
        """
        uv = np.asarray(uv, dtype=float)
        return self._fit_points(uv, self.points(uv))

    def _fit_points(self, uv: np.ndarray, points: np.ndarray) -> np.ndarray:
        """:meth:`fit` given the face points at uv, (..., 3, N) mm."""
        u, v = np.ascontiguousarray(uv[..., 0]), np.ascontiguousarray(uv[..., 1])
        return self.space.solve(self.space.u_basis.values(u), self.space.v_basis.values(v), points)

    def surface(self, poles: np.ndarray) -> np.ndarray:
        """Substitute points on the grid: poles (..., n_u, n_v, 3) -> (..., 3, g_u, g_v) mm."""
        by_coord = np.ascontiguousarray(np.moveaxis(np.asarray(poles), -1, -3))
        return np.matmul(np.matmul(self.grid_u, by_coord), self.grid_v_t)

    def expanded_field(self, poles: np.ndarray) -> np.ndarray:
        """Signed expanded deviation on the raster's nodes: poles (..., n_u, n_v, 3) ->
        (..., g_u, g_v) mm, d2 = n . e - e^T K e / 2 with e = S(h) - F(h) (0 where a node does not
        count; see the module docstring)."""
        poles = np.asarray(poles, dtype=float)
        return self._exact.field(poles, Scratch(poles.shape[:-3], poles.dtype, self.space.poles, self.grid.size))

    def expanded_edges(self, poles: np.ndarray) -> np.ndarray:
        """Signed expanded deviation at the edge nodes: poles (..., n_u, n_v, 3) -> (..., E) mm."""
        return self._exact.edges(np.asarray(poles, dtype=float))

    def _swarm_field(self, poles: np.ndarray) -> np.ndarray:
        """:meth:`expanded_field` for a swarm, in single precision in work arrays kept between calls
        (overwritten by the next call). A swarm's arrays are large: allocating them anew costs more
        than the arithmetic, and single precision halves their traffic; the swarm only compares
        values (1e-5 mm apart at worst), and every result is judged exactly in double precision.
        Nodes the objective does not count read 0 (their node, normal and curvatures are zeroed
        in these arrays), so a plain maximum of the field's magnitude skips them. A smaller batch
        than the arrays' works in their first rows."""
        batch = poles.shape[:-3]
        if self._scratch is None or self._scratch.batch[1:] != batch[1:] or self._scratch.batch[0] < batch[0]:
            self._scratch = Scratch(batch, np.float32, self.space.poles, self.grid.size)
        return self._single.field(poles, self._scratch.first(batch[0]))

    @property
    def lattice(self) -> LatticeFit | None:
        """The LatticeFit the swarm's fits are made with, built on first use; None for a face whose
        tables would exceed LATTICE_LIMIT_BYTES (its fits evaluate the bases anew)."""
        if self._lattice is None:
            small = LatticeFit.table_bytes(self.model, self.space) <= LATTICE_LIMIT_BYTES
            self._lattice = LatticeFit(self.model, self.space) if small else False
        return self._lattice or None

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_scratch"] = None
        state["_last"] = (None, None, 0.0)
        state["_lattice"] = None
        return state

    def __call__(self, uv: np.ndarray, above: np.ndarray | None = None) -> np.ndarray:
        """Maximum expanded deviation of each point set's substitute: uv (P, N, 2) -> (P,) mm.

        The substitutes are fitted at uv rounded to the lattice of :attr:`lattice` where the face
        has one (cmmsampling.fitting.lattice).

        above: None, or (P,) mm, each point set's value to beat (a swarm's personal bests): a point
        set whose deviation at the nodes of :class:`NodeScreen` already exceeds it is not scored
        over the whole raster, and gets that lower value instead (still at least ``above``), so
        whether a value beats ``above`` is decided as by the whole raster, and a value that does
        is the whole raster's.
        """
        given, uv = uv, np.asarray(uv, dtype=float)
        if self.lattice is not None:
            points, poles = self.lattice.points_and_poles(uv)
            self._last = (given, points, self.lattice.reach)
        else:
            points = self.points(uv)
            poles = self._fit_points(uv, points)
            self._last = (given, points, 0.0)
        self.evaluations += uv.shape[0]
        if above is None:
            return self._scored(poles)
        values = self._screen.lower(poles)
        rows = np.flatnonzero(values - self._screen.slack(values) < np.asarray(above, dtype=float))
        if rows.size:
            values[rows] = self._scored(poles[rows], learn=True)
        return values

    def _scored(self, poles: np.ndarray, learn: bool = False) -> np.ndarray:
        """Maximum expanded deviation over the raster and the edge nodes of the substitutes with
        poles (P, n_u, n_v, 3): (P,) mm; learn: tell the screen where each maximum lies."""
        field = self._swarm_field(poles).reshape(poles.shape[0], -1)
        field = np.abs(field, out=field)
        sets = np.arange(poles.shape[0])
        node = field.argmax(axis=1)
        worst = field[sets, node]
        if self.nodes.edge_uv.size:
            edges = np.abs(self._single.edges(poles))
            edge = edges.argmax(axis=1)
            node = np.where(edges[sets, edge] > worst, field.shape[1] + edge, node)
            worst = np.maximum(worst, edges[sets, edge])
        if learn:
            self._screen.learn(node)
        return worst

    def points(self, uv: np.ndarray) -> np.ndarray:
        """Face points of point sets, coordinate first: uv (..., N, 2) -> (..., 3, N) mm."""
        return self.model.points_by_coordinate(np.ascontiguousarray(uv[..., 0]), np.ascontiguousarray(uv[..., 1]))

    def spaced(self, uv: np.ndarray, min_spacing: float, rows: np.ndarray | Sequence[int] | None = None) -> np.ndarray:
        """True for the point sets uv[rows] (uv: (P, N, 2)) whose points keep ``min_spacing`` mm:
        (len(rows),) bool, all of them when rows is None.

        When uv is the array of this objective's last call, its face points are reused: exact
        ones (no lattice) decide at once; those at the lattice's rounded parameters lie within
        its reach of the exact ones, so a set whose closest pair is farther than 2 reach from
        ``min_spacing`` either way is decided by them, and only the others are evaluated exactly.
        """
        rows = np.arange(np.shape(uv)[0]) if rows is None else np.asarray(rows)
        last_uv, last_points, reach = self._last
        if uv is not last_uv:
            return self._exactly_spaced(uv, min_spacing, rows)
        if reach == 0:
            return closest_squared(last_points[rows]) >= min_spacing ** 2
        distance = np.sqrt(np.maximum(closest_squared(last_points[rows]), 0.0))
        spaced = distance >= min_spacing + 2.0 * reach
        unsure = np.flatnonzero(~spaced & (distance >= min_spacing - 2.0 * reach))
        if unsure.size:
            spaced[unsure] = self._exactly_spaced(uv, min_spacing, rows[unsure])
        return spaced

    def _exactly_spaced(self, uv: np.ndarray, min_spacing: float, rows: np.ndarray) -> np.ndarray:
        """:meth:`spaced` from the face points at uv[rows] evaluated anew."""
        return closest_squared(self.points(np.asarray(uv, dtype=float)[rows])) >= min_spacing ** 2

    def reference_poles(self) -> np.ndarray:
        """The substitute fitted to the face's points at every raster node: (n_u, n_v, 3) mm.

        What a fit to very many probe points tends to; the local bound is taken about it.
        """
        return self.space.fit(self.grid.uv.reshape(-1, 2), self.model.points(self.grid.uv.reshape(-1, 2)))


def closest_squared(points: np.ndarray) -> np.ndarray:
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


def _closest_squared_by_tree(points: np.ndarray) -> np.ndarray:
    """closest_squared by a k-d tree over all sets at once: (P, 3, N) mm -> (P,) mm^2."""
    sets, _, count = points.shape
    flat = np.swapaxes(points, 1, 2).copy()
    lower, upper = flat.min(axis=(0, 1)), flat.max(axis=(0, 1))
    stride = 3.0 * float(np.max(upper - lower)) + 1.0
    flat[:, :, 0] += stride * np.arange(sets)[:, None]
    flat = flat.reshape(-1, 3)
    distance = cKDTree(flat).query(flat, k=2)[0][:, 1].reshape(sets, count)
    return distance.min(axis=1) ** 2


def principal_terms(matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two principal terms of symmetric (M, 3, 3) matrices K whose third eigenvalue is 0.

    Returns (lambdas (M, 2), directions (M, 2, 3) unit), with K = sum_k lambda_k t_k t_k^T: the
    eigenpairs of largest magnitude (K's null direction is the normal).
    """
    values, vectors = np.linalg.eigh(matrices)
    order = np.argsort(np.abs(values), axis=1)[:, 1:]
    lambdas = np.take_along_axis(values, order, axis=1)
    directions = np.take_along_axis(vectors, order[:, None, :], axis=2)
    return lambdas, np.swapaxes(directions, 1, 2)


def nodes_principal_terms(model: Any, nodes: FaceNodes) -> tuple[np.ndarray, np.ndarray]:
    """:func:`principal_terms` of the face's curvature at the raster nodes, (M, 2) 1/mm and
    (M, 2, 3), M = g_u * g_v; computed once per FaceNodes (kept in ``nodes.principal``), since they
    depend on the face alone, whatever substitute space is judged on them."""
    if nodes.principal is None:
        nodes.principal = principal_terms(curvature_matrices(
            model, nodes.uv.reshape(-1, 2), np.nan_to_num(nodes.normals.reshape(-1, 3))))
    return nodes.principal


def curvature_matrices(model: Any, uv: np.ndarray, normals: np.ndarray) -> np.ndarray:
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

    def __init__(self, batch: Sequence[int], dtype: Any, poles: Sequence[int], grid: Sequence[int]) -> None:
        self.batch = tuple(batch)
        self.along_u = np.empty(self.batch + (3, grid[0], poles[1]), dtype)
        self.surface = np.empty(self.batch + (3,) + tuple(grid), dtype)
        self.field = np.empty(self.batch + tuple(grid), dtype)
        self.along = np.empty(self.batch + tuple(grid), dtype)

    def first(self, count: int) -> Scratch:
        """These arrays' first ``count`` rows along the batch's first axis, as a Scratch (views)."""
        if count == self.batch[0]:
            return self
        view = object.__new__(Scratch)
        view.batch = (count,) + self.batch[1:]
        for name in ("along_u", "surface", "field", "along"):
            setattr(view, name, getattr(self, name)[:count])
        return view


class Expansion:
    """The arrays of a DeviationObjective's expansion in one precision, and its evaluation.

    arrays: the grid's bases along u (g_u, n_u) and v, transposed (n_v, g_v); the nodes F(h)
    (3, g_u, g_v) mm; their normals (3, g_u, g_v); the halved principal curvatures of K
    (2, g_u, g_v) 1/mm and their directions (2, 3, g_u, g_v); edges: the bases at the edge nodes
    along u (E, n_u) and v (E, n_v), the edge nodes (E, 3) mm and the directions their offsets are
    measured along, the normal first (E, 3, 3); held coordinate first, so that every elementwise
    step runs along the edge nodes.
    """

    def __init__(self, arrays: Sequence[np.ndarray], edges: Sequence[np.ndarray], dtype: Any) -> None:
        self.dtype = dtype
        (self.grid_u, self.grid_v_t, self.foot_points, self.normals, self.halves,
         self.directions) = (np.ascontiguousarray(array, dtype=dtype) for array in arrays)
        along_u, along_v, points, directions = edges
        self.edge_columns = np.ascontiguousarray(kron_rows(along_u, along_v).T, dtype=dtype)
        self.edge_points = np.ascontiguousarray(np.asarray(points).T, dtype=dtype)
        self.edge_directions = [np.ascontiguousarray(directions[:, k].T, dtype=dtype) for k in range(3)]

    def field(self, poles: np.ndarray, scratch: Scratch) -> np.ndarray:
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
        offset = np.sqrt(np.einsum("...cij,...cij->...ij", error, error, out=scratch.along), out=scratch.along)
        return np.clip(field, -offset, offset, out=field)

    def edges(self, poles: np.ndarray) -> np.ndarray:
        """d_edge of poles (..., n_u, n_v, 3) at the edge nodes: (..., E) mm."""
        poles = np.asarray(poles, dtype=self.dtype)
        by_coord = np.swapaxes(poles.reshape(poles.shape[:-3] + (-1, 3)), -1, -2)
        error = np.matmul(by_coord, self.edge_columns)
        error -= self.edge_points
        normal = (error * self.edge_directions[0]).sum(-2)
        size = normal * normal
        for direction in self.edge_directions[1:]:
            part = (error * direction).sum(-2)
            size += part * part
        size = np.sqrt(size)
        return np.where(normal < 0, -size, size)


class NodeScreen:
    """A cheap lower bound of a swarm's maxima: the expanded deviation at the few nodes where
    the latest scored point sets had their maxima (a swarm's particles keep failing at the same
    places), in double precision.

    expansion: the objective's double-precision Expansion; margin: mm, how far the objective's
    single-precision maxima can lie from the double-precision values on top of a relative
    RELATIVE (see single_rounding and :meth:`slack`): a point set is skipped only when its bound
    exceeds the value to beat by more than that.
    """

    SIZE = 32
    RELATIVE = 16.0 * float(np.finfo(np.float32).eps)

    def __init__(self, expansion: Expansion, margin: float) -> None:
        self.expansion = expansion
        self.margin = margin
        self.raster = expansion.foot_points.shape[1:]
        self.nodes = np.empty(0, dtype=np.int64)
        self._columns = None

    def _gather(self) -> None:
        """The arrays :meth:`lower` needs at the screen's nodes (K of them): basis columns
        (n_u n_v, K), nodes (3, K) mm, projection directions (3, 3, K), curvature halves (2, K)
        1/mm (0 at edge nodes) and which are edge nodes (K,)."""
        expansion, cells = self.expansion, self.raster[0] * self.raster[1]
        inner, edge = self.nodes[self.nodes < cells], self.nodes[self.nodes >= cells] - cells
        rows, columns = np.divmod(inner, self.raster[1])
        inner_columns = (expansion.grid_u[rows][:, :, None] * expansion.grid_v_t[:, columns].T[:, None, :])
        inner_columns = inner_columns.reshape(inner.size, expansion.edge_columns.shape[0]).T
        self._columns = np.concatenate([inner_columns, expansion.edge_columns[:, edge]], axis=1)
        self._points = np.concatenate([expansion.foot_points[:, rows, columns], expansion.edge_points[:, edge]], axis=1)
        inner_directions = np.concatenate([expansion.normals[None, :, rows, columns],
                                           expansion.directions[:, :, rows, columns]])
        edge_directions = np.stack([direction[:, edge] for direction in expansion.edge_directions])
        self._directions = np.concatenate([inner_directions, edge_directions], axis=2)
        self._halves = np.concatenate([expansion.halves[:, rows, columns], np.zeros((2, edge.size))], axis=1)
        self._edge = np.arange(self.nodes.size) >= inner.size

    def lower(self, poles: np.ndarray) -> np.ndarray:
        """Largest |d| at the screen's nodes: poles (P, n_u, n_v, 3) -> (P,) mm (0 with none).

        Every node's offset e is one matrix product of the poles with the nodes' basis columns;
        its three projections (normal, then the two curvature directions at a raster node, or the
        conormals at an edge node) give d2 = e.n - h1 (e.t1)^2 - h2 (e.t2)^2 (within +-|e|) at a raster node and
        d_edge = sqrt of the sum of the squared projections at an edge node."""
        if self._columns is None:
            return np.zeros(poles.shape[0])
        poles = np.asarray(poles, dtype=float)
        by_coord = np.swapaxes(poles.reshape(poles.shape[0], -1, 3), -1, -2)
        error = np.matmul(by_coord, self._columns)
        error -= self._points
        projected = np.einsum("pck,jck->pjk", error, self._directions)
        squared = projected[:, 1:] ** 2
        offset = np.sqrt((error * error).sum(axis=1))
        inner = np.clip(projected[:, 0] - (self._halves * squared).sum(axis=1), -offset, offset)
        at_edge = np.sqrt(projected[:, 0] ** 2 + squared.sum(axis=1))
        return np.abs(np.where(self._edge, at_edge, inner)).max(axis=1)

    def slack(self, values: np.ndarray | float) -> np.ndarray | float:
        """How far single-precision maxima near ``values`` (mm, any shape) can lie from the
        double-precision ones: the margin plus RELATIVE of their size, mm."""
        return self.margin + self.RELATIVE * np.abs(values)

    def learn(self, found: np.ndarray) -> None:
        """Take the nodes of the latest maxima: found (P,) int, a raster node's flat index, or the
        number of raster nodes plus an edge node's index."""
        recent = np.concatenate([found[::-1], self.nodes])
        _, first = np.unique(recent, return_index=True)
        nodes = recent[np.sort(first)][: self.SIZE]
        changed = not np.array_equal(np.sort(nodes), np.sort(self.nodes))
        self.nodes = nodes
        if changed:
            self._gather()


def single_rounding(nodes: FaceNodes) -> float:
    """How far, in mm, a single-precision expanded deviation can lie from the double-precision
    one on these FaceNodes: a few units in the last place of the largest coordinate (the
    substitute's and the face's points are rounded to that before they are subtracted)."""
    coordinates = np.concatenate([np.nan_to_num(nodes.points).reshape(-1), nodes.edge_points.reshape(-1)])
    return 64.0 * float(np.finfo(np.float32).eps) * (1.0 + float(np.abs(coordinates).max(initial=0.0)))


# Deviations below this (mm, a nanometre) are the rounding of an exact fit, e.g. on a plane.
NUMERICAL_ZERO_MM = 1e-6


def mm_text(value: float) -> str:
    """A deviation in words: '0.2749 mm' (four significant digits), '0 mm' below
    NUMERICAL_ZERO_MM (never '5.711e-13 mm'), '' for NaN."""
    value = float(value)
    if not np.isfinite(value):
        return ""
    return "0 mm" if abs(value) < NUMERICAL_ZERO_MM else f"{value:.4g} mm"


@dataclass
class DeviationStats:
    """Deviation of a delivered substitute from the CAD face, all in mm (cmmsampling.fitting.exact).

    maximum: the largest |d| over the counted raster nodes, the edge nodes and the peaks found
    between them (cmmsampling.fitting.peaks), d the two-sided exact deviation; mean, rms, std: of
    |d| over the counted raster nodes and the edge nodes; field: (g_u, g_v) |d| per raster node
    (NaN where a node does not count); signed: (g_u, g_v) d; grid_uv: (g_u, g_v, 2) the raster h;
    nodes: (g_u, g_v, 3) F(h) mm; edge_signed: (E,) d at the edge nodes; edge_nodes: (E, 3) mm;
    peak_signed: (P,) d at the peaks; peak_nodes: (P, 3) mm; spacing: mm, every point of the face
    lies within it of a node; occ_maximum: OpenCASCADE's distances, both ways, at the places of
    largest deviation (see cmmsampling.fitting.crosscheck), which becomes the maximum where
    OCC checked the result, and occ_location: the face's point of it; judged_maximum: the
    maximum as the project's own measure found it, before OCC's check; normal_angle: degrees,
    the largest angle between the face's normal at a node and the substitute's at its nearest point (NaN
    where not measured): a substitute corrugated within a small distance shows here.
    """

    maximum: float
    mean: float
    rms: float
    std: float
    field: np.ndarray
    signed: np.ndarray
    grid_uv: np.ndarray
    nodes: np.ndarray
    edge_signed: np.ndarray | None = None
    edge_nodes: np.ndarray | None = None
    spacing: float = float("nan")
    occ_maximum: float = float("nan")
    peak_signed: np.ndarray | None = None
    peak_nodes: np.ndarray | None = None
    normal_angle: float = float("nan")
    occ_location: np.ndarray | None = None
    judged_maximum: float = float("nan")

    def max_location(self) -> np.ndarray:
        """(3,) mm: the face's point of largest deviation: OCC's where it checked (occ_location),
        else a raster, edge or peak node."""
        if self.occ_location is not None:
            return np.asarray(self.occ_location, dtype=float)
        field = np.nan_to_num(self.field, nan=-1.0)
        raster = np.unravel_index(int(np.argmax(field)), field.shape)
        places = [(field[raster], self.nodes[raster])]
        points: Any   # the nodes beside values that are not None
        for values, points in ((self.edge_signed, self.edge_nodes), (self.peak_signed, self.peak_nodes)):
            if values is not None and len(values):
                places.append((np.abs(values).max(), points[int(np.argmax(np.abs(values)))]))
        return np.asarray(max(places, key=lambda place: place[0])[1], dtype=float)

    def figures(self) -> dict[str, float]:
        """The summary figures by their keys in reports and point files, mm: max_mm, mean_mm,
        rms_mm, std_mm and occ_max_mm."""
        return {"max_mm": self.maximum, "mean_mm": self.mean, "rms_mm": self.rms, "std_mm": self.std,
                "occ_max_mm": self.occ_maximum}

    @classmethod
    def from_exact(cls, exact: ExactDeviation, space: SubstituteSpace | None = None) -> DeviationStats:
        """Statistics of an ExactDeviation (cmmsampling.fitting.exact) at its nodes and peaks; the
        normal angle (:func:`normal_angle`) where the substitute's space is given."""
        values = exact.counted_signed()
        magnitude = np.abs(values)
        nodes = exact.nodes
        grid = exact.grid_signed()
        return cls(
            maximum=exact.maximum,
            judged_maximum=exact.maximum,
            mean=float(magnitude.mean()),
            rms=float(np.sqrt(np.mean(values ** 2))),
            std=float(magnitude.std()),
            field=np.abs(grid),
            signed=grid,
            grid_uv=nodes.uv,
            nodes=nodes.points,
            edge_signed=exact.edge_signed(),
            edge_nodes=nodes.edge_points,
            spacing=nodes.spacing,
            peak_signed=exact.peak_signed(),
            peak_nodes=exact.peak_points,
            normal_angle=float("nan") if space is None else normal_angle(space, exact),
        )


def normal_angle(space: SubstituteSpace, exact: ExactDeviation) -> float:
    """Degrees: the largest angle between the face's normal at a node whose deviation counts and
    the substitute's normal at its nearest point on the substitute (either orientation: the
    angle between the lines, 0 to 90)."""
    from .substitute import FittedSurface

    nodes = exact.nodes
    count = len(nodes.node_weights())
    counted = nodes.node_weights() > 0
    derivatives = FittedSurface(space, exact.poles).derivatives(exact.forward.at[:count][counted])
    across = np.cross(derivatives[(1, 0)], derivatives[(0, 1)])
    lengths = np.linalg.norm(across, axis=1)
    face = np.concatenate([nodes.normals[nodes.counted], nodes.edge_normals])[counted]
    usable = lengths > 0
    cosines = np.abs(np.einsum("nc,nc->n", across[usable], face[usable])) / lengths[usable]
    return float(np.degrees(np.arccos(np.clip(cosines, 0.0, 1.0))).max(initial=0.0))
