"""The headline maximum is OCC's confirmed two-sided distance between the face and the delivered
substitute_shape(), however the search found it: not the project's own figure where that
overstates (Bottom.brep Face23, degree 7, a collapsed edge: its vertex judged 0.02606 mm, OCC
0.02072 mm), nor a node-bound one where the substitute swings between the judged nodes
(surf114.igs Face4, 81 points an optimal run placed, kept in tests/data: 1.633 mm at the nodes;
an independent OCC judge found 1.761 mm). Checked here with OCC on rasters of both surfaces
(skipped without the shared test data)."""
import os

import numpy as np
import pytest
from support.faces import Part, shared_face
from support.paths import DATA

import cmmsampling


def occ_two_sided(face, substitute, count):
    """OCC's largest distance (mm) from a count x count raster of the face (inside it) to the
    delivered substitute, and from one of the substitute (inside its trim) to the face."""
    def raster(shape):
        u0, u1, v0, v1 = shape.ParameterRange
        return [shape.Surface.value(u, v) for u in np.linspace(u0, u1, count) for v in np.linspace(v0, v1, count)
                if shape.isPartOfDomain(u, v)]

    ahead = max(substitute.distToShape(Part.Vertex(point))[0] for point in raster(face))
    back = max(face.distToShape(Part.Vertex(point))[0] for point in raster(substitute))
    return max(ahead, back)


def test_a_collapsed_edge_does_not_overstate_the_headline():
    face = shared_face("Bottom.brep", 22)
    assert any(edge.Degenerated for edge in face.Edges) and face.Surface.UDegree == 7
    result = cmmsampling.sample(face, 49, "uniform_parametric")
    independent = occ_two_sided(face, result.substitute_shape(), 40)
    print(f"Bottom F23, 49 uniform: headline {result.deviation.maximum:.5f} mm, OCC rasters {independent:.5f} mm")
    assert result.deviation.maximum == pytest.approx(0.02072, rel=0.01), "the independent judge's figure"
    assert independent * (1 - 1e-6) <= result.deviation.maximum <= independent * 1.01


def test_a_peak_on_the_substitute_between_the_nodes_is_in_the_headline():
    face = shared_face("surf114.igs", 3)
    uv = np.loadtxt(os.path.join(DATA, "surf114_face4_optimal_81_uv.txt"))
    result = cmmsampling.evaluate(face, uv)
    independent = occ_two_sided(face, result.substitute_shape(), 40)
    print(f"surf114 F4, 81 points: headline {result.deviation.maximum:.4f} mm, OCC rasters {independent:.4f} mm")
    assert result.deviation.maximum == pytest.approx(1.761, rel=0.01), "the independent judge's figure"
    assert result.deviation.maximum >= independent * (1 - 1e-6)
