"""Independent check of a result with OpenCASCADE: its distances, both ways, at the nodes of largest
deviation (cmmsampling.fitting.exact): from the face's nodes to the substitute as delivered
(trimmed like the face), and from the substitute's points at the nodes' parameters back to the face."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..geometry.occ_distance import distances_to_face
from .occ_surface import trimmed_like

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from .deviation import DeviationStats
    from .exact import ExactDeviation

OCC_DISTANCE_NODES = 25


def occ_cross_check(stats: DeviationStats, exact: ExactDeviation, substitute: Part.BSplineSurface,
                    face: Part.Face) -> DeviationStats:
    """Fill stats.occ_maximum using OpenCASCADE only: the largest of its closest-point distances,
    from the OCC_DISTANCE_NODES nodes of largest forward deviation to the substitute trimmed like
    the face and from the
    substitute's points at the OCC_DISTANCE_NODES nodes of largest reverse deviation to the face.

    stats: DeviationStats; exact: the ExactDeviation it summarises; substitute: the delivered
    Part.BSplineSurface (cmmsampling.fitting.occ_surface.substitute_surface); face: the Part.Face.
    """
    forward = np.argsort(np.abs(exact.forward.values))[-OCC_DISTANCE_NODES:]
    reverse = np.argsort(np.abs(exact.reverse.values))[-OCC_DISTANCE_NODES:]
    node_points = exact.points()[forward]
    substitute_points = np.array([substitute.value(*map(float, uv)) for uv in exact.reverse.at[reverse]])
    shape = trimmed_like(face, substitute)
    stats.occ_maximum = max(_largest_distance(shape, node_points), _largest_distance(face, substitute_points))
    return stats


def _largest_distance(face: Part.Shape, points: np.ndarray) -> float:
    """The largest OCC distance (mm) from the points (M, 3) to a face (a Part.Face)."""
    return float(distances_to_face(face, points)[0].max(initial=0.0))
