"""The substitute as an OCC surface: the fitted B-spline handed to FreeCAD (Part.BSplineSurface),
over the face's parameter range or over the wider range the deviation is measured on."""
import numpy as np

from ..geometry.bspline import design_matrices
from ..geometry.surface import make_bspline_surface
from .substitute import FittedSurface


def substitute_surface(space, poles, extended=False):
    """The substitute fitted in ``space`` (a SubstituteSpace) as a Part.BSplineSurface.

    poles: (n_u, n_v, 3) mm. The surface spans the face's parameter range, or with ``extended``
    the wider range of cmmsampling.fitting.substitute.FittedSurface, over which the deviation is measured:
    the same polynomials, its end spans lengthened (exactly representable, so the poles follow
    from a least-squares fit to the surface sampled over the wider range).
    """
    if not extended:
        return make_bspline_surface(poles, space.degrees, uknots=space.uknots, vknots=space.vknots)
    surface = FittedSurface(space, poles)
    u0, u1, v0, v1 = surface.bounds
    uknots = np.concatenate([[u0] * (space.degrees[0] + 1), space.uknots[space.degrees[0] + 1:-space.degrees[0] - 1],
                             [u1] * (space.degrees[0] + 1)])
    vknots = np.concatenate([[v0] * (space.degrees[1] + 1), space.vknots[space.degrees[1] + 1:-space.degrees[1] - 1],
                             [v1] * (space.degrees[1] + 1)])
    su = np.linspace(u0, u1, 4 * space.poles[0])
    sv = np.linspace(v0, v1, 4 * space.poles[1])
    grid = np.stack(np.meshgrid(su, sv, indexing="ij"), -1)
    samples = surface.points(grid.reshape(-1, 2)).reshape(grid.shape[:2] + (3,))
    bu = np.linalg.pinv(design_matrices(uknots, space.degrees[0], su)[0])
    bv = np.linalg.pinv(design_matrices(vknots, space.degrees[1], sv)[0])
    extended_poles = np.einsum("ai,ijc,bj->abc", bu, samples, bv)
    return make_bspline_surface(extended_poles, space.degrees, uknots=uknots, vknots=vknots)
