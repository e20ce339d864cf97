"""The head orientations a set of points is measured with: as few as serve them all.

An indexing head (a PH10-like head, :class:`cmmsampling.access.probe.Probe` with an
``index_step``) stops for seconds at every change of orientation (``Motion.index_time``), so a
program should use few orientations and change between them seldom. Given which of the head's
orientations may reach each point and a test of whether one does (:class:`Reaches`;
:func:`cmmsampling.access.reach.fewest_orientations` tests the probe's poses),
:func:`greedy_cover` picks orientations until every point has one (each time the one that reaches
the most points still without one: the greedy set cover, within a factor ln N of the fewest),
then gives each point the least tilted of those picked. The test is asked lazily: an orientation's
count of the points it may reach bounds what it reaches, so only the orientations whose bound
leads are tested. :mod:`cmmsampling.access.probe_moves` then visits the points orientation by
orientation (:func:`orientation_labels`, :func:`orientation_changes`). Angles in degrees.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..geometry.validation import InputError
from .probe import head_angles

# Head angles rounded to this many decimals of a degree name an orientation, as a DMIS program's
# sensors do (cmmsampling.formats.dmis); the grid's own angles are multiples of its step.
ANGLE_DECIMALS = 4

# A test of one orientation at some points: (rows (M,) int, column k) -> (M,) bool, reaches.
OrientationTest = Callable[[np.ndarray, int], np.ndarray]


class Reaches:
    """Which of K orientations reach which of N points, each pair tested once, when first asked.

    possible: (N, K) bool, the pairs that may reach (the others never do); test: an
    OrientationTest for the possible pairs (None: the possible pairs all reach). ``known`` and
    ``value`` (N, K) bool hold what is known so far.
    """

    def __init__(self, possible: np.ndarray, test: OrientationTest | None = None) -> None:
        self.possible = np.asarray(possible, dtype=bool)
        self.test = test
        self.known = ~self.possible if test is not None else np.ones(self.possible.shape, dtype=bool)
        self.value = np.zeros(self.possible.shape, dtype=bool) if test is not None else self.possible.copy()

    @property
    def shape(self) -> tuple[int, ...]:
        """(N, K)."""
        return self.possible.shape

    def column(self, k: int, rows: np.ndarray) -> np.ndarray:
        """(M,) bool: whether orientation k reaches the points rows (M,) int, testing those not yet known."""
        asked = rows[~self.known[rows, k]]
        if asked.size:
            assert self.test is not None   # without a test every pair is known
            self.value[asked, k] = np.asarray(self.test(asked, k), dtype=bool)
            self.known[asked, k] = True
        return self.value[rows, k]

    def block(self, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """(M, C) bool: whether orientations columns (C,) int reach the points rows (M,) int, all tested."""
        return np.stack([self.column(int(k), rows) for k in columns], axis=1).reshape(len(rows), len(columns))

    def optimistic(self, rows: np.ndarray) -> np.ndarray:
        """(M, K) bool: the pairs of the points rows (M,) int that reach or may still reach."""
        return self.possible[rows] & (self.value[rows] | ~self.known[rows])

    def set(self, rows: np.ndarray, columns: np.ndarray, reaches: bool) -> None:
        """Record that the orientations columns (M,) int reach (or not) the points rows (M,) int."""
        self.value[rows, columns] = reaches
        self.known[rows, columns] = True


def greedy_cover(reaches: Reaches | np.ndarray, tilts: np.ndarray) -> np.ndarray:
    """(N,) int: the orientation each point is measured with, few in all.

    reaches: a Reaches, or (N, K) bool, orientation k reaches point n; tilts: (N, K) degrees
    between each orientation and each point's normal. Picks, while some point has none, the
    orientation reaching the most of those points (ties: the least summed tilt over them, then the
    first; :func:`_next_pick`); drops the picks the others make needless (:func:`_needed`); then
    each pick in turn gives way to the orientation that reaches all the points it serves with the
    least summed tilt (:func:`_least_tilted`), and each point takes the least tilted orientation
    picked that reaches it. ValueError where a point has no orientation at all.
    """
    if not isinstance(reaches, Reaches):
        reaches = Reaches(np.asarray(reaches, dtype=bool))
    tilts = np.asarray(tilts, dtype=float)
    if len(reaches.shape) != 2 or tilts.shape != reaches.shape:
        raise InputError(f"reaches and tilts must be (N, K) arrays of one shape, got {reaches.shape} and {tilts.shape}")
    waiting = np.ones(reaches.shape[0], dtype=bool)
    picked: list[int] = []
    while waiting.any():
        rows = np.flatnonzero(waiting)
        pick = _next_pick(reaches, tilts, rows)
        picked.append(pick)
        waiting[rows[reaches.column(pick, rows)]] = False
    everyone = np.arange(reaches.shape[0])
    chosen = _least_tilted(reaches, tilts, _needed(reaches, np.array(picked)))
    return chosen[_nearest(reaches.block(everyone, chosen), tilts[:, chosen])]


def _next_pick(reaches: Reaches, tilts: np.ndarray, rows: np.ndarray) -> int:
    """The orientation reaching the most of the points rows (M,) int (ties: the least summed tilt
    over them, then the first): the leading bound (the points each may still reach), tested until
    the leader's count is known; ValueError where some of the points have no orientation."""
    while True:
        may = reaches.optimistic(rows)
        if not may.any(axis=1).all():
            raise InputError(f"{int((~may.any(axis=1)).sum())} point(s) have no orientation that reaches them")
        counts = may.sum(axis=0)
        ties = np.flatnonzero(counts == counts.max())
        leader = int(ties[np.argmin(_summed(may[:, ties], tilts[rows][:, ties]))])
        if reaches.known[rows, leader].all():
            return leader
        reaches.column(leader, rows)


def _summed(reaches: np.ndarray, tilts: np.ndarray) -> np.ndarray:
    """(K,) degrees: each orientation's tilts (M, K) summed over the points it reaches (M, K),
    rounded to ANGLE_DECIMALS (so that float noise breaks no tie)."""
    return np.round(np.where(reaches, tilts, 0.0).sum(axis=0), ANGLE_DECIMALS)


def _nearest(reaches: np.ndarray, tilts: np.ndarray) -> np.ndarray:
    """(N,) int: for each point, which of C orientations reaches it least tilted (an index into
    them); reaches (N, C) bool, tilts (N, C) degrees."""
    return np.argmin(np.where(reaches, tilts, np.inf), axis=1)


def _needed(reaches: Reaches, chosen: np.ndarray) -> np.ndarray:
    """The orientations chosen (C,) int without those whose points the others reach all of
    (tried from the first chosen on)."""
    served = reaches.block(np.arange(reaches.shape[0]), chosen)
    kept = np.ones(len(chosen), dtype=bool)
    for slot in range(len(chosen)):
        kept[slot] = False
        if not served[:, kept].any(axis=1).all():
            kept[slot] = True
    return chosen[kept]


def _least_tilted(reaches: Reaches, tilts: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """The orientations chosen (C,) int, each in turn replaced by the orientation that reaches
    every point it serves (:func:`_nearest`) with the least summed tilt, tried from the least
    summed tilt up: as many orientations or fewer (C,) int, every point still reached."""
    chosen = chosen.copy()
    everyone = np.arange(reaches.shape[0])
    for slot in range(len(chosen)):
        serves = np.flatnonzero(_nearest(reaches.block(everyone, chosen), tilts[:, chosen]) == slot)
        if not serves.size:
            continue
        fits = reaches.optimistic(serves).all(axis=0)
        fits[chosen[slot]] = True
        candidates = np.flatnonzero(fits)
        for k in candidates[np.argsort(_summed(np.ones((len(serves), len(candidates)), dtype=bool),
                                               tilts[serves][:, candidates]), kind="stable")]:
            if reaches.column(int(k), serves).all():
                chosen[slot] = int(k)
                break
    return chosen


def orientation_labels(axes: np.ndarray) -> np.ndarray:
    """(N,) int: one label per distinct head orientation of probe axes (N, 3) unit (their head
    angles rounded to ANGLE_DECIMALS degrees, as the DMIS sensors are named), numbered in order of
    first use."""
    angles = np.round(head_angles(np.asarray(axes, dtype=float).reshape(-1, 3)), ANGLE_DECIMALS) + 0.0
    if not len(angles):
        return np.zeros(0, dtype=int)
    _, first, inverse = np.unique(angles, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=int)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[np.asarray(inverse).ravel()]


def orientation_changes(labels: np.ndarray, order: np.ndarray) -> int:
    """How often the orientation changes along a visiting order (N,) int of points with
    orientation labels (N,) int: the index moves (a DMIS program's SNSLCT after its first)."""
    visited = np.asarray(labels)[np.asarray(order, dtype=int)]
    return int(np.count_nonzero(visited[1:] != visited[:-1]))
