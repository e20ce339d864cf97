"""The exact deviation of a delivered substitute from the CAD face: a two-sided distance in space.

The substitute S is the fitted surface on its own parameter rectangle (no extension), trimmed like
the face in the parameter plane. At every node of the face (cmmsampling.fitting.nodes: a raster of
the face's domain and points along its edges), at parameters h with F(h) the node:

* forward: the distance from F(h) to S, its closest point p searched over S's rectangle, or on
  S's boundary (S at the face's edge curves) where p lies outside the trim: the substitute
  delivered is trimmed like the face;
* reverse: the distance from S(h) back to the face, its closest point on the face's surface, or
  on the face's edges where that foot lies outside the face's trimming loops.

Each is signed by the face's normal there (+ out of the material); a node's deviation is the one
of larger magnitude. Where the substitute is stretched against the face, places inside those
raster cells (cmmsampling.fitting.stretch) join the nodes; where the deviation peaks between them,
the places found by searches about the largest (cmmsampling.fitting.peaks) join them too, and the
maximum over all of them is the figure reported. OpenCASCADE's distances from the nodes to the
substitute trimmed like the face (``r.substitute_shape()``) and from S(h) to the face agree with
both sides (cmmsampling.fitting.crosscheck, and the tests).

To first order in a change dS of the substitute, each side changes by w . dS(at) with w the unit
direction it is measured along and ``at`` the parameters on S (p forward, h reverse): exact there
in value and gradient, which :class:`Linearisation` hands to the descent and the local bound.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.bspline import kron_rows
from .nodes import FaceNodes, edge_curve_uv, face_nodes
from .peaks import FineStarts, peak_search
from .sides import Side, normals_or
from .stretch import stretched_places
from .substitute import FittedSurface

if TYPE_CHECKING:
    from .stretch import FinePlaces
    from .substitute import SubstituteSpace

FOOT_ITERATIONS = 400
FOOT_STEP_TOLERANCE = 1e-10
DAMPING_FLOOR = 1e-12
DAMPING_CEILING = 1e12
SEARCH_SAMPLES = 48
# More starts for the feet at the largest nodes and at the peaks found between them: the nearest
# samples of a denser raster of the substitute, the nearest nodes of the face.
SETTLE_SAMPLE_STARTS = 24
SETTLE_NODE_STARTS = 8
SETTLE_SAMPLES = 2 * SEARCH_SAMPLES
SETTLE_NODES = 32
SETTLE_PASSES = 3
# Edge pieces tried first for a point's nearest edge point, and the (point, piece) pairs compared
# at a time where more have to be tried.
NEAREST_SEGMENTS = 8
SEGMENT_PAIRS = 1_000_000
# Newton steps refining the nearest edge point on the edge's curve, and the step (in edge node
# steps) below which it is done.
EDGE_NEWTON_STEPS = 12
EDGE_STEP_TOLERANCE = 1e-9


@dataclass
class ExactDeviation:
    """The two-sided deviation of one substitute at the nodes (see the module docstring).

    poles: (n_u, n_v, 3) mm; nodes: FaceNodes; forward, reverse: Side over the K = counted
    raster nodes (in raster order), the edge nodes, then the P peak nodes found between them
    (cmmsampling.fitting.peaks); peak_points: (P, 3) mm, the face's points at the peak nodes: the
    places in stretched cells (cmmsampling.fitting.stretch), then the peaks.
    """

    poles: np.ndarray
    nodes: FaceNodes
    forward: Side
    reverse: Side
    peak_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def signed(self) -> np.ndarray:
        """(K + P,) the larger side at each node, signed, mm."""
        take_reverse = np.abs(self.reverse.values) > np.abs(self.forward.values)
        return np.where(take_reverse, self.reverse.values, self.forward.values)

    @property
    def maximum(self) -> float:
        """The largest |deviation| over the nodes and the peak nodes, mm."""
        return float(np.abs(self.signed).max(initial=0.0))

    def points(self) -> np.ndarray:
        """(K + P, 3) mm: the face's points at the nodes, then at the peak nodes."""
        return np.concatenate([self.nodes.all_points(), self.peak_points])

    def node_signed(self) -> np.ndarray:
        """(K,) signed deviations at the nodes (the peak nodes left out), mm."""
        return self.signed[:len(self.signed) - len(self.peak_points)]

    def counted_signed(self) -> np.ndarray:
        """(K',) signed deviations at the nodes that count (the edge nodes out of a probe's reach
        left out, see FaceNodes.edge_counted), mm."""
        return self.node_signed()[self.nodes.node_weights() > 0]

    def peak_signed(self) -> np.ndarray:
        """(P,) signed deviations at the peak nodes, mm."""
        return self.signed[len(self.signed) - len(self.peak_points):]

    def grid_signed(self) -> np.ndarray:
        """(g_u, g_v) signed deviations at the raster, NaN where a node does not count."""
        out = np.full(self.nodes.size, np.nan)
        out[self.nodes.counted] = self.signed[:int(self.nodes.counted.sum())]
        return out

    def edge_signed(self) -> np.ndarray:
        """(E,) signed deviations at the edge nodes, mm."""
        counted = int(self.nodes.counted.sum())
        return self.signed[counted:counted + len(self.nodes.edge_uv)]


def node_parameters(nodes: FaceNodes) -> np.ndarray:
    """(K, 2) the parameters of the counted raster nodes then the edge nodes."""
    return np.concatenate([nodes.uv[nodes.counted], nodes.edge_uv])


def node_normals(nodes: FaceNodes) -> np.ndarray:
    """(K, 3) the face's unit normals at the counted raster nodes then the edge nodes."""
    return np.concatenate([nodes.normals[nodes.counted], nodes.edge_normals])


def exact_deviation(space: SubstituteSpace, poles: np.ndarray, nodes: FaceNodes, face: Any,
                    on_face: Callable[[np.ndarray], np.ndarray] | None = None,
                    reached: Callable[[np.ndarray], np.ndarray] | None = None) -> ExactDeviation:
    """The ExactDeviation of the substitute with ``poles`` (n_u, n_v, 3) mm in ``space``, at the
    nodes and at the peaks searched between them (cmmsampling.fitting.peaks).

    nodes: FaceNodes; face: the face's NurbsPatch (bounds, points, normals, derivatives); on_face:
    uv (..., 2) -> (...) bool, the face's trim test (None: the whole rectangle); reached: uv
    (..., 2) -> (...) bool, where a probe reaches the face (None: everywhere): the deviation
    counts there only (the nodes' own ``counted`` and ``edge_counted`` say it for them; the edge
    nodes and peaks elsewhere get zero, with no gradient).
    """
    surface = FittedSurface(space, poles)
    trimmed = TrimmedSubstitute(surface, nodes, on_face)
    samples = _sample_raster(surface)
    weights = nodes.node_weights()
    forward = forward_side(surface, nodes, samples, trimmed).weighted(weights)
    reverse = reverse_side(surface, nodes, face, on_face).weighted(weights)
    judged = on_face if reached is None else _both(on_face, reached)
    fallback = node_normals(nodes)
    raster = _sample_raster(surface, SETTLE_SAMPLES)

    def counted(h: np.ndarray, sides: tuple[Side, Side]) -> tuple[Side, Side]:
        if reached is None:
            return sides
        counts = reached(h).astype(float)
        return sides[0].weighted(counts), sides[1].weighted(counts)

    def settled(h: np.ndarray, origin: np.ndarray, start: np.ndarray) -> tuple[Side, Side]:
        return counted(h, _settled_sides(trimmed, face, h, start, raster, fallback[origin]))

    def sides_at(h: np.ndarray, origin: np.ndarray, start: np.ndarray) -> tuple[Side, Side]:
        return counted(h, _sides_at(trimmed, face, h, start, fallback[origin], samples))

    forward, reverse = _settle_largest(node_parameters(nodes), forward, reverse, settled)
    sizes = np.maximum(np.abs(forward.values), np.abs(reverse.values))
    fine = _fine_starts(stretched_places(nodes, surface, judged), settled, sides_at)
    peaks = peak_search(nodes, sizes, forward.at, sides_at, judged, fine)
    ahead, back = (settled(peaks.uv, peaks.origin, peaks.forward.at) if len(peaks.uv)
                   else (peaks.forward, peaks.reverse))
    between = np.concatenate([fine.places.uv, peaks.uv])
    return ExactDeviation(np.asarray(poles, dtype=float), nodes, forward.joined(fine.forward).joined(ahead),
                          reverse.joined(fine.reverse).joined(back), face.points(between))


# first: a trim test or None; Any, since mypy 1.0 does not carry its narrowing into the lambda.
def _both(first: Any, second: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """uv (..., 2) -> (...) bool: True where both tests are (first None: the second alone)."""
    if first is None:
        return second
    return lambda uv: first(uv) & second(uv)


def _fine_starts(places: FinePlaces, settled: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Side, Side]],
                 sides_at: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Side, Side]]) -> FineStarts:
    """FineStarts (cmmsampling.fitting.peaks) at the FinePlaces ``places``: their Sides measured by
    ``sides_at`` and settled (``settled``) at the SETTLE_NODES largest, as the nodes' are."""
    if not len(places.uv):
        return FineStarts.none()
    forward, reverse = sides_at(places.uv, places.origin, places.uv)
    forward, reverse = _settle_largest(places.uv, forward, reverse,
                                       lambda h, rows, start: settled(h, places.origin[rows], start))
    return FineStarts(places, forward, reverse)


def _sides_at(trimmed: TrimmedSubstitute, face: Any, h: np.ndarray, start: np.ndarray, fallback: np.ndarray,
              samples: tuple[np.ndarray, cKDTree]) -> tuple[Side, Side]:
    """(forward, reverse) Sides at the face's points F(h), h (M, 2) its parameters: forward
    searched from ``start`` (M, 2) on the substitute, reverse from h; each searched again from the
    nearest sample of the substitute or node of the face where that lies nearer than the foot found
    (a search that maximises the deviation would otherwise find where a foot search got stuck);
    trimmed: the TrimmedSubstitute; fallback (M, 3) unit, the normals where the face has none at h
    (a collapsed edge); samples: :func:`_sample_raster` of the substitute."""
    surface, nodes, on_face = trimmed.surface, trimmed.nodes, trimmed.on_face
    normals = normals_or(face.normals(h), fallback)
    targets = face.points(h)
    at = closest_parameters(surface, targets, start)
    at = _restart_stuck(surface, targets, at, _nearest_samples(samples, targets))
    points = surface.points(h)
    feet = closest_parameters(face, points, h)
    distance, index = nodes.point_tree.query(points)
    feet = _restart_stuck(face, points, feet, (node_parameters(nodes)[index], distance))
    return trimmed.forward(targets, at, normals), _reverse_from_feet(face, nodes, on_face, points, h, feet, normals)


def _settled_sides(trimmed: TrimmedSubstitute, face: Any, h: np.ndarray, start: np.ndarray,
                   raster: tuple[np.ndarray, cKDTree], fallback: np.ndarray) -> tuple[Side, Side]:
    """(forward, reverse) Sides at the face's points F(h), h (M, 2) its parameters, each foot the
    nearest of searches from more starts than a node's: forward from ``start`` (M, 2) and the
    SETTLE_SAMPLE_STARTS nearest samples of ``raster`` ((parameters, k-d tree) of the substitute)
    and its nearest sample on each side of the rectangle, reverse from h and the SETTLE_NODE_STARTS
    nearest nodes. A foot search can stop short of the closest point (a flat valley of the
    distance; across a thin strip, in a hollow of its middle or at the wrong one of its two long
    edges, where all the nearest samples lie in the middle), and a search for the largest
    deviation finds first where it did; these feet are settled wider.
    trimmed: the TrimmedSubstitute; fallback (M, 3) unit: the normals where the face has none at h."""
    surface, nodes, on_face = trimmed.surface, trimmed.nodes, trimmed.on_face
    targets, points = face.points(h), surface.points(h)
    grid, samples = raster
    near_samples = samples.query(targets, k=SETTLE_SAMPLE_STARTS)[1]
    ahead = _nearest_of(surface, targets, np.concatenate(
        [start[:, None], grid[near_samples], _nearest_on_sides(raster, targets)], 1))
    near_nodes = nodes.point_tree.query(points, k=min(SETTLE_NODE_STARTS, nodes.point_tree.n))[1].reshape(len(h), -1)
    feet = _nearest_of(face, points, np.concatenate([h[:, None], node_parameters(nodes)[near_nodes]], 1))
    normals = normals_or(face.normals(h), fallback)
    return trimmed.forward(targets, ahead, normals), _reverse_from_feet(face, nodes, on_face, points, h, feet, normals)


def _nearest_on_sides(raster: tuple[np.ndarray, cKDTree], targets: np.ndarray) -> np.ndarray:
    """(M, 4, 2) for each target (M, 3) mm the parameters of its nearest sample of ``raster`` (a
    count x count raster of the rectangle: :func:`_sample_raster`) on each side of the rectangle,
    u = u0, u = u1, v = v0 and v = v1: from there a foot search follows that side where the
    closest point lies on it."""
    grid, tree = raster
    count = int(round(np.sqrt(len(grid))))
    index = np.arange(len(grid)).reshape(count, count)
    sides = np.stack([index[0], index[-1], index[:, 0], index[:, -1]])
    gap = ((tree.data[sides][None] - targets[:, None, None]) ** 2).sum(-1)
    return grid[sides[np.arange(4), gap.argmin(-1)]]


def _settle_largest(h: np.ndarray, forward: Side, reverse: Side,
                    settled: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Side, Side]]) -> tuple[Side, Side]:
    """The nodes' Sides with the feet of the SETTLE_NODES largest nodes settled (``settled``: (h,
    node index, start) -> Sides, see :func:`_settled_sides`), each side kept where it was nearer; again for
    the largest not yet settled, until the SETTLE_NODES largest all are (at most SETTLE_PASSES
    times). h: (K, 2) the nodes' parameters."""
    done = np.zeros(len(h), dtype=bool)
    for _ in range(SETTLE_PASSES):
        top = np.argsort(-np.maximum(np.abs(forward.values), np.abs(reverse.values)))[:SETTLE_NODES]
        top = top[~done[top]]
        if not top.size:
            break
        ahead, back = settled(h[top], top, forward.at[top])
        forward, reverse = _nearer(forward, top, ahead), _nearer(reverse, top, back)
        done[top] = True
    return forward, reverse


def _nearer(side: Side, rows: np.ndarray, other: Side) -> Side:
    """side with its entries ``rows`` (M,) replaced by other's (M entries) where those are nearer."""
    nearer = np.abs(other.values) < np.abs(side.values[rows])
    kept = side.copy()
    kept.put(rows[nearer], other.rows(nearer))
    return kept


class NearestParameters:
    """The parameters of the closest points on a face's model, for many points at once, from a
    raster built once per face: call with points (M, 3) mm -> uv (M, 2) in the model's parameter
    range. model: SurfaceModel; on_face: uv -> bool, the face's trim (None: the whole rectangle);
    grid: raster nodes per direction; starts: how many of the nearest nodes each damped Newton
    search (:func:`closest_parameters`) starts from, the nearest result kept."""

    def __init__(self, model: Any, on_face: Callable[[np.ndarray], np.ndarray] | None = None, grid: int = 60,
                 starts: int = 4) -> None:
        self.model = model
        self.nodes = face_nodes(model, grid, on_face)
        self.starts = node_parameters(self.nodes)
        self.count = min(starts, len(self.starts))

    def locate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(uv (M, 2), near (M, count) indices of the raster nodes searched from) for points (M, 3) mm."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        near = self.nodes.point_tree.query(points, k=self.count)[1].reshape(len(points), self.count)
        return _nearest_of(self.model, points, self.starts[near]), near

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return self.locate(points)[0]


def _nearest_of(model: Any, targets: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(M, 2) the parameters of the nearest of the closest points to targets (M, 3) searched on the
    model from each of starts (M, k, 2)."""
    count, k = starts.shape[:2]
    found = closest_parameters(model, np.repeat(targets, k, axis=0), starts.reshape(-1, 2)).reshape(count, k, 2)
    gap = ((model.points(found.reshape(-1, 2)).reshape(count, k, 3) - targets[:, None]) ** 2).sum(-1)
    return found[np.arange(count), np.argmin(gap, axis=1)]


def forward_side(surface: FittedSurface, nodes: FaceNodes, samples: tuple[np.ndarray, cKDTree] | None = None,
                 trimmed: TrimmedSubstitute | None = None) -> Side:
    """Side: from each node F(h) to its closest point on the substitute (see
    :class:`TrimmedSubstitute`; None: its whole rectangle); samples: :func:`_sample_raster` of the
    substitute where it is already built."""
    trimmed = trimmed or TrimmedSubstitute(surface, nodes)
    targets, start = nodes.all_points(), node_parameters(nodes)
    at = closest_parameters(surface, targets, start)
    at = _restart_stuck(surface, targets, at, _nearest_samples(samples or _sample_raster(surface), targets))
    return trimmed.forward(targets, at, node_normals(nodes))


class TrimmedSubstitute:
    """The substitute as delivered, trimmed like the face: surface (FittedSurface) on the face's
    domain, nodes: the face's FaceNodes (their edge curves bound it), on_face: uv (M, 2) -> (M,)
    bool, the face's trim test (None: the whole rectangle)."""

    def __init__(self, surface: FittedSurface, nodes: FaceNodes,
                 on_face: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self.surface, self.nodes, self.on_face = surface, nodes, on_face

    @cached_property
    def edges(self) -> FaceNodes:
        """The nodes with the substitute's points at the edge nodes' parameters as edge points
        (its boundary polygons), built at first use."""
        return replace(self.nodes, edge_points=self.surface.points(self.nodes.edge_uv))

    def forward(self, targets: np.ndarray, at: np.ndarray, normals: np.ndarray) -> Side:
        """The forward Side from targets (M, 3) mm to the substitute: at its points at ``at`` (M,
        2), the closest points found on its rectangle, where they are inside the trim, else at the
        nearest point of its boundary; normals (M, 3) the face's at the targets."""
        nearest, at = self.surface.points(at), np.array(at, dtype=float)
        off = np.zeros(len(at), dtype=bool) if self.on_face is None else ~self.on_face(at)
        if off.any():
            nearest[off], at[off] = _nearest_on_edge_curves(self.surface, self.edges, targets[off])
        return _side(nearest - targets, at, normals)


def reverse_side(surface: FittedSurface, nodes: FaceNodes, face: Any,
                 on_face: Callable[[np.ndarray], np.ndarray] | None) -> Side:
    """Side: from the substitute's point S(h) at each node's parameters back to the face.

    Each foot is searched from the node's own parameters h and, where another node lies nearer to
    S(h), from that node's parameters too (the closer foot is kept); S(h) usually lies nearest its
    own node, whose search would repeat the first."""
    at = node_parameters(nodes)
    points = surface.points(at)
    foot = closest_parameters(face, points, at)
    index = nodes.point_tree.query(points)[1]
    other = np.flatnonzero((at[index] != at).any(1))
    again = closest_parameters(face, points[other], at[index[other]])
    foot[other] = _better(face, points[other], foot[other], again)
    return _reverse_from_feet(face, nodes, on_face, points, at, foot, node_normals(nodes))


def _reverse_from_feet(face: Any, nodes: FaceNodes, on_face: Callable[[np.ndarray], np.ndarray] | None,
                       points: np.ndarray, at: np.ndarray, feet: np.ndarray, fallback: np.ndarray) -> Side:
    """The reverse Side of the substitute's points (M, 3) mm at ``at`` (M, 2), their closest
    points on the face's surface at ``feet`` (M, 2): measured there where the foot is on the
    face, else to the nearest edge point; fallback (M, 3) the normals where the face has none."""
    nearest, normals = face.points(feet), face.normals(feet)
    off = np.zeros(len(at), dtype=bool) if on_face is None else ~on_face(feet)
    if off.any():
        nearest[off], edge_uv = _nearest_on_edge_curves(face, nodes, points[off])
        normals[off] = face.normals(edge_uv)
    return _side(points - nearest, at, normals_or(normals, fallback))


def _side(offsets: np.ndarray, at: np.ndarray, normals: np.ndarray) -> Side:
    """A Side from offsets (K, 3) S - F, the parameters on S, and the face's normals (K, 3)."""
    length = np.linalg.norm(offsets, axis=1)
    side = np.where((offsets * normals).sum(1) < 0, -1.0, 1.0)
    measured = length > 1e-12 * max(1.0, float(length.max(initial=0.0)))
    directions = normals.copy()
    directions[measured] = side[measured, None] * offsets[measured] / length[measured, None]
    return Side(side * length, at, directions)


def _nearest_on_edge_curves(face: Any, nodes: FaceNodes, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nearest point (M, 3) mm on the edges of ``face`` (the face, or the substitute with
    ``nodes`` whose edge points are its own) to each point (M, 3) mm, and its parameters (M, 2).

    The nearest point on the edge polygons (:func:`_nearest_on_edges`) is refined on the edge
    itself: the face's point F(c(t)) of the edge's curve on the surface c, interpolated by cubics
    through the run's samples (equal parameter steps), by Gauss-Newton steps along the run
    (at most a segment each, halved where a step gains nothing, at most EDGE_NEWTON_STEPS). Only
    steps that bring the point nearer are kept, so the result is a point of the edge never
    farther than the curve's point where the search began."""
    place = _nearest_on_edges(nodes, points)
    runs = nodes.edge_runs[place.astype(int)]
    uv = edge_curve_uv(nodes, place, runs)[0]
    gap = ((face.points(uv) - points) ** 2).sum(1)
    scale = np.ones(len(place))
    active = np.flatnonzero(runs[:, 1] - runs[:, 0] > 1)
    for _ in range(EDGE_NEWTON_STEPS):
        if not active.size:
            break
        at, slope = edge_curve_uv(nodes, place[active], runs[active])
        derivatives = face.derivatives(at, 1)
        offset = derivatives[(0, 0)] - points[active]
        tangent = derivatives[(1, 0)] * slope[:, :1] + derivatives[(0, 1)] * slope[:, 1:]
        step = -(offset * tangent).sum(1) / np.maximum((tangent * tangent).sum(1), 1e-300)
        step = scale[active] * np.clip(step, -1.0, 1.0)
        trial = np.clip(place[active] + step, runs[active, 0], runs[active, 1] - 1.0)
        trial_gap = ((face.points(edge_curve_uv(nodes, trial, runs[active])[0]) - points[active]) ** 2).sum(1)
        better = trial_gap < gap[active]
        place[active[better]], gap[active[better]] = trial[better], trial_gap[better]
        scale[active[~better]] *= 0.5
        active = active[np.abs(step) > EDGE_STEP_TOLERANCE]
    uv = edge_curve_uv(nodes, place, runs)[0]
    return face.points(uv), uv


def _nearest_on_edges(nodes: FaceNodes, points: np.ndarray) -> np.ndarray:
    """Where on the face's edge polygons the nearest point to each point (M, 3) mm lies: (M,) a
    fractional edge node index within the run of the node it is nearest to (a segment between
    two runs, at a corner or where a loop closes, gives its nearer end).

    The edge segments are cut into pieces (FaceNodes.edge_pieces), and the NEAREST_SEGMENTS pieces
    whose midpoints lie nearest are tried. A piece left out lies at least its midpoint's distance
    less half the longest piece away, so a point whose nearest found is farther than that bound
    (far from the face, or beside a sharp corner where the nearest midpoints are all those of a
    short edge's pieces) is tried again with every piece whose midpoint lies within the nearest
    found plus half the longest piece (counted first, then fetched as that many nearest)."""
    pieces = nodes.edge_pieces
    first, second, a, along = pieces.first, pieces.second, pieces.starts, pieces.alongs
    middles, half, segment_of, fractions = pieces.middles, pieces.half, pieces.segment_of, pieces.fractions
    count = min(NEAREST_SEGMENTS, len(a))
    spans, candidates = middles.query(points, k=count)
    candidates, spans = candidates.reshape(len(points), count), spans.reshape(len(points), count)
    nearest, piece, t = _closest_on_segments(points, a, along, candidates)
    found = np.linalg.norm(nearest - points, axis=1)
    unsure = np.flatnonzero(found > spans[:, -1] - half)
    if unsure.size and count < len(a):
        within = middles.query_ball_point(points[unsure], found[unsure] + half, return_length=True)
        needed = np.minimum(2 ** np.ceil(np.log2(np.maximum(within, count))).astype(int), len(a))
        for k in np.unique(needed):
            rows = unsure[needed == k]
            for chunk in np.array_split(rows, -(-rows.size * k // SEGMENT_PAIRS)):
                candidates = middles.query(points[chunk], k=k)[1].reshape(len(chunk), k)
                nearest[chunk], piece[chunk], t[chunk] = _closest_on_segments(points[chunk], a, along, candidates)
    along = fractions[piece, 0] + t * (fractions[piece, 1] - fractions[piece, 0])
    start, end = first[segment_of[piece]], second[segment_of[piece]]
    within = (end == start + 1) & (nodes.edge_runs[start, 1] > end)
    return np.where(within, start + along, np.where(along < 0.5, start, end)).astype(float)


def _closest_on_segments(points: np.ndarray, starts: np.ndarray, alongs: np.ndarray,
                         candidates: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point (M, 3), the closest point on the segments from starts[c] to starts[c] + alongs[c]
    (starts, alongs: (S, 3) mm) of its candidates c (M, K) int: (closest points (M, 3), the
    segment's index (M,), its fraction along the segment (M,) in [0, 1])."""
    start, along = starts[candidates], alongs[candidates]
    t = np.clip(((points[:, None, :] - start) * along).sum(-1) / np.maximum((along * along).sum(-1), 1e-300), 0, 1)
    on_segment = start + t[..., None] * along
    best = np.argmin(((on_segment - points[:, None, :]) ** 2).sum(-1), axis=1)
    rows = np.arange(len(points))
    return on_segment[rows, best], candidates[rows, best], t[rows, best]


def _better(model: Any, targets: np.ndarray, first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Per target, the parameters (K, 2) of ``first`` or ``second`` whose point is closer to it
    (searches from two starts: a search from a node's own parameters can stop at a collapsed edge,
    where the surface's derivative along the edge vanishes)."""
    closer = (np.linalg.norm(model.points(second) - targets, axis=1)
              < np.linalg.norm(model.points(first) - targets, axis=1))
    return np.where(closer[:, None], second, first)


def _restart_stuck(model: Any, targets: np.ndarray, uv: np.ndarray,
                   samples: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Search again from the nearest sample (parameters (K, 2), distance (K,)) where the search from
    uv ended farther than that sample (a local minimum, e.g. on a closed surface); keep the better."""
    sample_uv, sample_distance = samples
    current = np.linalg.norm(model.points(uv) - targets, axis=1)
    stuck = np.flatnonzero(current > sample_distance)
    if len(stuck):
        again = closest_parameters(model, targets[stuck], sample_uv[stuck])
        better = np.linalg.norm(model.points(again) - targets[stuck], axis=1) < current[stuck]
        uv = uv.copy()
        uv[stuck[better]] = again[better]
    return uv


def _nearest_samples(samples: tuple[np.ndarray, cKDTree], targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nearest of the samples ((parameters, k-d tree of their points): :func:`_sample_raster`)
    to each target (K, 3): (parameters (K, 2), distance (K,) mm)."""
    grid, tree = samples
    distance, index = tree.query(targets)
    return grid[index], distance


def _sample_raster(surface: FittedSurface, count: int = SEARCH_SAMPLES) -> tuple[np.ndarray, cKDTree]:
    """A count x count raster of the surface's rectangle: (parameters (count^2, 2), a k-d tree
    of its points)."""
    u0, u1, v0, v1 = surface.bounds
    grid = np.stack(np.meshgrid(np.linspace(u0, u1, count), np.linspace(v0, v1, count),
                                indexing="ij"), -1).reshape(-1, 2)
    return grid, cKDTree(surface.points(grid))


def closest_parameters(model: Any, targets: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Parameters (K, 2) of the closest points to targets (K, 3), from uv (K, 2), in the model's box.

    model: anything with ``bounds``, ``points(uv)`` and ``derivatives(uv, 2)`` (a NurbsPatch or a
    FittedSurface). Damped Newton on |F(u, v) - target|^2, every target at once; a step is
    kept only where it brings the point closer. The damping (relative, between DAMPING_FLOOR and
    DAMPING_CEILING) falls where a step gains at least a quarter of what the local model
    promised and grows where it gains less: a step that overshoots on a curved surface, e.g.
    along a bound, would otherwise zigzag for hundreds of iterations. A target's search ends when
    its step falls below FOOT_STEP_TOLERANCE of the box, kept or not (a step that short that
    gains nothing meets the rounding of |r|^2), or when its damping reaches the ceiling.
    """
    u0, u1, v0, v1 = model.bounds
    low, high = np.array([u0, v0]), np.array([u1, v1])
    uv = np.clip(np.asarray(uv, dtype=float), low, high)
    squared = ((model.points(uv) - targets) ** 2).sum(1)
    damping = np.full(len(uv), 1e-9)
    active = np.ones(len(uv), dtype=bool)
    for _ in range(FOOT_ITERATIONS):
        if not active.any():
            break
        index = np.flatnonzero(active)
        start = uv[index]
        gradient, normal = _local_model(model, targets[index], start)
        step = _newton_step(gradient, normal, start, damping[index], low, high)
        trial = np.clip(start + step, low, high)
        trial_squared = ((model.points(trial) - targets[index]) ** 2).sum(1)
        gain = squared[index] - trial_squared
        better = gain >= 0
        moved = np.abs(trial - start).max(1) > FOOT_STEP_TOLERANCE * (high - low).max()
        uv[index[better]] = trial[better]
        squared[index[better]] = trial_squared[better]
        damping[index] = _next_damping(damping[index], gain, _promised_gain(gradient, normal, trial - start))
        active[index] = moved & (better | (damping[index] < DAMPING_CEILING))
    return uv


def _local_model(model: Any, targets: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The quadratic model of the squared distance at uv (K, 2): gradient (K, 2) = J^T r (half the
    gradient of |r|^2, r = F(uv) - target) and curvature (K, 3) = the columns a, b, c of half its
    Hessian, J^T J + r . F'' (Newton: quadratic convergence where the surface curves or the
    point is far), or of J^T J alone where that Hessian is not positive definite."""
    d = model.derivatives(uv, 2)
    residual = d[(0, 0)] - targets
    su, sv = d[(1, 0)], d[(0, 1)]
    gradient = np.column_stack([(residual * su).sum(1), (residual * sv).sum(1)])
    normal = np.column_stack([(su * su).sum(1), (su * sv).sum(1), (sv * sv).sum(1)])
    hessian = normal + np.column_stack([(residual * d[key]).sum(1) for key in ((2, 0), (1, 1), (0, 2))])
    definite = (hessian[:, 0] > 0) & (hessian[:, 0] * hessian[:, 2] > hessian[:, 1] ** 2)
    return gradient, np.where(definite[:, None], hessian, normal)


def _promised_gain(gradient: np.ndarray, normal: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(K,) the decrease of |r|^2 that the quadratic model promises for a step (K, 2)."""
    a, b, c = normal.T
    su, sv = step.T
    return -2.0 * (gradient * step).sum(1) - (a * su * su + 2.0 * b * su * sv + c * sv * sv)


def _next_damping(damping: np.ndarray, gain: np.ndarray, promised: np.ndarray) -> np.ndarray:
    """(K,) the damping after a step that gained ``gain`` (K,) of the ``promised`` (K,) decrease."""
    kept = gain >= 0
    grown = np.where(kept, damping * 10.0, damping * 100.0)
    good = kept & (gain >= 0.25 * promised)
    return np.clip(np.where(good, damping * 0.1, grown), DAMPING_FLOOR, DAMPING_CEILING)


def _newton_step(gradient: np.ndarray, normal: np.ndarray, uv: np.ndarray, damping: np.ndarray, low: np.ndarray,
                 high: np.ndarray) -> np.ndarray:
    """Damped Newton step (K, 2) towards the closest points from the local model (gradient
    (K, 2), normal (K, 3): see :func:`_local_model`), damping (K,) relative. A parameter on its
    bound that the step would push out stays there, and the step is taken along the bound in the
    other parameter alone; at a corner, along the edge that leads inward and gains more (so that a
    closest point on the rectangle's edge is found as exactly as one inside it)."""
    a, b, c = normal.T
    shift = damping * (a + c) + 1e-300
    a, c = a + shift, c + shift
    gu, gv = gradient.T
    det = a * c - b * b
    step = -np.column_stack([c * gu - b * gv, a * gv - b * gu]) / det[:, None]
    pushed = ((uv <= low) & (step < 0)) | ((uv >= high) & (step > 0))
    along = np.column_stack([-gu / a, -gv / c])
    inward = ~(((uv <= low) & (along < 0)) | ((uv >= high) & (along > 0)))
    gain = np.where(inward, np.column_stack([gu * gu / a, gv * gv / c]), -1.0)
    corner = pushed[:, 0] & pushed[:, 1]
    only_u = (pushed[:, 1] & ~pushed[:, 0]) | (corner & (gain[:, 0] >= gain[:, 1]) & (gain[:, 0] > 0))
    only_v = (pushed[:, 0] & ~pushed[:, 1]) | (corner & (gain[:, 1] > gain[:, 0]) & (gain[:, 1] > 0))
    step[pushed.any(1)] = 0.0
    step[only_u, 0] = along[only_u, 0]
    step[only_v, 1] = along[only_v, 1]
    return step


class Linearisation:
    """The exact two-sided deviations linearised about one substitute S0, for a descent that moves it.

    face: the face's NurbsPatch; space: SubstituteSpace; exact: the ExactDeviation of S0. Each side
    of each node, d + w . (S(at) - S0(at)), is exact at S0 in value and gradient. It has the
    interface the descent's surrogate uses: ``model``, ``space``, ``grid_error``, ``grid_transpose``.
    """

    def __init__(self, face: Any, space: SubstituteSpace, exact: ExactDeviation) -> None:
        self.model, self.space = face, space
        sides = (exact.forward, exact.reverse)
        self._signed = np.concatenate([side.values for side in sides])
        self._directions = np.concatenate([side.directions for side in sides])
        at = np.concatenate([side.at for side in sides])
        bu, bv = space.bases(at)
        self._rows = kron_rows(bu[0], bv[0])
        self._start = self._rows @ np.asarray(exact.poles).reshape(-1, 3)

    @property
    def rows(self) -> np.ndarray:
        """(2K, n_u n_v) the basis rows at each side's parameters."""
        return self._rows

    @property
    def targets(self) -> tuple[np.ndarray, np.ndarray]:
        """(2K,) each side's deviation at S0, mm, and (2K, 3) the directions they are measured along."""
        return self._signed, self._directions

    def grid_error(self, poles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Over both sides of every node: poles (n_u n_v, 3) or (n_u, n_v, 3) -> (error (3, 2K) =
        d w, distance (2K,) = |d| mm, counted (2K,) all True)."""
        moved = self._rows @ np.asarray(poles).reshape(-1, 3) - self._start
        field = self._signed + (moved * self._directions).sum(1)
        return (field[:, None] * self._directions).T, np.abs(field), np.ones(len(field), dtype=bool)

    def grid_transpose(self, field: np.ndarray) -> np.ndarray:
        """B^T applied to a field (3, 2K) at the sides' parameters: the (n_u * n_v, 3) pole-space result."""
        return self._rows.T @ field.T
