"""The inspection's closest points, found all at once on the face's NURBS model, are OCC's: on a
face with a hole (feet beyond the trim go to its edge) and on a real part's face, every point's
distance within 1e-6 mm of OCC's own (distToShape, per point), and its signed distance too where
the foot lies inside the face (beside an edge the foot may slide along it, for a point over the
hole's middle, and the normal with it); an inspection's decisive points confirmed by OCC without
a note."""
import numpy as np
import pytest
from support.faces import Part, holed_face, shared_face
from support.measured import judged, moved

from cmmsampling.inspection.closest import FaceCloser
from cmmsampling.measurement import closest_points


def scattered(face, count=300, spread=0.05, seed=0):
    """Points (N, 3) mm near the face: its points at random parameters of its whole rectangle
    (some beyond its trim) moved up to ``spread`` mm along the normal."""
    rng = np.random.default_rng(seed)
    u0, u1, v0, v1 = face.ParameterRange
    uv = np.column_stack([rng.uniform(u0, u1, count), rng.uniform(v0, v1, count)])
    points = np.array([tuple(face.Surface.value(*p)) for p in uv])
    normals = np.array([tuple(face.Surface.normal(*p)) for p in uv])
    return points + rng.uniform(-spread, spread, (count, 1)) * normals


def signed(feet, normals, points):
    return np.einsum("ij,ij->i", points - feet, normals)


@pytest.mark.parametrize("name", ["holed plate", "surf114 Face2"])
def test_the_feet_are_occs(name):
    face = holed_face() if name == "holed plate" else shared_face("surf114.igs", 1)
    points = scattered(face)
    feet, normals = FaceCloser(face)(points)
    occ_feet, occ_normals, occ_distances = closest_points(face, points)
    np.testing.assert_allclose(np.linalg.norm(points - feet, axis=1), occ_distances, atol=1e-6)
    inside = np.array([min(edge.distToShape(Part.Vertex(*foot))[0] for edge in face.Edges) > 0.01 for foot in occ_feet])
    assert inside.sum() > 100
    np.testing.assert_allclose(signed(feet, normals, points)[inside], signed(occ_feet, occ_normals, points)[inside],
                               atol=1e-6)


def test_an_inspection_of_a_holed_plate_is_confirmed_by_occ():
    face = holed_face()
    rng = np.random.default_rng(4)
    points = [p for p in scattered(face, 400, 0.0, seed=4)
              if face.isPartOfDomain(*face.Surface.parameter(Part.Vertex(*p).Point))][:60]
    nominal = np.array(points)
    normals = np.array([tuple(face.normalAt(*face.Surface.parameter(Part.Vertex(*p).Point))) for p in nominal])
    form = 0.004 * rng.standard_normal(len(nominal))
    found = judged(face, nominal, moved(nominal + form[:, None] * normals, (0.4, 0.2, -0.5), (0.5, 0.2, 0.1)),
                   tolerance=0.05)
    occ_feet, occ_normals, _ = closest_points(face, found.points)
    np.testing.assert_allclose(found.deviations, signed(occ_feet, occ_normals, found.points), atol=1e-6)
    assert not any("OCC's distances" in note for note in found.notes)
