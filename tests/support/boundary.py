"""The distance to a face's boundary as its curves on the surface define it, by OCC alone: the
reference where OCC's BRepExtrema measures to an edge's 3D curve, which may lie off that boundary
by up to the edge's tolerance."""
import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial import cKDTree

# Points per edge the nearest boundary point is first looked for among.
BOUNDARY_SAMPLES = 2001


def domain_parameters(face, raster=30, per_edge=200):
    """(u, v) of a raster x raster raster of the face's domain (the points inside its boundary by
    OCC's classifier) and of per_edge points along each of its edges, corners included."""
    u0, u1, v0, v1 = face.ParameterRange
    inside = [(u, v) for u in np.linspace(u0, u1, raster) for v in np.linspace(v0, v1, raster)
              if face.isPartOfDomain(u, v)]
    along = []
    for edge in face.Edges:
        curve, first, last = face.curveOnSurface(edge)[:3]
        along += [(curve.value(t).x, curve.value(t).y) for t in np.linspace(first, last, per_edge)]
    return inside + along


def boundary_distances(face, points):
    """mm (M,) from each point (M, 3) to the face's boundary as its curves on the surface define
    it: OCC's surface at OCC's curve on the surface, from the nearest of BOUNDARY_SAMPLES points an
    edge refined along the curve between its neighbours (bounded scalar minimisation of the squared
    distance over the fraction of that stretch, so that its tolerance is relative to the stretch)."""
    samples = []
    for edge in face.Edges:
        curve, first, last = face.curveOnSurface(edge)[:3]
        step = (last - first) / (BOUNDARY_SAMPLES - 1)
        samples += [(curve, t, max(first, t - step), min(last, t + step))
                    for t in np.linspace(first, last, BOUNDARY_SAMPLES)]
    on_face = np.array([boundary_point(face, curve, t) for curve, t, _, _ in samples])
    distances = []
    for point, nearest in zip(points, cKDTree(on_face).query(points)[1]):
        curve, _, low, high = samples[nearest]
        found = minimize_scalar(lambda s: np.sum((boundary_point(face, curve, low + s * (high - low)) - point) ** 2),
                                bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-12})
        distances.append(np.sqrt(found.fun))
    return np.array(distances)


def boundary_point(face, curve, t):
    """(3,) mm, OCC's surface of the face at its curve on the surface ``curve``'s parameter t."""
    at = curve.value(float(t))
    return np.array(tuple(face.Surface.value(at.x, at.y)))
