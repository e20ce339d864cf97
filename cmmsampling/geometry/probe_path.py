"""The order in which a CMM visits probe points: a short open path by nearest neighbour and 2-opt.

The path is the open polyline through the points in visiting order, measured in 3D (mm); the
clearance moves a CMM makes between points are not part of it. Any point may come first.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.distance import cdist

from ..geometry.validation import InputError

RELATIVE_TOLERANCE = 1e-12


@dataclass(frozen=True)
class PathOrder:
    """A visiting order and what it saves.

    order: (N,) int, a permutation of 0..N-1 (``points[order]`` is the visiting sequence);
    length_before: mm, the path through the points as given; length_after: mm, through ``order``.
    """

    order: np.ndarray
    length_before: float
    length_after: float

    @property
    def saving(self) -> float:
        """Shortening of the path in mm (length_before - length_after)."""
        return self.length_before - self.length_after


def path_length(points: np.ndarray, order: np.ndarray | None = None) -> float:
    """Length in mm of the open path through points (N, 3) mm, visited in order (N,) int (default: given)."""
    sequence = np.asarray(points, dtype=float)
    if order is not None:
        sequence = sequence[np.asarray(order)]
    return float(np.linalg.norm(np.diff(sequence, axis=0), axis=1).sum())


def unchanged(points: np.ndarray) -> PathOrder:
    """The given order of points (N, 3) mm as a PathOrder (nothing saved)."""
    length = path_length(points)
    return PathOrder(np.arange(len(points)), length, length)


def short_path(points: np.ndarray) -> PathOrder:
    """A short open path through points (N, 3) mm: nearest neighbour from the first point, then 2-opt.

    Never longer than the order given: when the nearest-neighbour start ends longer, the given
    order is improved by 2-opt instead. The result admits no segment reversal that shortens it by
    more than 1e-12 of the largest point distance. Returns a PathOrder.
    """
    points = _checked_points(points)
    if len(points) < 3:
        return unchanged(points)
    distances = cdist(points, points)
    tolerance = RELATIVE_TOLERANCE * max(float(distances.max()), 1.0)
    given = np.arange(len(points))
    order = two_opt(distances, nearest_neighbour(distances), tolerance)
    if _length(distances, order) > _length(distances, given):
        order = two_opt(distances, given, tolerance)
    return PathOrder(order, path_length(points), path_length(points, order))


def nearest_neighbour(distances: np.ndarray, start: int = 0) -> np.ndarray:
    """Greedy open path: from start, always on to the closest point not yet visited.

    distances: (N, N) mm, symmetric. Returns the order, (N,) int.
    """
    count = len(distances)
    order = np.empty(count, dtype=int)
    order[0] = start
    visited = np.zeros(count, dtype=bool)
    visited[start] = True
    for step in range(1, count):
        order[step] = np.argmin(np.where(visited, np.inf, distances[order[step - 1]]))
        visited[order[step]] = True
    return order


def two_opt(distances: np.ndarray, order: np.ndarray, tolerance: float) -> np.ndarray:
    """Reverse segments of the open path ``order`` while one shortens it by more than tolerance (mm).

    distances: (N, N) mm, symmetric; order: (N,) int. The open path is closed through a virtual
    point at distance 0 from all others, so every reversal of a contiguous run of the open path is
    a 2-opt move of that tour. For each first edge, all second edges are scored at once and the
    best improving one is taken. Returns the improved order, (N,) int.
    """
    count = len(order)
    closed = np.zeros((count + 1, count + 1))
    closed[:count, :count] = distances
    tour = np.append(np.asarray(order, dtype=int), count)
    improved = True
    while improved:
        improved = False
        for i in range(count - 1):
            a, b = tour[i], tour[i + 1]
            c = tour[i + 2:]
            d = np.append(tour[i + 3:], tour[0])
            gain = closed[a, b] + closed[c, d] - closed[a, c] - closed[b, d]
            best = int(np.argmax(gain))
            if gain[best] > tolerance:
                j = i + 2 + best
                tour[i + 1:j + 1] = tour[i + 1:j + 1][::-1].copy()
                improved = True
    virtual = int(np.flatnonzero(tour == count)[0])
    return np.roll(tour, -(virtual + 1))[:-1]


def _length(distances: np.ndarray, order: np.ndarray) -> float:
    """Length in mm of the open path ``order`` (N,) through a (N, N) distance matrix."""
    return float(distances[order[:-1], order[1:]].sum())


def _checked_points(points: np.ndarray) -> np.ndarray:
    """(N, 3) finite float array; ValueError naming the bad shape or values."""
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3:
        raise InputError(f"points must be an (N, 3) array in mm, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InputError("points contain NaN or infinite coordinates")
    return array
