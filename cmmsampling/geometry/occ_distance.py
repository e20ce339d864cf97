"""OpenCASCADE's distance from points to a face, asked two ways.

``Shape.distToShape`` (BRepExtrema) was seen to miss the nearest point: on a rational patch with
clustered knots it put a point of the face itself 6.07 mm off. So each point is also projected
onto the face's surface (``Surface.parameter``, GeomAPI_ProjectPointOnSurf); where that foot lies
inside the face (``isPartOfDomain``) and nearer, it is the answer. Both feet are points of the
face, so the smaller distance is never below the true one.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .freecad_env import import_part

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)


def distances_to_face(face: Part.Face, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distance (N,) mm from each point (N, 3) mm to the Part.Face ``face`` and the nearest
    point on it (N, 3) mm, the nearer of BRepExtrema's and the surface projection's (see the
    module docstring). One OCC query of each kind per point: for checks, not optimiser loops."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    distances, feet = np.empty(len(points)), np.empty((len(points), 3))
    for row, point in enumerate(points):
        distances[row], feet[row] = _nearer(face, point, *_extrema(face, point))
    return distances, feet


def _extrema(face: Part.Face, point: np.ndarray) -> tuple[float, np.ndarray]:
    """(distance mm, foot (3,) mm) of BRepExtrema from point (3,) mm to the face."""
    distance, pairs, _ = face.distToShape(Part.Vertex(FreeCAD.Vector(*point)))
    return distance, np.array(tuple(pairs[0][0]))


def _nearer(face: Part.Face, point: np.ndarray, distance: float, foot: np.ndarray) -> tuple[float, np.ndarray]:
    """(distance, foot) of the surface projection of point (3,) mm where it lies on the face and
    nearer than ``distance`` mm, else the given pair. The projection's parameters are held to the
    face's parameter range: beyond a corner they were seen 3e-10 past it, where the face
    classifier still says inside and the surface's extrapolated point lay 1.1e-7 mm nearer than
    any point of the face."""
    vector = FreeCAD.Vector(*point)
    try:
        u, v = face.Surface.parameter(vector)
    except Part.OCCError:
        return distance, foot
    u0, u1, v0, v1 = face.ParameterRange
    u, v = min(max(u, u0), u1), min(max(v, v0), v1)
    projected = face.Surface.value(u, v)
    gap = projected.distanceToPoint(vector)
    if gap < distance and face.isPartOfDomain(u, v):
        return gap, np.array(tuple(projected))
    return distance, foot
