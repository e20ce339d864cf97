"""Where on a face probe points may go: the trimmed domain and the edge offset, in (u, v).

A face is a region of its surface's parameter rectangle ``bounds``. For an untrimmed face with no
edge offset the region is the rectangle itself, tested exactly. Otherwise the rectangle is cut into
a grid of about CELLS cells, classified once; the cells are about square in 3D (a thin strip gets
many cells across its length and few across its width), so that their size, and with it the
margin below, is as small as CELLS allows:

* on the face: the cell centre lies inside the face's trimming loops (each edge's curve on the
  surface, from OCC, discretised; even-odd rule, so holes need no orientation). A point within
  NEAR_CELLS // 2 cells of a cell that a loop passes through is tested against the discretised
  loops themselves;
* feasible: on the face and at least ``edge_offset`` mm (3D) from every edge of the face. The 3D
  distance is taken from a fine discretisation of the face's wires and made conservative by half
  the largest gap between its samples and half the cell's 3D diagonal, so every point of a
  feasible cell keeps the offset. A point's clearance is thus underrated by at most half that gap
  and a whole cell diagonal: that margin (``FaceDomain.margin``, mm) is what a refusal may be
  wrong by. A face is refused only when none of its points lies farther than edge_offset +
  margin from its edges.

Given where a probe reaches the part (``reachable``), the cells it cannot reach are infeasible too:
asked once per face on a coarser raster of about REACH_CELLS cells (at the middle of each coarse
cell's part on the face), and a cell counts only when its coarse cell and their eight neighbours
are reached (so a corner far from a centre is judged; for placing points, a neighbour off the
face counts as unreached: a margin more along the face's edges). Where the probe reaches only
part of a face, that part is the face's domain for judging too (``judged``): a substitute is
fitted to points there and says nothing about the surface the probe cannot touch, so its
deviation is measured over the reached part of the face only (the rest is reported, with its
area).

Points outside the feasible cells are moved to the nearest feasible cell centre.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, cast

import numpy as np
from scipy.ndimage import distance_transform_edt, maximum_filter, minimum_filter
from scipy.spatial import cKDTree

if TYPE_CHECKING:
    from .nurbs import NurbsPatch
    from .surface import SurfaceModel

CELLS = 256 * 256
MIN_CELLS_PER_SIDE = 16
SHAPE_SAMPLES = 17
NEAR_CELLS = 5
# Cells of the coarser raster on which a probe's reach is judged.
REACH_CELLS = 32 * 32
# Bands of v a point-in-loops test sorts the loops' segments into (LoopCrossings).
BANDS = 128


class FaceDomain:
    """The feasible part of a face's parameter rectangle (see the module docstring).

    bounds: (u0, u1, v0, v1) of the face; trimmed: the face is not the whole rectangle;
    edge_offset: mm kept from every edge; on_face, feasible: (R_u, R_v) bool rasters; lower,
    upper: (2,) corners of the box holding every feasible point; feasible_area: mm^2 of the
    feasible cells (the face's area when exact); reach: mm, the largest edge offset that some
    cell keeps by the conservative measure; margin: mm, how much farther from the edges a point
    of the face may lie than that measure says (0 when exact); unreached: (R_u, R_v) bool, the
    cells on the face that a probe cannot reach (None when no probe was asked); unreached_area:
    mm^2 of those cells; out_of_reach: (R_u, R_v) bool, the cells in the probe's coarse cells
    it cannot reach, on the face or not (a point near a trimming loop may lie on the face in a
    cell the raster has off it).
    """

    def __init__(self, bounds: Sequence[float], trimmed: bool = False, edge_offset: float = 0.0,
                 on_face: np.ndarray | None = None, feasible: np.ndarray | None = None, area: float | None = None,
                 loops: Sequence[np.ndarray] | None = None, reach: float = np.inf, margin: float = 0.0,
                 unreached: np.ndarray | None = None, unreached_area: float = 0.0,
                 out_of_reach: np.ndarray | None = None) -> None:
        self.bounds = tuple(float(b) for b in bounds)
        self.trimmed = trimmed
        self.edge_offset = float(edge_offset)
        self.reach = float(reach)
        self.margin = float(margin)
        self.unreached = unreached
        self.unreached_area = float(unreached_area)
        self._out_of_reach = out_of_reach
        self.shape = np.array(feasible.shape if feasible is not None else (1, 1))
        self._on_face = on_face
        self._loops = loops if trimmed else None
        self._near_loops: np.ndarray | None = None
        self._crossings: LoopCrossings | None = None
        if self._loops is not None:
            touched = np.zeros(tuple(self.shape), dtype=bool)
            cells = self._cells(np.concatenate(self._loops))
            touched[cells[:, 0], cells[:, 1]] = True
            self._near_loops = maximum_filter(touched, size=NEAR_CELLS)
        self._feasible = feasible
        self._nearest: np.ndarray | None = None
        self.feasible_area = area
        self.lower = np.array([self.bounds[0], self.bounds[2]])
        self.upper = np.array([self.bounds[1], self.bounds[3]])
        if feasible is not None and feasible.any():
            rows, cols = np.nonzero(feasible)
            cell = (self.upper - self.lower) / np.array(feasible.shape)
            self.lower = self.lower + np.array([rows.min(), cols.min()]) * cell
            self.upper = np.array([self.bounds[0], self.bounds[2]]) + (np.array([rows.max(), cols.max()]) + 1) * cell

    @property
    def exact(self) -> bool:
        """True when the domain is the plain parameter rectangle (no raster involved)."""
        return self._feasible is None

    @property
    def empty(self) -> bool:
        """True when no point of the face keeps the edge offset."""
        return self._feasible is not None and not self._feasible.any()

    def _cells(self, uv: np.ndarray) -> np.ndarray:
        """Raster cell indices (..., 2) of uv (..., 2), clipped to the raster."""
        u0, u1, v0, v1 = self.bounds
        scale = self.shape / np.array([u1 - u0, v1 - v0])
        cells = np.floor((np.asarray(uv, dtype=float) - [u0, v0]) * scale)
        return np.clip(np.nan_to_num(cells, nan=-1), 0, self.shape - 1).astype(int)

    def _in_rectangle(self, uv: np.ndarray) -> np.ndarray:
        uv = np.asarray(uv, dtype=float)
        low, high = np.array(self.bounds[0::2]), np.array(self.bounds[1::2])
        return np.all((uv >= low) & (uv <= high), axis=-1)

    def _lookup(self, raster: np.ndarray | None, uv: np.ndarray) -> np.ndarray:
        """In the rectangle and, where there is a raster, in a True cell of it: (...,) bool."""
        inside = self._in_rectangle(uv)
        if raster is None:
            return inside
        cells = self._cells(uv)
        return inside & raster[cells[..., 0], cells[..., 1]]

    def on_face(self, uv: np.ndarray) -> np.ndarray:
        """True where uv: (..., 2) lies on the face (inside its trimming loops): (...,) bool.

        Points in raster cells near a trimming loop are tested against the loops themselves
        (even-odd rule on the sampled loops), so none is misclassified by a cell's size.
        """
        uv = np.asarray(uv, dtype=float)
        inside = self._lookup(self._on_face, uv)
        if self._loops is None:
            return inside
        cells = self._cells(uv)
        assert self._near_loops is not None   # set in __init__ whenever there are loops
        near = self._in_rectangle(uv) & self._near_loops[cells[..., 0], cells[..., 1]]
        if self._crossings is None:
            self._crossings = LoopCrossings(self._loops)
        inside[near] = self._crossings.inside(uv[near])
        return inside

    def reached(self, uv: np.ndarray) -> np.ndarray:
        """False where uv: (..., 2) lies in a cell of the face a probe cannot reach, else True
        (everywhere when no probe was asked): (...,) bool."""
        uv = np.asarray(uv, dtype=float)
        if self._out_of_reach is None:
            return np.ones(uv.shape[:-1], dtype=bool)
        cells = self._cells(uv)
        return ~self._out_of_reach[cells[..., 0], cells[..., 1]]

    def judged(self, uv: np.ndarray) -> np.ndarray:
        """True where uv: (..., 2) lies on the face and where a probe reaches it (the part of
        the face a substitute's deviation is measured over): (...,) bool."""
        return self.on_face(uv) & self.reached(uv)

    def contains(self, uv: np.ndarray) -> np.ndarray:
        """True where uv: (..., 2) is a feasible probe position: (...,) bool (on the face by
        :meth:`on_face`, near the loops tested against the loops themselves)."""
        feasible = self._lookup(self._feasible, uv)
        if self._loops is not None:
            feasible &= self.on_face(uv)
        return feasible

    def project(self, uv: np.ndarray) -> np.ndarray:
        """Nearest feasible point for each uv: (..., 2) -> (..., 2); feasible points stay put."""
        uv = np.asarray(uv, dtype=float)
        low, high = np.array(self.bounds[0::2]), np.array(self.bounds[1::2])
        clipped = np.minimum(np.maximum(uv, low), high)
        if self._feasible is None:
            return clipped
        if self._nearest is None:
            self._nearest = distance_transform_edt(~self._feasible, return_distances=False,
                                                   return_indices=True)
        cells = self._cells(clipped)
        ok = self._feasible[cells[..., 0], cells[..., 1]]
        target = np.stack([self._nearest[0][cells[..., 0], cells[..., 1]],
                           self._nearest[1][cells[..., 0], cells[..., 1]]], axis=-1)
        centres = low + (target + 0.5) * (high - low) / self.shape
        return np.where(ok[..., None], clipped, centres)

    def unreached_rectangles(self) -> np.ndarray:
        """(K, 4) rectangles (u0, u1, v0, v1) covering the unreached cells (see
        :func:`cell_rectangles`); (0, 4) without any or without a probe."""
        if self.unreached is None:
            return np.zeros((0, 4))
        return cell_rectangles(self.bounds, self.unreached)

    def out_of_reach_rectangles(self) -> np.ndarray | None:
        """(K, 4) rectangles (u0, u1, v0, v1) covering the cells a probe was found not to reach,
        on the face or off it (what :meth:`judged` leaves out besides the trim), for
        :func:`face_domain`'s out_of_reach; None without a probe."""
        if self._out_of_reach is None:
            return None
        return cell_rectangles(self.bounds, self._out_of_reach)

    def from_unit(self, unit: np.ndarray) -> np.ndarray:
        """Map points of the unit square, (..., 2) in [0, 1]^2, onto the feasible box."""
        return self.lower + np.asarray(unit, dtype=float) * (self.upper - self.lower)


def face_domain(model: SurfaceModel, edge_offset: float = 0.0,
                reachable: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                out_of_reach: np.ndarray | None = None) -> FaceDomain:
    """The FaceDomain of a SurfaceModel's face, keeping ``edge_offset`` mm from its edges.

    reachable: None, or callable(points (M, 3) mm, normals (M, 3) unit) -> (M,) bool, where a
    probe can touch the face (cmmsampling.access.reach.Reachability): the cells it cannot reach
    are infeasible too, judged once on a coarser raster (:func:`reachable_cells`). out_of_reach:
    instead of reachable, what a probe was found not to reach before: (K, 4) parameter
    rectangles (u0, u1, v0, v1), an earlier domain's :meth:`FaceDomain.out_of_reach_rectangles`,
    whose cells are out of reach again (the same cells: the raster is the face's own).
    """
    trimmed = model.trimmed
    if out_of_reach is not None and reachable is not None:
        raise ValueError("give reachable or out_of_reach, not both")
    if not trimmed and edge_offset <= 0 and reachable is None and out_of_reach is None:
        return FaceDomain(model.bounds, area=model.area)
    shape = raster_shape(model)
    centres = _cell_centres(model.bounds, shape)
    points = model.points(centres.reshape(-1, 2)).reshape(*shape, 3)
    half_diagonals = 0.5 * _cell_diagonals(points)
    step = max(min(model.diagonal / 1000.0, float(half_diagonals.max())), 1e-6)
    loops = model.trim_loops(step)
    on_face = _inside_loops(loops, centres) if trimmed else np.ones(shape, bool)
    samples = [model.points(loop) for loop in loops]
    distance = _edge_distance(np.concatenate(samples), points)
    gap = max(float(np.linalg.norm(np.diff(loop, axis=0), axis=1).max(initial=0.0)) for loop in samples)
    clearance = distance - 0.5 * gap - half_diagonals
    feasible = on_face & (clearance >= edge_offset)
    cell_areas = _cell_areas(points)
    if reachable is not None:
        placeable, judged = reachable_cells(model, on_face, reachable, centres)
        out_of_reach = ~judged
        feasible &= placeable
    elif out_of_reach is not None:
        out_of_reach = rectangle_cells(model.bounds, shape, out_of_reach)
        feasible &= ~out_of_reach
    unreached = None if out_of_reach is None else on_face & out_of_reach
    reach = float(clearance[on_face].max(initial=0.0))
    margin = 0.5 * gap + 2.0 * float(half_diagonals[on_face].max(initial=0.0))
    return FaceDomain(model.bounds, trimmed, edge_offset, on_face, feasible,
                      float(cell_areas[feasible].sum()), loops, reach, margin, unreached,
                      0.0 if unreached is None else float(cell_areas[unreached].sum()), out_of_reach)


def rectangle_cells(bounds: Sequence[float], shape: Sequence[int], rectangles: np.ndarray) -> np.ndarray:
    """The raster (shape: (R_u, R_v) cells over bounds (u0, u1, v0, v1)) whose True cells the
    rectangles (K, 4) of :func:`cell_rectangles` on that raster cover: (R_u, R_v) bool."""
    cells = np.zeros(tuple(shape), dtype=bool)
    u0, u1, v0, v1 = bounds
    scale = np.array([shape[0] / (u1 - u0), shape[0] / (u1 - u0), shape[1] / (v1 - v0), shape[1] / (v1 - v0)])
    edges = np.rint((np.asarray(rectangles, dtype=float).reshape(-1, 4) - [u0, u0, v0, v0]) * scale).astype(int)
    for a, b, c, d in edges:
        cells[a:b, c:d] = True
    return cells


def cell_rectangles(bounds: Sequence[float], cells: np.ndarray) -> np.ndarray:
    """Parameter rectangles covering the True cells of a raster: (K, 4) rows (u0, u1, v0, v1).

    bounds: (u0, u1, v0, v1) of the raster; cells: (R_u, R_v) bool. Each row's runs of True
    cells along v make rectangles, and a run repeated in the next rows joins them, so that a
    region takes few rectangles (a drawing's, a file's).
    """
    cells = np.asarray(cells, dtype=bool)
    padded = np.pad(cells, ((0, 0), (1, 1))).astype(np.int8)
    rows, edges = np.nonzero(np.diff(padded, axis=1))
    runs = np.column_stack([rows[0::2], edges[0::2], edges[1::2]])
    runs = runs[np.lexsort((runs[:, 0], runs[:, 2], runs[:, 1]))]
    joins = ((np.diff(runs[:, 0]) == 1) & (np.diff(runs[:, 1]) == 0) & (np.diff(runs[:, 2]) == 0))
    firsts = np.flatnonzero(np.concatenate([[True], ~joins])) if len(runs) else np.zeros(0, int)
    lasts = np.concatenate([firsts[1:] - 1, [len(runs) - 1]]) if len(runs) else np.zeros(0, int)
    u0, u1, v0, v1 = bounds
    du, dv = (u1 - u0) / cells.shape[0], (v1 - v0) / cells.shape[1]
    return np.column_stack([u0 + runs[firsts, 0] * du, u0 + (runs[lasts, 0] + 1) * du,
                            v0 + runs[firsts, 1] * dv, v0 + runs[firsts, 2] * dv])


def reachable_cells(model: NurbsPatch, on_face: np.ndarray, reachable: Callable[[np.ndarray, np.ndarray], np.ndarray],
                    centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a probe reaches the raster's cells: (placeable, judged), each (R_u, R_v) bool.

    The coarse cells (about REACH_CELLS in all, each covering whole cells of the raster) over
    the face (``on_face`` (R_u, R_v) bool) are asked once, each at the mean parameters of its
    cells' centres (R_u, R_v, 2) on the face (a coarse cell's own centre may lie off it). A cell
    counts only where its coarse cell and their eight neighbours are reached, so that a cell's far
    corner is judged too; a neighbour off the face counts as unreached for ``placeable`` (the
    cells a point may go: along the face's edges the probe gets that margin more, erring on the
    side of refusing) and as reached for ``judged`` (the part of the face judged, which the face's
    own edges should not eat into). reachable: see :func:`face_domain`."""
    shape = np.array(on_face.shape)
    factor = max(1, int(np.ceil(np.sqrt(on_face.size / REACH_CELLS))))
    coarse = tuple(-(-shape // factor))
    rows, cols = np.nonzero(on_face)
    index = np.ravel_multi_index((rows // factor, cols // factor), coarse)
    count = np.bincount(index, minlength=int(np.prod(coarse)))
    asked = np.flatnonzero(count)
    middles = np.column_stack([np.bincount(index, weights=centres[rows, cols, k], minlength=count.size)[asked]
                               for k in range(2)]) / count[asked, None]
    answers = reachable(model.points(middles), model.normals(middles))
    placeable, judged = np.zeros(coarse, dtype=bool), np.ones(coarse, dtype=bool)
    placeable.ravel()[asked], judged.ravel()[asked] = answers, answers
    fine = (np.arange(shape[0])[:, None] // factor, np.arange(shape[1])[None, :] // factor)
    return cast("tuple[np.ndarray, np.ndarray]",
                tuple(minimum_filter(cells, size=3, mode="nearest")[fine] for cells in (placeable, judged)))


def raster_shape(model: NurbsPatch) -> tuple[int, int]:
    """(R_u, R_v) cells of the raster, about CELLS in all, in proportion to the face's 3D extent
    along u and along v (the longest iso-parametric line of SHAPE_SAMPLES in each direction),
    so that the cells are about square in 3D; at least MIN_CELLS_PER_SIDE along each."""
    u0, u1, v0, v1 = model.bounds
    grid = np.stack(np.meshgrid(np.linspace(u0, u1, SHAPE_SAMPLES), np.linspace(v0, v1, SHAPE_SAMPLES),
                                indexing="ij"), -1)
    points = model.points(grid.reshape(-1, 2)).reshape(SHAPE_SAMPLES, SHAPE_SAMPLES, 3)
    along_u = np.linalg.norm(np.diff(points, axis=0), axis=-1).sum(axis=0).max()
    along_v = np.linalg.norm(np.diff(points, axis=1), axis=-1).sum(axis=1).max()
    ratio = max(along_u, 1e-12) / max(along_v, 1e-12)
    cells_u = int(np.clip(round(np.sqrt(CELLS * ratio)), MIN_CELLS_PER_SIDE, CELLS // MIN_CELLS_PER_SIDE))
    return cells_u, max(CELLS // cells_u, MIN_CELLS_PER_SIDE)


def _cell_centres(bounds: Sequence[float], shape: Sequence[int]) -> np.ndarray:
    """(R_u, R_v, 2) centres of the raster cells of ``shape`` (R_u, R_v) over the rectangle."""
    u0, u1, v0, v1 = bounds
    u = u0 + (np.arange(shape[0]) + 0.5) * (u1 - u0) / shape[0]
    v = v0 + (np.arange(shape[1]) + 0.5) * (v1 - v0) / shape[1]
    return np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)


def _inside_loops(loops: Sequence[np.ndarray], centres: np.ndarray) -> np.ndarray:
    """Even-odd classification of the raster cell centres against the trimming loops: (R_u, R_v) bool."""
    u = centres[:, 0, 0]
    v = centres[0, :, 1]
    crossings: list[list[np.ndarray]] = [[] for _ in v]
    for loop in loops:
        a, b = loop, np.roll(loop, -1, axis=0)
        low, high = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
        spans = (low[:, None] <= v[None, :]) & (v[None, :] < high[:, None])
        seg, col = np.nonzero(spans)
        t = (v[col] - a[seg, 1]) / (b[seg, 1] - a[seg, 1])
        at = a[seg, 0] + t * (b[seg, 0] - a[seg, 0])
        for j in np.unique(col):
            crossings[j].append(at[col == j])
    inside = np.zeros((len(u), len(v)), dtype=bool)
    for j, parts in enumerate(crossings):
        if parts:
            xs = np.sort(np.concatenate(parts))
            inside[:, j] = np.searchsorted(xs, u) % 2 == 1
    return inside


def inside_loops(loops: Sequence[np.ndarray], uv: np.ndarray) -> np.ndarray:
    """Even-odd test of points uv (M, 2) against the loops (list of (K, 2) closed polygons): (M,) bool."""
    return LoopCrossings(loops).inside(uv)


class LoopCrossings:
    """The even-odd test against closed polygons in (u, v), with their segments sorted into BANDS
    bands of v: a point is tested against the segments of its own band only (a trimming loop of
    thousands of segments crosses a few bands each), the same crossings as against all of them.

    loops: list of (K, 2) closed polygons (the last vertex joins the first).
    """

    def __init__(self, loops: Sequence[np.ndarray], bands: int = BANDS) -> None:
        starts = np.concatenate(loops)
        ends = np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
        spanning = starts[:, 1] != ends[:, 1]
        self.starts, self.ends = starts[spanning], ends[spanning]
        self.slope = (self.ends[:, 0] - self.starts[:, 0]) / (self.ends[:, 1] - self.starts[:, 1])
        low = np.minimum(self.starts[:, 1], self.ends[:, 1])
        high = np.maximum(self.starts[:, 1], self.ends[:, 1])
        self.v0 = float(low.min(initial=0.0))
        self.width = max(float(high.max(initial=0.0)) - self.v0, 1e-300) / bands
        self.bands = bands
        first, last = self.band(low), self.band(high)
        self.members = [np.flatnonzero((first <= b) & (last >= b)) for b in range(bands)]

    def band(self, v: np.ndarray) -> np.ndarray:
        """Band index (...,) int of v (...,), clipped to the bands."""
        return np.clip(np.floor((np.asarray(v, dtype=float) - self.v0) / self.width), 0, self.bands - 1).astype(int)

    def inside(self, uv: np.ndarray, block: int = 4096) -> np.ndarray:
        """(M,) bool: uv (M, 2) inside the polygons (even-odd rule)."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        inside = np.zeros(len(uv), dtype=bool)
        bands = self.band(uv[:, 1])
        for b in np.unique(bands):
            points = np.flatnonzero(bands == b)
            segments = self.members[b]
            for first in range(0, len(points), block):
                chosen = points[first:first + block]
                inside[chosen] = self._crossings(uv[chosen], segments) % 2 == 1
        return inside

    def _crossings(self, uv: np.ndarray, segments: np.ndarray) -> np.ndarray:
        """Crossings (M,) of the rays from uv (M, 2) towards +u with the given segments."""
        starts, ends = self.starts[segments], self.ends[segments]
        u, v = uv[:, 0, None], uv[:, 1, None]
        crosses = (starts[:, 1] <= v) != (ends[:, 1] <= v)
        at = starts[:, 0] + (v - starts[:, 1]) * self.slope[segments]
        return (crosses & (at > u)).sum(axis=1)


def _edge_distance(samples: np.ndarray, points: np.ndarray) -> np.ndarray:
    """3D distance (mm) from each cell centre, points (R_u, R_v, 3), to the nearest of the edge
    samples (K, 3): (R_u, R_v). Every point of an edge is within about half the largest gap
    between consecutive samples of a sample; less that and half the cell's diagonal, it is a
    distance every point of the cell keeps from the edges."""
    return cKDTree(samples).query(points.reshape(-1, 3))[0].reshape(points.shape[:2])


def _cell_diagonals(points: np.ndarray) -> np.ndarray:
    """Approximate 3D diagonal of each raster cell from its neighbours' centres: (R_u, R_v) mm."""
    du = np.linalg.norm(np.gradient(points, axis=0), axis=-1)
    dv = np.linalg.norm(np.gradient(points, axis=1), axis=-1)
    return np.hypot(du, dv)


def _cell_areas(points: np.ndarray) -> np.ndarray:
    """Approximate 3D area of each raster cell: (R_u, R_v) mm^2."""
    su = np.gradient(points, axis=0)
    sv = np.gradient(points, axis=1)
    return np.linalg.norm(np.cross(su, sv), axis=-1)
