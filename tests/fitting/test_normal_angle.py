"""The substitute's shape beside its distance: the largest angle between its normals and the
face's (DeviationStats.normal_angle), checked against OCC's normals of the delivered
substitute_shape() at its nearest points to the face's raster nodes. A poor substitute of a
Ventilator blade (uniform, 16 points) lies within about 0.5 mm of the face but is corrugated:
its normals a median of about 28 degrees off, up to about 85."""
import os

import numpy as np
import pytest
from support.faces import TESTDATA, Part

import cmmsampling


def occ_angles(result, face):
    """Degrees between the face's normal at each counted raster node and the delivered
    substitute's normal at its nearest point, by OCC."""
    substitute = result.substitute_shape()
    counted = np.isfinite(result.deviation.field)
    angles = []
    for point, (u, v) in zip(result.deviation.nodes[counted], result.deviation.grid_uv[counted]):
        foot = substitute.distToShape(Part.Vertex(*point))[1][0][0]
        normal = substitute.Surface.normal(*substitute.Surface.parameter(foot))
        angles.append(np.degrees(np.arccos(min(1.0, abs(normal.dot(face.normalAt(u, v)))))))
    return np.array(angles)


def test_a_good_substitute_follows_the_faces_normals(reference):
    result = cmmsampling.sample(reference, 144, "uniform_parametric")
    angles = occ_angles(result, reference)
    assert result.deviation.normal_angle == pytest.approx(angles.max(), abs=0.5)
    assert result.deviation.normal_angle < 10


def test_a_corrugated_substitute_shows_in_its_normal_angle():
    path = os.path.join(TESTDATA, "Ventilator.stp")
    if not os.path.isfile(path):
        pytest.skip("the shared test data (Ventilator.stp) is not here")
    face = Part.read(path).Faces[229]
    result = cmmsampling.sample(face, 16, "uniform_parametric")
    angles = occ_angles(result, face)
    print(f"F230, 16 uniform points: max {result.deviation.maximum:.3f} mm, normals up to "
          f"{result.deviation.normal_angle:.1f} deg off (OCC at the raster: median {np.median(angles):.1f}, "
          f"max {angles.max():.1f})")
    assert result.deviation.maximum < 1.0 and np.median(angles) > 15, "near the face, but corrugated"
    assert angles.max() - 0.5 <= result.deviation.normal_angle <= 90, "its own nodes and the edges besides"
    assert result.deviation.normal_angle > 45
