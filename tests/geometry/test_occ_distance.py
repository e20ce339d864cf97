"""OCC's distance from points to a face, asked two ways (cmmsampling.geometry.occ_distance), what
the inspection measures with it, and what a swarm's note quotes where distToShape misses."""
import numpy as np
import pytest
from support.faces import FreeCAD, Part, clustered_reversed_face

import cmmsampling
from cmmsampling.formats.pointset import PointSet
from cmmsampling.geometry.occ_distance import distances_to_face

# Where OCC's distToShape misses the face's own point on clustered_reversed_face().
MISSED_UV = (0.79901291, 2.05576347)


def test_a_face_point_distToShape_misses_is_found_on_the_face():
    face = clustered_reversed_face()
    point = face.Surface.value(*MISSED_UV)
    assert face.distToShape(Part.Vertex(point))[0] > 6.0
    distance, foot = distances_to_face(face, [tuple(point)])
    assert distance[0] <= 1e-9 and np.allclose(foot[0], tuple(point), atol=1e-9)


def test_points_off_the_face_keep_their_distance():
    """A point 1.5 mm above the face along its normal, and one beyond its corner, where the
    projection's foot would lie outside the face: both as far as the geometry says."""
    face = clustered_reversed_face()
    u, v = 0.5, 20.0
    above = face.Surface.value(u, v) + face.normalAt(u, v) * 1.5
    corner = face.Surface.value(1.0, 50.0)
    beyond = corner + FreeCAD.Vector(3.0, 4.0, 0.0)
    distance, foot = distances_to_face(face, [tuple(above), tuple(beyond)])
    assert distance[0] == pytest.approx(1.5, rel=1e-6)
    assert distance[1] == pytest.approx(face.distToShape(Part.Vertex(beyond))[0], rel=1e-9)
    assert distance[1] <= beyond.distanceToPoint(corner) + 1e-9


def test_a_point_beyond_a_corner_is_as_far_as_the_corner():
    """Beyond the reference face's corner the surface projection lands a hair past the parameter
    range, where the classifier still says inside: held to the range, the distance is the
    corner's (unheld, the extrapolated point was 1.1e-7 mm nearer)."""
    face = cmmsampling.reference_face()
    u, v = face.ParameterRange[1], face.ParameterRange[3]
    corner = face.Surface.value(u, v)
    outward = (corner - face.Surface.value(u - 1e-6, v)) + (corner - face.Surface.value(u, v - 1e-6))
    for scale in (1e2, 1e1, 1.0):
        point = corner + outward * scale
        distance = distances_to_face(face, [tuple(point)])[0][0]
        assert distance == pytest.approx(point.distanceToPoint(corner), rel=1e-9)


def test_the_inspection_measures_the_face_points_distToShape_misses_as_on_it():
    face = clustered_reversed_face()
    places = [MISSED_UV, (0.5, 20.0), (0.2, 40.0)]
    points = np.array([tuple(face.Surface.value(*uv)) for uv in places])
    normals = np.array([tuple(face.normalAt(*uv)) for uv in places])
    measured = cmmsampling.measured_deviation(face, PointSet(["P1", "P2", "P3"], points, normals))
    assert np.abs(measured.distances).max() <= 1e-6


def test_a_swarm_note_quotes_the_figures_the_result_reports():
    """The swarm's best is compared with its uniform starts in a note; the start it returns is
    compared as it is delivered (the face point distToShape misses, in the uniform Cartesian
    layout, moved first), so the note gives the figure the result reports."""
    face = clustered_reversed_face()
    result = cmmsampling.sample(face, 25, "pso", iterations=40, workers=1, occ_check=True)
    quoted = [note for note in result.notes if "that layout is returned" in note]
    assert quoted, result.notes
    assert f"({result.deviation.maximum:.4g} mm against" in quoted[0]
    assert result.deviation.occ_maximum == pytest.approx(result.deviation.maximum, rel=1e-6)
