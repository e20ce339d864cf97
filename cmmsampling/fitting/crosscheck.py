"""Independent check of a result with OpenCASCADE: its distances, both ways, at the places of
largest deviation (cmmsampling.fitting.exact): from the face's nodes to the substitute as delivered
(trimmed like the face), and from the substitute's points back to the face: those at the nodes'
parameters and those of a dense raster of the substitute whose distance to the face, estimated
from the face nodes' tangent planes, is largest (a peak on the substitute's side between the
judged nodes: surf114 Face4 with 81 optimal points was judged 1.633 mm at its nodes, and OCC
found 1.746 mm on an 80 x 80 raster of the substitute). The largest of them is the result's
headline figure (:func:`cmmsampling.strategies.sampling.evaluate`)."""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..geometry.occ_distance import distances_to_face
from .occ_surface import trimmed_like

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from .deviation import DeviationStats
    from .exact import ExactDeviation
    from .substitute import SubstituteSpace

OCC_DISTANCE_NODES = 25
# Points per direction of the substitute's dense raster, and how many of them OCC measures.
DENSE_RASTER = 160
DENSE_MEASURED = 25


def occ_cross_check(stats: DeviationStats, exact: ExactDeviation, substitute: Part.BSplineSurface,
                    face: Part.Face, space: SubstituteSpace | None = None,
                    counts: Callable[[np.ndarray], np.ndarray] | None = None) -> DeviationStats:
    """Fill stats.occ_maximum and stats.occ_location using OpenCASCADE only: the largest of its
    closest-point distances from the OCC_DISTANCE_NODES nodes of largest forward deviation to the
    substitute trimmed like the face, and to the face from the substitute's points at the
    OCC_DISTANCE_NODES nodes of largest reverse deviation and (given the substitute's space) at
    the DENSE_MEASURED points of its DENSE_RASTER raster estimated farthest from the face; the
    location is the face's point of that distance.

    stats: DeviationStats; exact: the ExactDeviation it summarises; substitute: the delivered
    Part.BSplineSurface (cmmsampling.fitting.occ_surface.substitute_surface); face: the Part.Face;
    space: the substitute's SubstituteSpace; counts: uv (..., 2) -> (...) bool, where the
    deviation counts (the face's trim and the probe's reach; None: everywhere).
    """
    forward = np.argsort(np.abs(exact.forward.values))[-OCC_DISTANCE_NODES:]
    reverse = np.argsort(np.abs(exact.reverse.values))[-OCC_DISTANCE_NODES:]
    node_points = exact.points()[forward]
    substitute_points = np.array([substitute.value(*map(float, uv)) for uv in exact.reverse.at[reverse]])
    if space is not None:
        substitute_points = np.concatenate([substitute_points, _dense_candidates(exact, space, counts)])
    ahead = distances_to_face(trimmed_like(face, substitute), node_points)[0]
    back, feet = distances_to_face(face, substitute_points)
    if ahead.max(initial=0.0) >= back.max(initial=0.0):
        stats.occ_maximum, stats.occ_location = float(ahead.max(initial=0.0)), node_points[int(np.argmax(ahead))]
    else:
        stats.occ_maximum, stats.occ_location = float(back.max()), feet[int(np.argmax(back))]
    return stats


def _dense_candidates(exact: ExactDeviation, space: SubstituteSpace,
                      counts: Callable[[np.ndarray], np.ndarray] | None) -> np.ndarray:
    """(DENSE_MEASURED, 3) mm: the substitute's points on a DENSE_RASTER raster of its parameter
    rectangle, where the deviation counts, farthest from the face by the tangent plane of the
    face node nearest each (an estimate that ranks them)."""
    from .substitute import FittedSurface

    u0, u1, v0, v1 = space.bounds
    grid = np.stack(np.meshgrid(np.linspace(u0, u1, DENSE_RASTER), np.linspace(v0, v1, DENSE_RASTER),
                                indexing="ij"), axis=-1).reshape(-1, 2)
    if counts is not None:
        grid = grid[np.asarray(counts(grid), dtype=bool)]
    if not len(grid):
        return np.zeros((0, 3))
    points = FittedSurface(space, exact.poles).points(grid)
    nodes = exact.nodes
    normals = np.concatenate([nodes.normals[nodes.counted], nodes.edge_normals])
    _, nearest = nodes.point_tree.query(points)
    estimate = np.abs(np.einsum("nc,nc->n", points - nodes.all_points()[nearest], normals[nearest]))
    return points[np.argsort(estimate)[-DENSE_MEASURED:]]
