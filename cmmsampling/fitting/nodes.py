"""Where the deviation is measured: nodes on the CAD face itself, covering it.

Two kinds of node, both points of the face F at known parameters:

* a raster of the face's own parameter rectangle, (g_u, g_v) values per direction placed at equal
  steps of the face's longest iso-parametric length (so a rational or unevenly parametrised face
  gets nodes evenly spread in space, not in parameters), counted where the raster point lies on
  the face (inside its trimming loops);
* points along every edge of the face, trim loops and collapsed edges included, at most half a
  raster step apart, with the corners, and close enough that the cubic through them follows the
  edge's curve (:func:`edge_node_uv`).

``spacing`` (mm) is the largest 3D diagonal of a raster cell: every point of the face lies within
it of a node. Each edge node also carries the in-surface directions its deviation is measured along
besides the normal (``across``): the edge's outward conormal, so that a substitute whose edge drifts
inside the face (leaving the face's edge uncovered) or beyond it (reaching past the face) is seen;
at a collapsed edge, where the conormal is undefined, the whole offset counts.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

DEFAULT_GRID = 60
# Samples per raster step when the raster's parameter values are placed (their lengths are summed).
LENGTH_SAMPLES = 4
# Edge nodes per raster step (3D) along every edge.
EDGE_NODES_PER_STEP = 2
# Edge nodes per edge span (cmmsampling.geometry.surface.SurfaceModel.edge_spans): at least
# EDGE_NODES_LEAST and what the spacing and raster ask for (span_needs), doubled until the cubic
# through them (edge_curve_uv), which the edge searches follow, keeps within EDGE_CURVE_MM (3D) of
# the span halfway between nodes, but not beyond EDGE_NODES_MOST or what span_needs asks for.
EDGE_NODES_LEAST = 5
EDGE_NODES_MOST = 257
EDGE_CURVE_MM = 1e-7
# Points of each edge span its length and raster steps are measured along.
SPAN_PROBES = 33
# The longest edge piece searched for the nearest edge point, in median segments.
PIECE_MEDIANS = 2.0


@dataclass
class FaceNodes:
    """Nodes on the face (see the module docstring).

    uv: (g_u, g_v, 2) the raster; points: (g_u, g_v, 3) F(uv) mm; normals: (g_u, g_v, 3) unit, out
    of the material; counted: (g_u, g_v) bool, on the face with a point and a normal;
    edge_uv: (E, 2); edge_points: (E, 3) mm; edge_normals: (E, 3) unit; edge_across: (E, 2, 3) the
    directions an edge node's offset is measured along besides the normal (rows of zeros where
    unused); loops: list of (start, stop) index ranges of edge_uv, one closed polygon each;
    edge_runs: (E, 2) int, the [start, stop) index range of the run each edge node is in: samples
    of one edge span's curve on the surface at equal parameter steps; spacing: mm, the largest raster
    cell diagonal; edge_counted: (E,) bool, the edge nodes whose deviation counts (None: all; the
    others lie where a probe cannot reach the face and stay for the edges' geometry only);
    principal: the face's curvature terms at the raster nodes, once computed
    (cmmsampling.fitting.deviation.nodes_principal_terms).
    """

    uv: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    counted: np.ndarray
    edge_uv: np.ndarray
    edge_points: np.ndarray
    edge_normals: np.ndarray
    edge_across: np.ndarray
    loops: list
    edge_runs: np.ndarray
    spacing: float
    edge_counted: np.ndarray | None = None
    principal: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False, compare=False)

    @property
    def size(self) -> tuple[int, ...]:
        """(g_u, g_v) of the raster."""
        return self.counted.shape

    @property
    def edge_weights(self) -> np.ndarray:
        """(E,) 1.0 at the edge nodes whose deviation counts, 0.0 at the others."""
        if self.edge_counted is None:
            return np.ones(len(self.edge_uv))
        return self.edge_counted.astype(float)

    def node_weights(self) -> np.ndarray:
        """(K,) 1.0 at the counted raster nodes then at the edge nodes whose deviation counts, 0.0
        at the other edge nodes: the nodes in the order of :meth:`all_points`."""
        return np.concatenate([np.ones(int(self.counted.sum())), self.edge_weights])

    def all_points(self) -> np.ndarray:
        """The counted raster nodes then the edge nodes: (K, 3) mm."""
        return np.concatenate([self.points[self.counted], self.edge_points])

    @cached_property
    def point_tree(self) -> cKDTree:
        """A k-d tree of :meth:`all_points`, built once per face and kept."""
        return cKDTree(self.all_points())

    @cached_property
    def edge_pieces(self) -> SimpleNamespace:
        """The edge polygons' segments cut into pieces for the nearest edge point, built once
        per face and kept: see :func:`edge_pieces`."""
        return edge_pieces(self)


def face_nodes(model: Any, size: int | Sequence[int] = DEFAULT_GRID,
               on_face: Callable[[np.ndarray], np.ndarray] | None = None,
               reached: Callable[[np.ndarray], np.ndarray] | None = None) -> FaceNodes:
    """The FaceNodes of a face.

    model: SurfaceModel (its ``edge_spans`` and ``span_samples`` give the edges) or, for
    tests, anything with ``bounds``, ``points``, ``normals``, ``edge_spans`` and
    ``span_samples``; size: int or (g_u, g_v); on_face:
    uv (..., 2) -> (...) bool, the face's trim test (None: the whole parameter rectangle);
    reached: uv (..., 2) -> (...) bool, where a probe reaches the face (None: everywhere): the
    raster and edge nodes elsewhere do not count.
    """
    size = grid_size(size)
    uv = length_raster(model, size)
    points, normals = model.points(uv), model.normals(uv)
    counted = np.isfinite(points).all(-1) & np.isfinite(normals).all(-1)
    if on_face is not None:
        counted &= on_face(uv)
    if reached is not None:
        counted &= reached(uv)
    spacing = _largest_cell_diagonal(points)
    step = max(spacing / EDGE_NODES_PER_STEP, 1e-9 * max(spacing, 1.0))
    wires = [edges for edges in edge_node_uv(model, step, uv) if edges]
    sizes = [len(edge) for edges in wires for edge in edges]
    edge_uv = np.concatenate([edge for edges in wires for edge in edges]) if sizes else np.zeros((0, 2))
    bounds = np.cumsum([0] + [sum(len(edge) for edge in edges) for edges in wires])
    edge_points, edge_normals = model.points(edge_uv), model.normals(edge_uv)
    across = edge_directions(edge_points, edge_normals, list(zip(bounds[:-1], bounds[1:])))
    keep = np.isfinite(edge_points).all(-1)
    edge_normals = np.where(np.isfinite(edge_normals).all(-1, keepdims=True), edge_normals, [0.0, 0.0, 1.0])
    edge_counted = None if reached is None else reached(edge_uv[keep])
    return FaceNodes(uv, points, normals, counted, edge_uv[keep], edge_points[keep], edge_normals[keep],
                     across[keep], _ranges(bounds, keep), _runs(sizes, keep), spacing, edge_counted)


def edge_node_uv(model: Any, step: float, raster: np.ndarray) -> list[list[np.ndarray]]:
    """The edge nodes' (u, v), a list per wire of (K, 2) arrays, one per edge span
    (``model.edge_spans``) in the wire's order. A span's nodes are at least as many as
    :func:`span_needs` asks for and EDGE_NODES_LEAST, doubled until the cubic through them
    follows the span within EDGE_CURVE_MM, and never more than the larger of what it asks for and
    EDGE_NODES_MOST. step: mm; raster: the (g_u, g_v, 2) raster of the face's nodes."""
    sizes = [len(spans) for spans in model.edge_spans]
    probes = _flat(model.span_samples([[SPAN_PROBES] * size for size in sizes]))
    needs = np.array([span_needs(model, uv, step, raster) for uv in probes], dtype=int)
    most = np.maximum(needs, EDGE_NODES_MOST)
    counts = np.maximum(needs, EDGE_NODES_LEAST)
    spans = _flat(model.span_samples(_nested(counts, sizes)))
    pending = counts < most
    while pending.any():
        finer = np.where(pending, np.minimum(2 * counts - 1, most), 0)
        fine = _flat(model.span_samples(_nested(finer, sizes)))
        for k in np.flatnonzero(pending):
            halved = finer[k] == 2 * counts[k] - 1
            if halved and _strays(model, spans[k], fine[k][1::2]) <= EDGE_CURVE_MM:
                pending[k] = False
            else:
                spans[k], counts[k], pending[k] = fine[k], finer[k], finer[k] < most[k]
    return _nested(spans, sizes)


def span_needs(model: Any, uv: np.ndarray, step: float, raster: np.ndarray) -> int:
    """The nodes an edge span needs, from its points uv (P, 2) in order: enough that they are at
    most ``step`` mm apart along it (3D), and EDGE_NODES_PER_STEP per raster step it crosses in
    either parameter (raster (g_u, g_v, 2)), so that along an edge the nodes are as dense as the
    raster is across it (on a narrow strip the raster's steps across it are far shorter than the
    cell diagonals that set ``step``)."""
    length = np.nan_to_num(np.linalg.norm(np.diff(model.points(uv), axis=0), axis=1)).sum()
    cells_u = np.interp(uv[:, 0], raster[:, 0, 0], np.arange(raster.shape[0]))
    cells_v = np.interp(uv[:, 1], raster[0, :, 1], np.arange(raster.shape[1]))
    crossed = np.abs(np.diff(cells_u)).sum() + np.abs(np.diff(cells_v)).sum()
    return int(np.ceil(max(length / step, EDGE_NODES_PER_STEP * crossed))) + 1


def _flat(wires: Sequence[Sequence[Any]]) -> list[Any]:
    """A list per wire of per-edge items as one list of the items."""
    return [item for wire in wires for item in wire]


def _nested(items: Sequence[Any] | np.ndarray, sizes: Sequence[int]) -> list[list[Any]]:
    """The per-edge items (E,) back as a list per wire of ``sizes`` (number of edges per wire)."""
    bounds = np.cumsum([0] + list(sizes))
    return [list(items[start:stop]) for start, stop in zip(bounds[:-1], bounds[1:])]


def _strays(model: Any, uv: np.ndarray, halfway: np.ndarray) -> float:
    """mm, the largest 3D distance between the cubic through an edge's samples uv (K, 2)
    (edge_curve_uv) and the edge's true points halfway between them, halfway (K - 1, 2)."""
    if len(uv) < 2:
        return 0.0
    nodes = SimpleNamespace(edge_uv=uv)
    runs = np.tile([0, len(uv)], (len(uv) - 1, 1))
    cubic = edge_curve_uv(nodes, np.arange(len(uv) - 1) + 0.5, runs)[0]
    gap = np.linalg.norm(model.points(cubic) - model.points(halfway), axis=1)
    return float(np.nanmax(gap, initial=0.0))


def grid_size(size: Any) -> tuple[int, ...]:
    """(n_u, n_v) from an int or a pair."""
    pair = (size, size) if np.ndim(size) == 0 else tuple(size)
    return tuple(int(s) for s in pair)


def length_raster(model: Any, size: Sequence[int]) -> np.ndarray:
    """A (g_u, g_v, 2) raster of the parameter rectangle whose values along each direction are
    at equal steps of the face's longest iso-parametric length in that direction."""
    u0, u1, v0, v1 = model.bounds
    fine = (LENGTH_SAMPLES * (size[0] - 1) + 1, LENGTH_SAMPLES * (size[1] - 1) + 1)
    su, sv = np.linspace(u0, u1, fine[0]), np.linspace(v0, v1, fine[1])
    points = model.points(np.stack(np.meshgrid(su, sv, indexing="ij"), -1))
    steps_u = np.nan_to_num(np.linalg.norm(np.diff(points, axis=0), axis=-1)).max(axis=1)
    steps_v = np.nan_to_num(np.linalg.norm(np.diff(points, axis=1), axis=-1)).max(axis=0)
    u = _equal_length_values(su, steps_u, size[0])
    v = _equal_length_values(sv, steps_v, size[1])
    return np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)


def _equal_length_values(samples: np.ndarray, steps: np.ndarray, count: int) -> np.ndarray:
    """``count`` parameter values from samples[0] to samples[-1] at equal steps of the cumulated
    lengths ``steps`` (len(samples) - 1,) between the samples (equal parameter steps where the
    face has no length)."""
    length = np.concatenate([[0.0], np.cumsum(steps)])
    if not length[-1] > 0:
        return np.linspace(samples[0], samples[-1], count)
    length = length + 1e-9 * length[-1] * np.linspace(0.0, 1.0, len(length))
    values = np.interp(np.linspace(0.0, length[-1], count), length, samples)
    values[0], values[-1] = samples[0], samples[-1]
    return values


def edge_directions(points: np.ndarray, normals: np.ndarray, loops: Sequence[tuple[int, int]]) -> np.ndarray:
    """(E, 2, 3) for edge nodes (E, 3) with unit normals (E, 3) on closed polygons ``loops``
    ((start, stop) ranges): the outward conormal and a zero row where the edge has a direction;
    two tangent directions spanning the plane across the normal where it has none (a collapsed
    edge); the x and y axes where a node has no normal either (:func:`face_nodes` then gives it
    the z axis as its normal, so the offset's whole length is measured)."""
    across = np.zeros((len(points), 2, 3))
    for start, stop in loops:
        if stop - start < 2:
            continue
        piece = points[start:stop]
        tangent = np.roll(piece, -1, axis=0) - np.roll(piece, 1, axis=0)
        across[start:stop] = _across(tangent, normals[start:stop], scale=np.ptp(points, axis=0).max())
    return across


def _across(tangent: np.ndarray, normals: np.ndarray, scale: float) -> np.ndarray:
    """The directions of :func:`edge_directions` for one loop."""
    rows = np.zeros((len(tangent), 2, 3))
    finite = np.isfinite(normals).all(1)
    length = np.linalg.norm(tangent, axis=1)
    regular = finite & (length > 1e-9 * max(scale, 1e-12))
    conormal = np.cross(tangent[regular], normals[regular])
    rows[regular, 0] = conormal / np.linalg.norm(conormal, axis=1, keepdims=True)
    collapsed = np.flatnonzero(finite & ~regular)
    if collapsed.size:
        first, second = _plane_basis(normals[collapsed])
        rows[collapsed, 0], rows[collapsed, 1] = first, second
    lost = np.flatnonzero(~finite)
    rows[lost, 0], rows[lost, 1] = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    return rows


def _plane_basis(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (M, 3) each, across the unit normals (M, 3) and each other."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    first = np.cross(normals, helper)
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    return first, np.cross(normals, first)


def _largest_cell_diagonal(points: np.ndarray) -> float:
    """The largest 3D diagonal (mm) of the raster's cells, points (g_u, g_v, 3)."""
    diagonals = cell_diagonals(points)
    return float(np.nanmax(diagonals)) if diagonals.size else 0.0


def cell_diagonals(points: np.ndarray) -> np.ndarray:
    """(g_u - 1, g_v - 1) the longer 3D diagonal (mm) of each raster cell, points (g_u, g_v, 3)."""
    first = np.linalg.norm(points[:-1, :-1] - points[1:, 1:], axis=-1)
    second = np.linalg.norm(points[1:, :-1] - points[:-1, 1:], axis=-1)
    return np.maximum(first, second)


def _ranges(bounds: np.ndarray, keep: np.ndarray) -> list[tuple[int, int]]:
    """The (start, stop) ranges of the loops after dropping the nodes ``keep`` marks False."""
    kept = np.concatenate([[0], np.cumsum(keep)])
    return [(int(kept[start]), int(kept[stop])) for start, stop in zip(bounds[:-1], bounds[1:])
            if kept[stop] > kept[start]]


def _runs(sizes: Sequence[int], keep: np.ndarray) -> np.ndarray:
    """(E, 2) int: for each kept edge node, the [start, stop) range (among the kept nodes) of its
    run: the kept samples of one edge with no dropped sample between them. sizes: samples per
    edge, in order; keep: (sum(sizes),) bool."""
    edge = np.repeat(np.arange(len(sizes)), sizes)
    begins = np.ones(len(edge), dtype=bool)
    begins[1:] = (edge[1:] != edge[:-1]) | ~keep[:-1]
    run = np.cumsum(begins)[keep]
    return np.column_stack([np.searchsorted(run, run, "left"), np.searchsorted(run, run, "right")])


def edge_curve_uv(nodes: Any, place: np.ndarray, runs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edge's curve on the surface at ``place`` (M,), a fractional edge node index within its
    run runs (M, 2) [start, stop): the cubic through the 4 run samples around it (equal parameter
    steps), or the chord where the run has fewer than 4. Returns ((M, 2) uv, (M, 2) its
    derivative per edge node step)."""
    stencil = np.clip(np.floor(place).astype(int) - 1, runs[:, 0], np.maximum(runs[:, 1] - 4, runs[:, 0]))
    s = place - stencil
    cubic = runs[:, 1] - runs[:, 0] >= 4
    weights = np.column_stack([-(s - 1) * (s - 2) * (s - 3) / 6, s * (s - 2) * (s - 3) / 2,
                               -s * (s - 1) * (s - 3) / 2, s * (s - 1) * (s - 2) / 6])
    slopes = np.column_stack([-((s - 2) * (s - 3) + (s - 1) * (s - 3) + (s - 1) * (s - 2)) / 6,
                              ((s - 2) * (s - 3) + s * (s - 3) + s * (s - 2)) / 2,
                              -((s - 1) * (s - 3) + s * (s - 3) + s * (s - 1)) / 2,
                              ((s - 1) * (s - 2) + s * (s - 2) + s * (s - 1)) / 6])
    rows = nodes.edge_uv[np.minimum(stencil[:, None] + np.arange(4), len(nodes.edge_uv) - 1)]
    near = np.clip(np.floor(place).astype(int), runs[:, 0], runs[:, 1] - 1)
    ahead = np.minimum(near + 1, runs[:, 1] - 1)
    fraction = np.clip(place - near, 0.0, 1.0)[:, None]
    chord = (1 - fraction) * nodes.edge_uv[near] + fraction * nodes.edge_uv[ahead]
    curve = np.where(cubic[:, None], np.einsum("mk,mkj->mj", weights, rows), chord)
    slope = np.where(cubic[:, None], np.einsum("mk,mkj->mj", slopes, rows), nodes.edge_uv[ahead] - nodes.edge_uv[near])
    return curve, slope


def edge_pieces(nodes: Any) -> SimpleNamespace:
    """The segments of the face's closed edge polygons (nodes: FaceNodes, or anything with
    ``loops`` and ``edge_points``) cut into equal pieces no longer than PIECE_MEDIANS times the
    median segment, so that a few long segments among many short ones (a long straight edge beside
    finely noded short ones) do not loosen the bound of the nearest edge point's search
    (cmmsampling.fitting.exact). A namespace of: first, second (S,) the segments' edge node
    indices; starts, alongs (P, 3) mm each piece's start and extent; segment_of (P,) the segment
    each piece is part of; fractions (P, 2) where it starts and ends along it, in [0, 1]; middles
    a k-d tree of the pieces' midpoints; half: mm, half the longest piece."""
    first, second = _edge_segments(nodes)
    starts, ends = nodes.edge_points[first], nodes.edge_points[second]
    lengths = np.linalg.norm(ends - starts, axis=1)
    longest = PIECE_MEDIANS * float(np.median(lengths)) if lengths.size else 0.0
    cuts = np.ones(len(lengths), dtype=int) if longest <= 0 else np.maximum(1, np.ceil(lengths / longest).astype(int))
    segment_of = np.repeat(np.arange(len(lengths)), cuts)
    offset = np.arange(len(segment_of)) - np.repeat(np.cumsum(cuts) - cuts, cuts)
    fractions = np.column_stack([offset, offset + 1]) / cuts[segment_of, None]
    along = ends - starts
    a = starts[segment_of] + fractions[:, :1] * along[segment_of]
    b = starts[segment_of] + fractions[:, 1:] * along[segment_of]
    return SimpleNamespace(first=first, second=second, starts=a, alongs=b - a, segment_of=segment_of,
                           fractions=fractions, middles=cKDTree(0.5 * (a + b)),
                           half=0.5 * float(np.linalg.norm(b - a, axis=1).max(initial=0.0)))


def _edge_segments(nodes: Any) -> tuple[np.ndarray, np.ndarray]:
    """(first, second) edge node indices (S,) of every segment of the face's closed edge polygons."""
    starts, ends = [], []
    for start, stop in nodes.loops:
        index = np.arange(start, stop)
        starts.append(index)
        ends.append(np.roll(index, -1))
    return np.concatenate(starts), np.concatenate(ends)
