"""Faces that are hard on purpose: a collapsed pole row, poles of a sphere, a full periodic cylinder,
a plane, a tiny face; each gets usable points or a message saying what to change."""
import numpy as np
import pytest
from support.faces import FreeCAD, Part, cartesian_refuses, collapsed_face, tolerant_face

import cmmsampling
from cmmsampling.geometry.surface import SurfaceModel

QUICK = {"pso": {"iterations": 10, "population": 6}, "optimal": {"max_evaluations": 40}}


def test_normals_on_degenerate_edges_are_the_limit_normals():
    collapsed = collapsed_face()
    model = SurfaceModel.from_face(collapsed)
    uv = np.array([[0.0, 0.2], [0.0, 0.5], [0.0, 1.0]])
    occ = np.array([tuple(collapsed.normalAt(u, v)) for u, v in uv])
    assert np.abs(model.normals(uv) - occ).max() < 1e-5
    sphere = SurfaceModel.from_face(Part.makeSphere(5).Faces[0])
    poles = np.array([[1.0, sphere.bounds[3]], [2.0, sphere.bounds[2]]])
    occ = np.array([tuple(sphere.face.normalAt(u, v)) for u, v in poles])
    assert np.abs(sphere.normals(poles) - occ).max() < 1e-5


@pytest.mark.parametrize("strategy", sorted(cmmsampling.self_contained()))
@pytest.mark.parametrize("make", [collapsed_face, lambda: Part.makeSphere(5).Faces[0],
                                  lambda: Part.makeCylinder(10, 20).Faces[0]],
                         ids=["collapsed_edge", "sphere", "full_cylinder"])
def test_degenerate_and_periodic_faces_give_usable_points(make, strategy):
    face = make()
    run = lambda: cmmsampling.sample(face, 16, strategy, grid=24, occ_check=False, **QUICK.get(strategy, {}))  # noqa: E731
    if cartesian_refuses(strategy, isinstance(face.Surface, Part.Cylinder), run):
        return
    result = run()
    assert np.all(np.isfinite(result.points)) and np.all(np.isfinite(result.normals))
    occ = np.array([tuple(result.model.face.normalAt(u, v)) for u, v in result.uv])
    assert np.abs(occ - result.normals).max() < 1e-5
    gaps = np.linalg.norm(result.points[:, None] - result.points[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    assert gaps.min() > 0


@pytest.mark.parametrize("face", [Part.makePlane(50, 30).Faces[0], Part.makePlane(1e-3, 2e-3).Faces[0]],
                         ids=["plane", "tiny"])
def test_exact_fits_say_so(face):
    result = cmmsampling.sample(face, 16, "pso", iterations=5, population=4)
    assert result.exact and result.multiple_of_bound() == 1.0
    assert any("reproduces this face exactly" in note for note in result.notes), result.notes
    assert np.isfinite(result.deviation.maximum)


def test_nan_and_infinite_input_is_refused(reference):
    with pytest.raises(ValueError, match="edge_offset must be a finite number"):
        cmmsampling.sample(reference, 16, "halton", edge_offset=float("inf"))
    with pytest.raises(ValueError, match="uv contains NaN"):
        cmmsampling.evaluate(reference, np.full((16, 2), np.nan))
    with pytest.raises(ValueError, match="uv must be an \\(N, 2\\) array"):
        cmmsampling.evaluate(reference, np.zeros((16, 3)))


@pytest.mark.parametrize("strategy", ["uniform_parametric", "halton", "pso", "optimal"])
def test_a_valid_face_with_tolerant_edges_is_sampled_inside_its_3d_boundary(strategy):
    """Points between the face's curves on the surface and its 3D edges (within the face's
    tolerance of it, but off it by OCC's distance and classifier) are moved onto it."""
    face = tolerant_face()
    assert face.isValid() and face.Surface.UDegree == 8
    face.check(True)   # raises where OCC finds the face broken
    assert face.getTolerance(1) > 0.01
    model = SurfaceModel.from_face(face)
    angles = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    rim = np.c_[0.5 + 0.4001 * np.cos(angles), 0.5 + 0.4001 * np.sin(angles)]
    off, _, inside = model._occ_placement(rim)
    within = inside & (off > 1e-3) & (off <= face.getTolerance(1))
    assert within.any() and not model.on_face(rim[within]).any()
    result = cmmsampling.sample(face, 49, strategy, edge_offset=0.0, workers=1, occ_check=False,
                                **QUICK.get(strategy, {}))
    assert len(result.points) == 49
    assert all(face.isPartOfDomain(u, v) for u, v in result.uv)
    distances = [face.distToShape(Part.Vertex(*point))[0] for point in result.points]
    assert max(distances) <= 1e-4
    assert all(face.isInside(FreeCAD.Vector(*point), 1e-4, True) for point in result.points)
