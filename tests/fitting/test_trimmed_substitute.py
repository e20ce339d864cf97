"""The substitute handed to the user is trimmed like the face: ``substitute_shape()`` (the document's
Substitute surface) is bounded by the face's own boundary laid on the substitute, so what OCC
measures between it and the face, both ways, is the reported maximum. A STEP file's curves on the
surface leave gaps at the corners that OCC's wire does not bridge, and the whole parameter
rectangle was handed over instead (148 of the Ventilator's 189 B-spline faces). And the points
delivered lie on the face within its own tolerance, also where its edges are tolerant."""
import os

import numpy as np
import pytest
from support.boundary import domain_parameters
from support.faces import TESTDATA, Part

import cmmsampling
from cmmsampling.fitting.occ_surface import trimmed_like

pytestmark = pytest.mark.skipif(not os.path.isdir(TESTDATA), reason="the shared CAD files are not beside the checkout")


@pytest.fixture(scope="module")
def ventilator():
    return Part.read(os.path.join(TESTDATA, "Ventilator.stp"))


def test_every_b_spline_face_laid_on_its_own_surface_is_itself(ventilator):
    """Trimmed like itself, each B-spline face of the Ventilator has its own area (to 1e-4: the
    corner gaps, up to 1e-4 of a parameter, are closed at their middles)."""
    faces = [face for face in ventilator.Faces if isinstance(face.Surface, Part.BSplineSurface)]
    ratios = np.array([trimmed_like(face, face.Surface).Area / face.Area for face in faces])
    assert len(faces) == 189
    assert np.abs(ratios - 1.0).max() < 1e-4, f"{np.sum(np.abs(ratios - 1.0) >= 1e-4)} faces differ"


@pytest.mark.parametrize("name, strategy", [("Face61", "uniform_parametric"), ("Face230", "uniform_parametric"),
                                            ("Face23", "halton"), ("Face192", "halton")])
def test_the_delivered_substitute_is_what_the_figure_describes(ventilator, name, strategy):
    """OCC alone, from the face's points to substitute_shape() and from its points (a raster of its
    own domain and its edges) back to the face: the largest is the reported maximum to 1 %. On
    Face23 and Face192 (trimmed by slanted edges) the face's corner lies farther from the trimmed
    substitute than from its rectangle, which the forward side measured before: 0.0700 mm
    reported where OCC finds 0.0814 mm, 0.0974 where 0.1309."""
    face = ventilator.getElement(name)
    result = cmmsampling.sample(face, 49, strategy)
    delivered = result.substitute_shape()
    forward = max(delivered.distToShape(Part.Vertex(face.valueAt(u, v)))[0] for u, v in domain_parameters(face))
    reverse = max(face.distToShape(Part.Vertex(delivered.valueAt(u, v)))[0] for u, v in domain_parameters(delivered))
    assert max(forward, reverse) == pytest.approx(result.deviation.maximum, rel=0.01)
    assert delivered.isValid() and len(delivered.Edges) == len(face.Edges)


@pytest.mark.parametrize("strategy", ["uniform_parametric", "halton"])
def test_points_on_a_plane_with_tolerant_edges_lie_on_it(ventilator, strategy):
    """Ventilator Face16, a plane whose parameter range reaches 0.024 mm past its edges (the edges
    0.014 mm tolerant, the face 1e-7 mm): every point within 1e-4 mm of the face by OCC's distance
    (the face's own tolerance counts, not its edges': 5 points lay 0.014-0.024 mm outside it)."""
    face = ventilator.getElement("Face16")
    result = cmmsampling.sample(face, 25, strategy, occ_check=False)
    distances = [face.distToShape(Part.Vertex(*point))[0] for point in result.points]
    assert max(distances) < 1e-4
