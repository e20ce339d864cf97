"""Independent check of a result with OpenCASCADE: its closest-point distance from the face's
nodes to the substitute surface, at the nodes of largest deviation."""
import numpy as np

from ..geometry.freecad_env import import_part

Part = import_part()

OCC_DISTANCE_NODES = 50


def occ_cross_check(stats, substitute):
    """Fill stats.occ_maximum using OpenCASCADE only: the largest of its closest-point distances
    from the nodes to the substitute, over the OCC_DISTANCE_NODES nodes of largest |d|.

    stats: DeviationStats; substitute: the fitted Part.BSplineSurface over the range the
    deviation is measured on (cmmsampling.geometry.surface.substitute_surface with ``extended``).
    """
    counted = ~np.isnan(stats.field)
    nodes = stats.nodes[counted]
    worst = nodes[np.argsort(stats.field[counted])[-OCC_DISTANCE_NODES:]]
    shape = substitute.toShape()
    stats.occ_maximum = float(max(shape.distToShape(Part.Vertex(*map(float, p)))[0] for p in worst))
    return stats
