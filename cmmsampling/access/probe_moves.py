"""A collision-free probe path through reachable points, in the order that makes it short.

Per point ``i`` (contact ``p``, normal ``n``, axis ``a``, from :mod:`cmmsampling.access.reach`): the ball
centre touches at ``c = p + r n`` and waits ``approach`` mm out along the normal at ``s``; the
touch is ``s -> c -> s``. From one point's ``s`` to the next the probe travels straight when
both share an axis and the move keeps the clearance (the ball's sweep grown by the clearance,
the stylus and the body at poses along the move, grown by it); otherwise it leaves along its
axis to the part's box grown by the ball radius and the clearance (``e``), rises to the
clearance plane above that box (``u``), crosses, and comes down the next point's way. The head
turns to the next axis on the clearance plane: an indexing head's index move, which costs
``Motion.index_time`` seconds, as long as ``index_time * move_speed`` mm of travel. The order is
the quickest, in travel plus index moves, of: the points orientation by orientation (each
orientation's points along a short path, the orientations chained end to nearest end), as it is
and improved by 2-opt on travel plus index moves; the nearest-neighbour path on travel plus index
moves, improved likewise; the nearest-neighbour paths improved by 2-opt on travel alone (the order
when index moves cost nothing); and the straight nearest-neighbour order: never slower than that
order with the detours and index moves it needs.
``by_orientation=False`` orders by travel alone. All coordinates are ball centres, mm.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.distance import cdist

from ..geometry.probe_path import nearest_neighbour, two_opt
from ..geometry.validation import InputError
from .obstacles import Obstacles, along_segments
from .orientations import orientation_changes, orientation_labels
from .probe import Motion, Probe

# Poses checked along a straight travel move are at most this many mm apart.
POSE_STEP = 2.0
AXIS_TOLERANCE = 1e-9
NO_PART = ("a probe path needs the part the points must keep clear of: sample the face with part=<the solid> "
           "(and probe=), or export with order='short_path'")


@dataclass
class ProbeMoves:
    """A probe program's path.

    order: (N,) int, the visiting order of the points; waypoints: (W, 3) mm, the ball centre's
    path from the first clearance position to the last, touches included; kinds: (W - 1,) str,
    'touch' (approach and retract), 'axis' (along the probe's axis, in or out of the part's box)
    or 'travel' (keeps the clearance); travel: mm, the length of everything but the touches;
    straight: mm, the straight nearest-neighbour path through the ready positions (collisions
    ignored); baseline: mm, that order's travel with the detours it needs (``travel`` is never
    longer when ordered by travel alone); detours: the travel moves that go over the clearance
    plane; seconds: estimated measuring time (Motion: the moves, the touches and, for an
    indexing head, index_time per tip change); ready: (N, 3) the ready positions in the points'
    own order; legs: the travel before each point in visiting order and after the last (see
    :func:`_legs`); orientations: the distinct head orientations (probe axes) of the points;
    tip_changes: the changes of orientation along the path (the index moves; a DMIS program's
    SNSLCT after its first).
    """

    order: np.ndarray
    waypoints: np.ndarray
    kinds: np.ndarray
    travel: float
    straight: float
    baseline: float
    detours: int
    seconds: float
    ready: np.ndarray
    legs: list
    orientations: int = 0
    tip_changes: int = 0

    def travel_pairs(self) -> list[tuple[np.ndarray, ...]]:
        """The legs as N + 1 pairs (leaving, arriving) of (M, 3) positions, mm (PointSet.travel)."""
        return [tuple(np.array([p for p, _ in part]).reshape(-1, 3) for part in leg) for leg in self.legs]

    def segments(self, kind: str) -> tuple[np.ndarray, np.ndarray]:
        """(starts (S, 3), ends (S, 3)) of the path's moves of one kind."""
        chosen = self.kinds == kind
        return self.waypoints[:-1][chosen], self.waypoints[1:][chosen]


def moves_through(probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray, axes: np.ndarray,
                  motion: Motion | None = None, by_orientation: bool = True,
                  groups: Sequence[np.ndarray] | None = None) -> ProbeMoves:
    """The path through reachable points (N, 3) mm with normals (N, 3) and probe axes (N, 3)
    unit (:func:`cmmsampling.access.reach.reach`); motion: speeds and index time for the time
    estimate and the order (default Motion()); by_orientation: order for the least estimated time,
    index moves included (see the module's docstring); False: by travel alone; groups: index
    arrays covering the points once, visited one after the other, each in its own best order (a
    plan's datum faces before the toleranced points; None: one group). Returns ProbeMoves."""
    points, normals, axes = (np.asarray(v, dtype=float).reshape(-1, 3) for v in (points, normals, axes))
    motion = motion or Motion()
    centres, ready = probe.stations(points, normals)
    exits, above = _clearance_positions(probe, obstacles, ready, axes)
    direct = _direct_moves(probe, obstacles, ready, axes)
    lengths = _travel_lengths(ready, exits, above, direct)
    ends = _end_lengths(ready, exits, above)
    labels = orientation_labels(axes)
    indexing = probe.index_step is not None
    straight_lines = cdist(ready, ready)
    index_length = motion.index_time * motion.move_speed if indexing else 0.0

    def ordered(rows: np.ndarray) -> np.ndarray:
        """rows in their best order (see by_orientation)."""
        block = np.ix_(rows, rows)
        if not by_orientation:
            return rows[_short_order(lengths[block], straight_lines[block])]
        return rows[_quick_order(lengths[block], straight_lines[block], ends[rows],
                                 np.unique(labels[rows], return_inverse=True)[1], index_length)]

    order = np.concatenate([ordered(np.asarray(rows)) for rows in (groups or [np.arange(len(points))])])
    legs = _legs(order, ready, exits, above, direct)
    waypoints, kinds = _waypoints(order, centres, legs)
    steps = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    travel = float(steps[kinds != "touch"].sum())
    plain = nearest_neighbour(straight_lines)
    straight = float(np.linalg.norm(np.diff(ready[plain], axis=0), axis=1).sum())
    baseline = float(lengths[plain[:-1], plain[1:]].sum() + ends[plain[0]] + ends[plain[-1]])
    detours = int(np.count_nonzero(~direct[order[:-1], order[1:]]))
    changes = orientation_changes(labels, order)
    seconds = motion.seconds(travel, len(points), probe.approach, changes if indexing else 0)
    return ProbeMoves(order, waypoints, kinds, travel, straight, baseline, detours, seconds, ready, legs,
                      int(labels.max(initial=-1)) + 1, changes)


def _clearance_positions(probe: Probe, obstacles: Obstacles, ready: np.ndarray,
                         axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(exits, above) (N, 3) mm of ready positions (N, 3) on axes (N, 3): where the probe leaves
    the part's box (grown by the ball radius and the clearance) along its axis, and that point
    raised to the clearance plane above the box."""
    grow = probe.radius + probe.clearance
    exits = obstacles.exits(ready, axes, grow)[1]
    return exits, np.column_stack([exits[:, :2], np.maximum(exits[:, 2], obstacles.box[1, 2] + grow)])


def _same_axis(axes: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(R,) bool: which of axes (R, 3) unit are axis (3,) (NaN rows: none)."""
    return np.abs(axes @ np.nan_to_num(axis) - 1.0) < AXIS_TOLERANCE


def _end_lengths(ready: np.ndarray, exits: np.ndarray, above: np.ndarray) -> np.ndarray:
    """(N,) mm: from the clearance plane down to each ready position (the program's first and
    last moves)."""
    return np.linalg.norm(exits - ready, axis=1) + np.linalg.norm(above - exits, axis=1)


def probe_moves(source: object, motion: Motion | None = None) -> ProbeMoves:
    """The ProbeMoves through a source's points (motion: the time estimate): a SamplingResult
    run with the part (``sample(face, ..., part=)``), a PartPlan made with a probe (each has
    ``probe_moves(motion)``), or a document object whose Proxy has ``probe_moves(obj, motion)``
    (the document's probe points). ValueError for a run without the part, for points the
    probe cannot reach and for a source without a probe path (e.g. a PointSet)."""
    own = getattr(getattr(source, "Proxy", None), "probe_moves", None)
    if callable(own):
        return own(source, motion)
    own = getattr(source, "probe_moves", None)
    if callable(own):
        return own(motion)
    raise InputError(NO_PART)


def _direct_moves(probe: Probe, obstacles: Obstacles, ready: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(N, N) bool: the pairs of ready positions a straight move joins keeping the clearance
    (same axis; the ball's sweep and the stylus and body at poses along it clear by it)."""
    count = len(ready)
    same = np.abs(np.einsum("ic,jc->ij", axes, axes) - 1.0) < AXIS_TOLERANCE
    i, j = np.nonzero(np.triu(same, 1))
    clear = _clear_moves(probe, obstacles, ready[i], ready[j], axes[i])
    direct = np.zeros((count, count), dtype=bool)
    direct[i[clear], j[clear]] = direct[j[clear], i[clear]] = True
    return direct


def _clear_moves(probe: Probe, obstacles: Obstacles, starts: np.ndarray, ends: np.ndarray,
                 axes: np.ndarray) -> np.ndarray:
    """(M,) bool: the straight moves from starts to ends (M, 3) mm of a probe on axes (M, 3)
    unit that keep the clearance (the ball's sweep, and the stylus and body at poses along it)."""
    if not len(starts):
        return np.zeros(0, dtype=bool)
    clear = ~obstacles.swept_blocked(starts, ends, probe.radius + probe.clearance)
    rows = np.flatnonzero(clear)
    if rows.size:
        clear[rows] = ~_poses_blocked_along(probe, obstacles, starts[rows], ends[rows], axes[rows])
    return clear


def _poses_blocked_along(probe: Probe, obstacles: Obstacles, starts: np.ndarray, ends: np.ndarray,
                         axes: np.ndarray) -> np.ndarray:
    """(M,) bool: moves from starts to ends (M, 3) of a probe on axes (M, 3) whose stylus or body,
    grown by the clearance, meets the part at a pose along the move (POSE_STEP mm apart)."""
    positions, owner, _ = along_segments(starts, ends, np.full(len(starts), POSE_STEP))
    along = axes[owner]
    pieces = [(positions + probe.stylus_start * along, positions + probe.stylus_length * along,
               0.5 * probe.stylus_diameter + probe.clearance),
              (positions + probe.stylus_length * along, positions + probe.reach * along,
               0.5 * probe.body_diameter + probe.clearance)]
    hit = np.zeros(len(positions), dtype=bool)
    for start, end, radius in pieces:
        hit |= obstacles.cylinders_blocked(start, end, np.full(len(positions), radius))
    return np.bincount(owner, weights=hit, minlength=len(starts)) > 0


def _travel_lengths(ready: np.ndarray, exits: np.ndarray, above: np.ndarray, direct: np.ndarray) -> np.ndarray:
    """(N, N) mm: straight where ``direct``, else out along the axis, up, across the clearance
    plane, down and in."""
    out = _end_lengths(ready, exits, above)
    detour = out[:, None] + out[None, :] + cdist(above, above)
    return np.where(direct, cdist(ready, ready), detour)


def _short_order(lengths: np.ndarray, straight: np.ndarray) -> np.ndarray:
    """A short open path on the travel lengths (N, N): 2-opt from the nearest-neighbour path on
    them and from the straight nearest-neighbour order, the shorter."""
    if len(lengths) < 3:
        return np.arange(len(lengths))
    tolerance = 1e-12 * max(float(lengths.max()), 1.0)
    orders = [two_opt(lengths, nearest_neighbour(lengths), tolerance),
              two_opt(lengths, nearest_neighbour(straight), tolerance)]
    return min(orders, key=lambda order: float(lengths[order[:-1], order[1:]].sum()))


def _quick_order(lengths: np.ndarray, straight: np.ndarray, ends: np.ndarray, labels: np.ndarray,
                 index_length: float) -> np.ndarray:
    """(N,) int: the visiting order of least travel plus ``index_length`` mm per change of
    orientation (an index move's time as travel), from the clearance plane down to the first
    point (ends (N,) mm) and back up from the last included: among the straight
    nearest-neighbour order, :func:`_short_order`'s, the points orientation by orientation
    (:func:`_grouped_order`) and, 2-opt improved on that cost, that order and the
    nearest-neighbour path on the cost.
    lengths, straight: (N, N) mm (travel, straight lines); labels: (N,) int orientations."""
    if len(lengths) < 3:
        return np.arange(len(lengths))
    cost = lengths + index_length * (labels[:, None] != labels[None, :])
    tolerance = 1e-12 * max(float(cost.max()), 1.0)
    grouped = _grouped_order(lengths, ends, labels)
    candidates = [nearest_neighbour(straight), _short_order(lengths, straight), grouped,
                  two_opt(cost, grouped, tolerance), two_opt(cost, nearest_neighbour(cost), tolerance)]
    return min(candidates, key=lambda order: _open_length(cost, ends, order))


def _open_length(cost: np.ndarray, ends: np.ndarray, order: np.ndarray) -> float:
    """mm: the cost (N, N) along an order (N,) int, with the ends (N,) of its first and last point."""
    return float(cost[order[:-1], order[1:]].sum() + ends[order[0]] + ends[order[-1]])


def _grouped_order(lengths: np.ndarray, ends: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """(N,) int: the points orientation by orientation (labels (N,) int), each orientation's
    points along a short path on the travel lengths (N, N) mm (:func:`_group_path`), chained end
    to nearest end (:func:`_chained`) from each orientation's path in turn, either way round; the
    shortest of these with its ends (N,) mm."""
    paths = [_group_path(lengths, np.flatnonzero(labels == label)) for label in np.unique(labels)]
    chains = [_chained(lengths, paths, first, backwards) for first in range(len(paths)) for backwards in (False, True)]
    return min(chains, key=lambda order: _open_length(lengths, ends, order))


def _group_path(lengths: np.ndarray, members: np.ndarray) -> np.ndarray:
    """The points ``members`` (M,) int in a short open order on the travel lengths (N, N) mm:
    nearest neighbour, then 2-opt."""
    if len(members) < 3:
        return members
    within = lengths[np.ix_(members, members)]
    return members[two_opt(within, nearest_neighbour(within), 1e-12 * max(float(within.max()), 1.0))]


def _chained(lengths: np.ndarray, paths: list[np.ndarray], first: int, backwards: bool) -> np.ndarray:
    """(N,) int: the paths (each (M,) int) one after the other: paths[first] (reversed when
    backwards), then always the path whose nearer end is nearest the last point on the travel
    lengths (N, N) mm, entered at that end."""
    pieces = [paths[first][::-1] if backwards else paths[first]]
    left = [k for k in range(len(paths)) if k != first]
    while left:
        end = pieces[-1][-1]
        heads = lengths[end, [paths[k][0] for k in left]]
        tails = lengths[end, [paths[k][-1] for k in left]]
        nearest = int(np.argmin(np.minimum(heads, tails)))
        chosen = paths[left.pop(nearest)]
        pieces.append(chosen if heads[nearest] <= tails[nearest] else chosen[::-1])
    return np.concatenate(pieces)


def _legs(order: np.ndarray, ready: np.ndarray, exits: np.ndarray, above: np.ndarray,
          direct: np.ndarray) -> list[tuple[list[tuple[np.ndarray, str]], list[tuple[np.ndarray, str]]]]:
    """The travel of a visiting order as N + 1 pairs (leaving, arriving), each a list of
    (position (3,) mm, kind of the move that ends there): the moves out of the previous point
    (none before the first) and in to this one; last, out of the last point. A detour leaves
    along the axis and up to the clearance plane, and arrives across it, down and in along the
    next axis; a straight move only arrives."""
    first, last = order[0], order[-1]
    legs: list[tuple[list[tuple[np.ndarray, str]], list[tuple[np.ndarray, str]]]]
    legs = [([], [(above[first], "travel"), (exits[first], "travel"), (ready[first], "axis")])]
    for a, b in zip(order[:-1], order[1:]):
        if direct[a, b]:
            legs.append(([], [(ready[b], "travel")]))
        else:
            legs.append(([(exits[a], "axis"), (above[a], "travel")],
                         [(above[b], "travel"), (exits[b], "travel"), (ready[b], "axis")]))
    legs.append(([(exits[last], "axis"), (above[last], "travel")], []))
    return legs


def _waypoints(order: np.ndarray, centres: np.ndarray,
               legs: list[tuple[list[tuple[np.ndarray, str]], list[tuple[np.ndarray, str]]]]
               ) -> tuple[np.ndarray, np.ndarray]:
    """The ball centre's whole path (W, 3) and the kind of each move (W - 1,): the legs, with a
    touch (to the contact's centre and back) at each point; the first position is the start."""
    steps = []
    for k, (leaving, arriving) in enumerate(legs):
        steps += leaving + arriving
        if k < len(order):
            steps += [(centres[order[k]], "touch"), (arriving[-1][0], "touch")]
    return np.array([position for position, _ in steps]), np.array([kind for _, kind in steps[1:]])


class StepMoves:
    """Collision-free moves to points chosen one at a time (a run that picks its next touch from
    what it has measured): the same moves as :func:`moves_through`'s, between any two points.

    probe: the Probe; obstacles: the part (Obstacles); points, normals, axes: (N, 3) mm, unit,
    unit: the places and the probe's axis at each (:func:`cmmsampling.access.reach.reach`; NaN
    rows where it reaches none, which no move may go to); motion: the CMM's speeds and an
    indexing head's index time (default Motion()): a change of the head's orientation counts as
    that much travel, as :func:`moves_through` counts it. All positions are ball centres, mm.
    """

    def __init__(self, probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray,
                 axes: np.ndarray, motion: Motion | None = None) -> None:
        self.probe, self.obstacles = probe, obstacles
        motion = motion or Motion()
        self.index_length = motion.index_time * motion.move_speed if probe.index_step is not None else 0.0
        self.axes = np.asarray(axes, dtype=float).reshape(-1, 3)
        points, normals = (np.asarray(v, dtype=float).reshape(-1, 3) for v in (points, normals))
        self.ready = probe.stations(points, normals)[1]
        self.reachable = np.isfinite(self.axes).all(axis=1)
        self.exits, self.above = self.ready.copy(), self.ready.copy()
        self.exits[self.reachable], self.above[self.reachable] = _clearance_positions(
            probe, obstacles, self.ready[self.reachable], self.axes[self.reachable])
        self.out = _end_lengths(self.ready, self.exits, self.above)

    def _direct(self, last: int, rows: np.ndarray) -> np.ndarray:
        """(R,) bool: rows a straight move from row last reaches keeping the clearance."""
        same = _same_axis(self.axes[rows], self.axes[last])
        direct = np.zeros(len(rows), dtype=bool)
        if same.any():
            ends = self.ready[rows[same]]
            starts = np.broadcast_to(self.ready[last], ends.shape)
            direct[same] = _clear_moves(self.probe, self.obstacles, starts, ends,
                                        np.broadcast_to(self.axes[last], ends.shape))
        return direct

    def lengths(self, last: int, rows: np.ndarray) -> np.ndarray:
        """(R,) mm: the travel from row last's ready position to each of rows (R,) int: straight
        where that keeps the clearance, else out along the axis, over the clearance plane and in,
        plus the index move's equivalent where the head turns; inf at rows the probe does not
        reach."""
        rows = np.asarray(rows, dtype=int)
        lengths = np.full(len(rows), np.inf)
        open_ = np.flatnonzero(self.reachable[rows])
        if not open_.size:
            return lengths
        targets = rows[open_]
        detour = self.out[last] + self.out[targets] + np.linalg.norm(self.above[targets] - self.above[last], axis=1)
        straight = np.linalg.norm(self.ready[targets] - self.ready[last], axis=1)
        turns = ~_same_axis(self.axes[targets], self.axes[last])
        lengths[open_] = np.where(self._direct(last, targets), straight, detour) + self.index_length * turns
        return lengths

    def leg(self, last: int | None, row: int) -> np.ndarray:
        """(K, 3) mm: the ball centre's positions from row last's ready position (None: from
        the start, over the clearance plane) to row's, its ready position last (a position the
        path is already at left out)."""
        if not self.reachable[row]:
            raise InputError(f"the probe reaches no pose at place {row}: it cannot be touched")
        arriving = [self.above[row], self.exits[row], self.ready[row]]
        if last is None:
            path = np.array(arriving)
        elif self._direct(last, np.array([row]))[0]:
            return self.ready[row][None]
        else:
            path = np.array([self.exits[last], self.above[last], *arriving])
        return path[np.r_[True, np.linalg.norm(np.diff(path, axis=0), axis=1) > 1e-9]]
