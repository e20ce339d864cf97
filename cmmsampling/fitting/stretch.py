"""Where the substitute is sampled more coarsely than the face: more places in those raster cells.

The nodes (cmmsampling.fitting.nodes) spread evenly over the face, every point of it within
``spacing`` of one. The reverse side measures the substitute at the nodes' parameters, S(h); where
the substitute is stretched against the face (a poor fit that bulges, or widens a pinched end of the
face), its points at neighbouring nodes lie farther apart than ``spacing``, and a bump of the
substitute between them goes unseen: on surf114.igs's Face4 a 49-point substitute optimised on the
nodes lies 33.3 mm from the face at its worst point while the nodes saw 19.1 mm. Each raster cell
(a cell with a node on the face) whose substitute diagonal exceeds STRETCH times the spacing gets a
(k + 1) x (k + 1) raster of places, its corners left out, k its diagonal over the spacing rounded up
(2 to MOST_SPLITS), so that the substitute is sampled there about as finely as the face is
everywhere. At most as many places as the raster has nodes (a judge then costs up to about four
times an unstretched one's): beyond, every cell's splits are scaled down alike.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .nodes import cell_diagonals

if TYPE_CHECKING:
    from .nodes import FaceNodes
    from .substitute import FittedSurface

STRETCH = 1.25
MOST_SPLITS = 16
# Rounds that scale the splits down to the budget.
BUDGET_STEPS = 8


@dataclass
class FinePlaces:
    """Places inside stretched raster cells: uv (M, 2) on the face (inside its trim); origin (M,)
    the index, among the counted raster nodes, of a node on the face at a corner of the place's
    cell; half (M, 2) the place's step in u and v (a zoom about it spans one either side)."""

    uv: np.ndarray
    origin: np.ndarray
    half: np.ndarray

    @classmethod
    def none(cls) -> FinePlaces:
        """No places."""
        return cls(np.zeros((0, 2)), np.zeros(0, dtype=int), np.zeros((0, 2)))


def stretched_places(nodes: FaceNodes, surface: FittedSurface,
                     on_face: Callable[[np.ndarray], np.ndarray] | None = None) -> FinePlaces:
    """The FinePlaces of the raster cells where the substitute is stretched (module docstring).

    nodes: FaceNodes; surface: the substitute (``points(uv)``, uv (M, 2) -> (M, 3) mm); on_face:
    uv (M, 2) -> (M,) bool, the face's trim test (None: the whole rectangle).
    """
    size = nodes.size
    if min(size) < 2 or nodes.spacing <= 0:
        return FinePlaces.none()
    points = surface.points(nodes.uv.reshape(-1, 2)).reshape(*size, 3)
    ratio = cell_diagonals(points) / nodes.spacing
    counted = nodes.counted
    corners = np.stack([counted[:-1, :-1], counted[1:, :-1], counted[:-1, 1:], counted[1:, 1:]], -1)
    cells = np.argwhere(corners.any(-1) & (ratio > STRETCH))
    if not len(cells):
        return FinePlaces.none()
    cells, splits = _within_budget(cells, ratio[cells[:, 0], cells[:, 1]], size[0] * size[1])
    order = np.cumsum(counted.ravel()) - 1
    first = np.argmax(corners[cells[:, 0], cells[:, 1]], axis=-1)
    corner_u, corner_v = cells[:, 0] + first % 2, cells[:, 1] + first // 2
    origin = order[corner_u * size[1] + corner_v]
    places = [_cell_places(nodes.uv, cells[splits == k], origin[splits == k], k) for k in np.unique(splits)]
    uv, origin, half = (np.concatenate(parts) for parts in zip(*places))
    keep = np.ones(len(uv), dtype=bool) if on_face is None else on_face(uv)
    return FinePlaces(uv[keep], origin[keep], half[keep])


def _within_budget(cells: np.ndarray, ratio: np.ndarray, most: int) -> tuple[np.ndarray, np.ndarray]:
    """(cells (C', 2), splits (C',)): the cells (C, 2) with their splits, the cell's ratio (C,) of
    diagonal to spacing rounded up (2 to MOST_SPLITS), all of them scaled down alike where the
    places would be more than ``most``, and the least stretched cells dropped where even two
    splits each are too many."""
    def splits_at(scale: float) -> np.ndarray:
        return np.clip(np.ceil(ratio * scale).astype(int), 2, MOST_SPLITS)

    scale = 1.0
    for _ in range(BUDGET_STEPS):
        needed = int(((splits_at(scale) + 1) ** 2 - 4).sum())
        if needed <= most:
            break
        scale *= 0.95 * np.sqrt(most / needed)
    splits = splits_at(scale)
    order = np.argsort(-ratio, kind="stable")
    kept = order[np.cumsum((splits[order] + 1) ** 2 - 4) <= most]
    return cells[kept], splits[kept]


def _cell_places(raster: np.ndarray, cells: np.ndarray, origin: np.ndarray,
                 splits: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(uv (C m, 2), origin (C m,), half (C m, 2)): the (splits + 1)^2 - 4 places of each cell (C, 2)
    of the raster (g_u, g_v, 2), its corners left out, at steps of a splits-th of the cell."""
    fraction = np.arange(splits + 1) / splits
    a, b = (grid.ravel() for grid in np.meshgrid(fraction, fraction, indexing="ij"))
    inner = ~(((a == 0) | (a == 1)) & ((b == 0) | (b == 1)))
    low = raster[cells[:, 0], cells[:, 1]]
    step = raster[cells[:, 0] + 1, cells[:, 1] + 1] - low
    uv = low[:, None] + np.stack([a[inner], b[inner]], -1)[None] * step[:, None]
    count = int(inner.sum())
    return uv.reshape(-1, 2), np.repeat(origin, count), np.repeat(step / splits, count, axis=0)
