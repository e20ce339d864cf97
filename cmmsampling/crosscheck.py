"""Independent check of a result with OpenCASCADE: both surfaces evaluated by OCC, and OCC's
closest-point distance from the substitute to the CAD face."""
import numpy as np

from .freecad_env import import_part

Part = import_part()

OCC_DISTANCE_NODES = 50


def occ_cross_check(stats, substitute, face):
    """Fill stats.occ_maximum and stats.occ_distance_maximum using OpenCASCADE only.

    substitute: the fitted Part.BSplineSurface; face: the CAD Part.Face (its (u, v) are the grid's).
    """
    nodes = stats.grid_uv[~np.isnan(stats.field)]
    cad = face.Surface
    gaps = np.array([(substitute.value(u, v) - cad.value(u, v)).Length for u, v in nodes])
    stats.occ_maximum = float(gaps.max())
    worst = nodes[np.argsort(gaps)[-OCC_DISTANCE_NODES:]]
    distances = [face.distToShape(Part.Vertex(substitute.value(u, v)))[0] for u, v in worst]
    stats.occ_distance_maximum = float(max(distances))
    return stats
