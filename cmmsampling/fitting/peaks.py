"""Where the deviation peaks between the nodes: local searches about the nodes of largest deviation.

The nodes (cmmsampling.fitting.nodes) sample the face; between them the two-sided deviation can
be larger than at any node: on a crease of the face (a knot line where it is only C0), beside a
trimmed edge, or on a large face whose raster is coarse. Each node that is a local maximum of the
nodes within PEAK_SHARE of the largest (at most PEAK_NODES of them, largest first) starts a search
for the local maximum beside it, all of them at once: ZOOM_ROUNDS rounds of a grid of ZOOM_STEPS
steps either side of the best place so far, over the raster cells about it (both parameters) or
along its edge's curve a segment either side, each round's grid as wide as the last one's step,
until a round raises the largest deviation by no more than ZOOM_GAIN of it. Trials off the face
are not measured. The places measured inside raster cells where the substitute is stretched
(cmmsampling.fitting.stretch) start searches too, the largest of them (at most PEAK_NODES, none
within a place's step of a larger one), over that place's step either side. The places where a
search found more than its start join the nodes (cmmsampling.fitting.exact), so that the figure
reported is the local maximum found, not the value at the node beside it.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .nodes import edge_curve_uv
from .sides import Side
from .stretch import FinePlaces

if TYPE_CHECKING:
    from .nodes import FaceNodes

PEAK_SHARE = 0.8
PEAK_NODES = 64
ZOOM_ROUNDS = 4
ZOOM_STEPS = 4
# A round that raises no search by more than this share of the largest deviation is the last.
ZOOM_GAIN = 1e-6
_NEIGHBOURS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)])
_LINE = np.concatenate([np.arange(-ZOOM_STEPS, 0), np.arange(1, ZOOM_STEPS + 1)]) / ZOOM_STEPS
_PLANE = np.array([(a, b) for a in range(-ZOOM_STEPS, ZOOM_STEPS + 1) for b in range(-ZOOM_STEPS, ZOOM_STEPS + 1)
                   if a or b], dtype=float) / ZOOM_STEPS


@dataclass
class FineStarts:
    """Places measured inside stretched raster cells: places, FinePlaces (cmmsampling.fitting.stretch);
    forward, reverse: the Sides there."""

    places: FinePlaces
    forward: Side
    reverse: Side

    @classmethod
    def none(cls) -> FineStarts:
        """No places."""
        return cls(FinePlaces.none(), Side.zeros(0), Side.zeros(0))

    @property
    def sizes(self) -> np.ndarray:
        """(M,) |d| mm, the larger side at each place."""
        return np.maximum(np.abs(self.forward.values), np.abs(self.reverse.values))

    @property
    def start(self) -> np.ndarray:
        """(M, 2) the forward sides' parameters on the substitute."""
        return self.forward.at

    def largest(self, largest: float) -> np.ndarray:
        """Indices of at most PEAK_NODES places whose sizes lie within PEAK_SHARE of ``largest``
        mm, largest first, none within a step (FinePlaces.half) of one taken before: a search
        starts from each."""
        sizes = self.sizes
        order = np.argsort(-sizes, kind="stable")
        left = order[(sizes[order] >= PEAK_SHARE * largest) & (largest > 0)]
        taken: list[int] = []
        while left.size and len(taken) < PEAK_NODES:
            taken.append(left[0])
            uv, half = self.places.uv, self.places.half[left[0]]
            left = left[(np.abs(uv[left] - uv[left[0]]) > 1.01 * half).any(1)]
        return np.array(taken, dtype=int)


@dataclass
class Peaks:
    """The peaks found: uv (P, 2) their parameters on the face; origin (P,) the index of the node
    each search started from; forward, reverse: the Sides there."""

    uv: np.ndarray
    origin: np.ndarray
    forward: Side
    reverse: Side


def peak_search(nodes: FaceNodes, sizes: np.ndarray, start: np.ndarray,
                sides_at: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Side, Side]],
                on_face: Callable[[np.ndarray], np.ndarray] | None, fine: FineStarts | None = None) -> Peaks:
    """The Peaks found about the largest nodes: the places where a search found more than its node.

    nodes: FaceNodes; sizes: (K,) |d| mm at the counted raster nodes then the edge nodes; start:
    (K, 2) the forward sides' parameters on the substitute at the nodes; sides_at: (h (M, 2),
    origin (M,) node index, start (M, 2)) -> (forward, reverse) Sides at the face's points F(h),
    the forward foot searched from ``start``; on_face: h (M, 2) -> (M,) bool (None: the whole
    rectangle); fine: FineStarts, places measured inside stretched raster cells
    (cmmsampling.fitting.stretch), whose largest start searches too (None: none).
    """
    fine = fine or FineStarts.none()
    fine_sizes = fine.sizes
    largest = max(sizes.max(initial=0.0), fine_sizes.max(initial=0.0))
    top = largest_nodes(sizes, local_maxima(nodes, sizes), largest)
    counted = int(nodes.counted.sum())
    picked = fine.largest(largest)
    on_raster, on_edges = top[top < counted], top[top >= counted]
    origin = np.concatenate([on_raster, fine.places.origin[picked], on_edges])
    centre, half = _raster_cells(nodes, on_raster)
    raster = _RasterZoom(np.concatenate([centre, fine.places.uv[picked]]),
                         np.concatenate([half, fine.places.half[picked]]), nodes.uv[0, 0], nodes.uv[-1, -1], on_face)
    edge = _EdgeZoom(nodes, on_edges - counted)
    split = len(raster.centre)
    per = np.repeat([len(_PLANE), len(_LINE)], [split, len(edge.place)])
    first = np.cumsum(per) - per
    whole = split * len(_PLANE)
    best = np.concatenate([sizes[on_raster], fine_sizes[picked], sizes[on_edges]]).astype(float)
    foot = np.concatenate([start[on_raster], fine.start[picked], start[on_edges]])
    rows = _Rows(origin)
    for _ in range(ZOOM_ROUNDS if len(origin) else 0):
        uv_raster, keep = raster.trials()
        uv = np.concatenate([uv_raster.reshape(-1, 2), edge.trials().reshape(-1, 2)])
        keep = np.concatenate([keep.ravel(), np.ones(len(uv) - keep.size, dtype=bool)])
        forward, reverse, size = _measured(sides_at, uv, keep, np.repeat(origin, per), np.repeat(foot, per, axis=0))
        pick = first + np.concatenate([np.argmax(size[:whole].reshape(split, len(_PLANE)), axis=1),
                                       np.argmax(size[whole:].reshape(-1, len(_LINE)), axis=1)])
        gain = size[pick] > best
        before = best.max()
        best[gain], foot[gain] = size[pick[gain]], forward.at[pick[gain]]
        rows.take(gain, pick, uv, forward, reverse)
        if best.max() - before <= ZOOM_GAIN * before:
            break
        raster.move(gain[:split], (pick - first)[:split])
        edge.move(gain[split:], (pick - first)[split:])
    return rows.peaks()


def _measured(sides_at: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Side, Side]], uv: np.ndarray,
              keep: np.ndarray, origin: np.ndarray, start: np.ndarray) -> tuple[Side, Side, np.ndarray]:
    """(forward, reverse, size): the Sides' values, at and directions (M entries each, zero where
    ``keep`` (M,) is False) and |d| (M,) mm (-inf there) at the trials uv (M, 2), measured (by
    sides_at) only where keep says they are on the face."""
    forward, reverse = Side.zeros(len(uv)), Side.zeros(len(uv))
    size = np.full(len(uv), -np.inf)
    if keep.any():
        ahead, back = sides_at(uv[keep], origin[keep], start[keep])
        forward.put(keep, ahead)
        reverse.put(keep, back)
        size[keep] = np.maximum(np.abs(ahead.values), np.abs(back.values))
    return forward, reverse, size


def largest_nodes(sizes: np.ndarray, peaked: np.ndarray, largest: float | None = None) -> np.ndarray:
    """Indices of the nodes ``peaked`` marks (K,) bool whose sizes (K,) lie within PEAK_SHARE of
    ``largest`` (mm; None: the largest size), at most PEAK_NODES of them, largest first (none
    where that is 0)."""
    largest = sizes.max(initial=0.0) if largest is None else largest
    order = np.argsort(-np.where(peaked, sizes, -np.inf), kind="stable")[:PEAK_NODES]
    return order[peaked[order] & (sizes[order] >= PEAK_SHARE * largest) & (largest > 0)]


def local_maxima(nodes: FaceNodes, sizes: np.ndarray) -> np.ndarray:
    """(K,) True at the nodes whose size is no less than their neighbours': a raster node's 8
    counted raster neighbours, an edge node's neighbours along its run."""
    counted = int(nodes.counted.sum())
    grid = np.full(np.add(nodes.size, 2), -np.inf)
    grid[1:-1, 1:-1][nodes.counted] = sizes[:counted]
    centre = grid[1:-1, 1:-1]
    raster = np.ones(nodes.size, dtype=bool)
    for du, dv in _NEIGHBOURS:
        raster &= centre >= grid[1 + du:grid.shape[0] - 1 + du, 1 + dv:grid.shape[1] - 1 + dv]
    edge = sizes[counted:]
    index = np.arange(len(edge))
    runs = nodes.edge_runs
    before = np.where(index > runs[:, 0], edge[np.maximum(index - 1, 0)], -np.inf)
    after = np.where(index < runs[:, 1] - 1, edge[np.minimum(index + 1, max(len(edge) - 1, 0))], -np.inf)
    return np.concatenate([raster[nodes.counted], (edge >= before) & (edge >= after)])


class _Rows:
    """The Side rows at each search's best place found so far (none until it gains); origin (S,)
    the node each search started from."""

    def __init__(self, origin: np.ndarray) -> None:
        self.origin = origin
        self.gained = np.zeros(len(origin), dtype=bool)
        self.uv = np.zeros((len(origin), 2))
        self.forward, self.reverse = Side.zeros(len(origin)), Side.zeros(len(origin))

    def take(self, gain: np.ndarray, pick: np.ndarray, uv: np.ndarray, forward: Side, reverse: Side) -> None:
        """Keep the trials' rows ``pick`` (S,) where ``gain`` (S,) bool; uv (M, 2) the trials."""
        chosen = pick[gain]
        self.gained |= gain
        self.uv[gain] = uv[chosen]
        self.forward.put(gain, forward.rows(chosen))
        self.reverse.put(gain, reverse.rows(chosen))

    def peaks(self) -> Peaks:
        """The Peaks of the searches that gained."""
        gained = self.gained
        return Peaks(self.uv[gained], self.origin[gained], self.forward.rows(gained), self.reverse.rows(gained))


class _RasterZoom:
    """Searches over the face's parameters about places on it: centre (R, 2) the best place so
    far; half (R, 2) the next grid's half-widths; low, high (2,) the face's parameter rectangle."""

    def __init__(self, centre: np.ndarray, half: np.ndarray, low: np.ndarray, high: np.ndarray,
                 on_face: Callable[[np.ndarray], np.ndarray] | None) -> None:
        self.centre, self.half = centre, half
        self.low, self.high = low, high
        self.on_face = on_face
        self.grid = np.zeros((len(centre), len(_PLANE), 2))

    def trials(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, T, 2) the grid's places, within the face's rectangle, and (R, T) bool: on the face."""
        self.grid = np.clip(self.centre[:, None, :] + _PLANE * self.half[:, None, :], self.low, self.high)
        keep = np.ones(self.grid.shape[:2], dtype=bool)
        if self.on_face is not None and self.grid.size:
            keep = self.on_face(self.grid.reshape(-1, 2)).reshape(keep.shape)
        return self.grid, keep

    def move(self, gain: np.ndarray, index: np.ndarray) -> None:
        """Centre the next grid on trial ``index`` (R,) where ``gain`` (R,) bool; narrow it."""
        rows = np.flatnonzero(gain)
        self.centre[rows] = self.grid[rows, index[rows]]
        self.half /= ZOOM_STEPS


class _EdgeZoom:
    """Searches along the edges' curves about edge nodes (origin: edge node indices): place (E,)
    the best place so far, a fractional edge node index within its run; half (E,) the next grid's
    half-width, in edge node steps."""

    def __init__(self, nodes: FaceNodes, origin: np.ndarray) -> None:
        self.nodes = nodes
        self.place = origin.astype(float)
        self.runs = nodes.edge_runs[origin]
        self.half = np.ones(len(origin))
        self.grid = np.zeros((len(origin), len(_LINE)))

    def trials(self) -> np.ndarray:
        """(E, T, 2) the grid's places on the face, along the edges' curves within their runs."""
        self.grid = np.clip(self.place[:, None] + _LINE * self.half[:, None],
                            self.runs[:, :1], self.runs[:, 1:] - 1.0)
        runs = np.repeat(self.runs, len(_LINE), axis=0)
        return edge_curve_uv(self.nodes, self.grid.ravel(), runs)[0].reshape(len(self.place), len(_LINE), 2)

    def move(self, gain: np.ndarray, index: np.ndarray) -> None:
        """Centre the next grid on trial ``index`` (E,) where ``gain`` (E,) bool; narrow it."""
        rows = np.flatnonzero(gain)
        self.place[rows] = self.grid[rows, index[rows]]
        self.half /= ZOOM_STEPS


def _raster_cells(nodes: FaceNodes, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre (R, 2), half (R, 2)) of searches about the counted raster nodes ``origin`` (R,):
    the node, and the larger raster step either side of it in u and in v."""
    cells = np.argwhere(nodes.counted)[origin]
    half = np.column_stack([_cell_steps(nodes.uv[:, 0, 0], cells[:, 0]), _cell_steps(nodes.uv[0, :, 1], cells[:, 1])])
    return nodes.uv[nodes.counted][origin], half.reshape(-1, 2)


def _cell_steps(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """The larger of the raster steps either side of raster value ``index`` (M,) in values (g,)."""
    steps = np.diff(values)
    before = steps[np.maximum(index - 1, 0)]
    after = steps[np.minimum(index, len(steps) - 1)]
    return np.maximum(before, after)
