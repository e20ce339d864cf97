"""SurfaceModel against OpenCASCADE: points, normals, derivatives and curvature."""
import numpy as np
import pytest
from support.faces import FreeCAD, Part, holed_face, sample_faces, uv_samples

from cmmsampling.geometry.surface import ON_FACE_MM, SurfaceModel, reference_poles

FACES = sample_faces()


def _scale(model):
    return max(1.0, float(np.abs(model.poles).max()))


@pytest.mark.parametrize("name", sorted(FACES))
def test_points_match_occ(name):
    model = SurfaceModel.from_face(FACES[name])
    uv = uv_samples(model)
    ours = model.points(uv)
    occ = np.array([tuple(model.face.Surface.value(u, v)) for u, v in uv])
    assert np.abs(ours - occ).max() <= 1e-9 * _scale(model)
    on_face = np.array([tuple(model.face.valueAt(u, v)) for u, v in uv])
    assert np.abs(ours - on_face).max() <= 1e-9 * _scale(model)


def test_no_parameters_give_no_points(reference):
    """An empty (u, v) set (a strategy's candidates can all fall off the face) is no error."""
    model = SurfaceModel.from_face(reference)
    assert model.points(np.zeros((0, 2))).shape == (0, 3)
    assert model.points(np.zeros((3, 0, 2))).shape == (3, 0, 3)


@pytest.mark.parametrize("name", sorted(FACES))
def test_normals_match_occ_face_orientation(name):
    model = SurfaceModel.from_face(FACES[name])
    uv = uv_samples(model)
    ours = model.normals(uv)
    occ = np.array([tuple(model.face.normalAt(u, v)) for u, v in uv])
    assert np.abs(ours - occ).max() <= 1e-9
    assert np.allclose(np.linalg.norm(ours, axis=1), 1.0, atol=1e-12)


def test_rational_faces_are_detected():
    assert SurfaceModel.from_face(FACES["rational_patch"]).rational
    assert SurfaceModel.from_face(FACES["sphere_converted"]).rational
    assert not SurfaceModel.from_face(FACES["reference_bspline"]).rational


def test_reversed_face_normal_points_out_of_the_box():
    face = FACES["box_face_reversed"]
    model = SurfaceModel.from_face(face)
    assert model.reversed
    centre = face.CenterOfMass
    normal = model.normals(uv_samples(model, 1))[0]
    box_centre = np.array([15.0, 10.0, 5.0])
    assert np.dot(normal, np.array(tuple(centre)) - box_centre) > 0


@pytest.mark.parametrize("name", ["rational_patch", "torus_converted", "reference_bspline"])
def test_derivatives_match_finite_differences(name):
    model = SurfaceModel.from_face(FACES[name])
    u0, u1, v0, v1 = model.bounds
    unit = 0.1 + 0.8 * np.random.default_rng(4).random((10, 2))
    uv = np.array([u0, v0]) + unit * np.array([u1 - u0, v1 - v0])
    d = model.derivatives(uv, 2)
    h = 1e-5 * np.array([u1 - u0, v1 - v0])
    for axis, key, key2 in ((0, (1, 0), (2, 0)), (1, (0, 1), (0, 2))):
        step = np.zeros(2)
        step[axis] = h[axis]
        plus, minus = model.derivatives(uv + step, 1), model.derivatives(uv - step, 1)
        fd = (plus[(0, 0)] - minus[(0, 0)]) / (2 * h[axis])
        fd2 = (plus[key] - minus[key]) / (2 * h[axis])
        scale = np.abs(d[key]).max()
        assert np.abs(fd - d[key]).max() <= 1e-6 * scale
        assert np.abs(fd2 - d[key2]).max() <= 1e-4 * max(np.abs(d[key2]).max(), scale)


def test_curvature_of_sphere_and_cylinder():
    sphere = SurfaceModel.from_face(FACES["sphere_converted"])
    u0, u1, v0, v1 = sphere.bounds
    uv = np.column_stack([np.linspace(u0 + 0.1, u1 - 0.1, 7), np.linspace(v0 + 0.3, v1 - 0.3, 7)])
    mean, gauss = sphere.curvatures(uv)
    assert np.allclose(np.abs(mean), 0.1, rtol=1e-9) and np.allclose(gauss, 0.01, rtol=1e-9)
    cylinder = SurfaceModel.from_face(FACES["cylinder_converted"])
    mean, gauss = cylinder.curvatures(uv_samples(cylinder))
    assert np.allclose(np.abs(mean), 0.05, rtol=1e-9) and np.allclose(gauss, 0.0, atol=1e-12)


def test_curvature_matches_occ(reference):
    model = SurfaceModel.from_face(reference)
    uv = uv_samples(model, 15, seed=2)
    mean, gauss = model.curvatures(uv)
    occ_mean = np.array([reference.Surface.curvature(u, v, "Mean") for u, v in uv])
    occ_gauss = np.array([reference.Surface.curvature(u, v, "Gauss") for u, v in uv])
    assert np.allclose(np.abs(mean), np.abs(occ_mean), rtol=1e-7, atol=1e-12)
    assert np.allclose(gauss, occ_gauss, rtol=1e-7, atol=1e-12)


def test_reference_face_definition(reference):
    surface = reference.Surface
    assert (surface.UDegree, surface.VDegree) == (5, 5)
    assert (surface.NbUPoles, surface.NbVPoles) == (9, 9)
    poles = np.array([[tuple(p) for p in row] for row in surface.getPoles()])
    assert np.allclose(poles, reference_poles())
    assert poles[8, 8, 0] == pytest.approx(100.0) and poles[3, 2, 1] == pytest.approx(25.0)
    x, y = 75.0, 25.0
    z = 12 * np.sin(2.5 * np.pi * x / 100) * np.cos(1.7 * np.pi * y / 100)
    z += 8 * np.exp(-((x - 70) ** 2 + (y - 30) ** 2) / 300)
    assert poles[6, 2, 2] == pytest.approx(z, abs=1e-12)
    assert np.allclose(surface.getWeights(), 1.0)
    assert reference.ParameterRange == pytest.approx((0.0, 1.0, 0.0, 1.0))


def test_non_face_input_is_refused():
    import Part

    with pytest.raises(TypeError, match="one face"):
        SurfaceModel.from_face(Part.makeBox(1, 1, 1))
    with pytest.raises(TypeError, match="Part.Face"):
        SurfaceModel.from_face("Face1")


def test_points_off_a_trimmed_face_are_moved_onto_it_and_the_others_stay():
    face = holed_face()
    model = SurfaceModel.from_face(face)
    hole_centre = np.array(face.Surface.parameter(FreeCAD.Vector(40, 55, 0)))
    inside = uv_samples(model, 6)
    inside = inside[[face.isPartOfDomain(u, v) and face.distToShape(Part.Vertex(face.valueAt(u, v)))[0] < 1e-9
                     for u, v in inside]]
    uv = np.vstack([inside, hole_centre + [0.01, 0.0], hole_centre])
    moved, which, off = model.onto_face(uv)
    assert off[:len(inside)].max() < 1e-9 and off[len(inside):].min() > 7.0
    assert not which[:len(inside)].any() and which[len(inside):].all()
    assert np.array_equal(moved[:len(inside)], inside)
    after = [face.distToShape(Part.Vertex(*p))[0] for p in model.points(moved)]
    assert max(after) <= ON_FACE_MM
    # a moved point lands at the hole's edge, 8 mm (the radius) in 3D from the hole's centre
    assert np.allclose(np.linalg.norm(model.points(moved[-2:])[:, :2] - [40, 55], axis=1), 8.0, atol=0.05)


def test_the_banded_loop_test_counts_the_crossings_of_every_segment():
    """LoopCrossings tests a point against its band's segments only: the same answer as the
    even-odd count over every segment (written out here), also at the loops' own vertices' v,
    and the answer OCC gives for points clear of the boundary."""
    from cmmsampling.geometry.domain import LoopCrossings

    face = holed_face()
    model = SurfaceModel.from_face(face)
    loops = model.trim_loops(model.diagonal / 1000)
    starts, ends = np.concatenate(loops), np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
    rng = np.random.default_rng(5)
    u0, u1, v0, v1 = model.bounds
    uv = np.c_[rng.uniform(u0, u1, 3000), rng.uniform(v0, v1, 3000)]
    uv[:500, 1] = starts[rng.integers(0, len(starts), 500), 1]
    u, v = uv[:, 0, None], uv[:, 1, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        at = starts[:, 0] + (v - starts[:, 1]) * (ends[:, 0] - starts[:, 0]) / (ends[:, 1] - starts[:, 1])
    every = (((starts[:, 1] <= v) != (ends[:, 1] <= v)) & (at > u)).sum(axis=1) % 2 == 1
    tester = LoopCrossings(loops, bands=64)
    np.testing.assert_array_equal(tester.inside(uv), every)
    scale = np.array([u1 - u0, v1 - v0])
    gap = np.min(np.linalg.norm((uv[500:, None] - starts[None]) / scale, axis=-1), axis=1)
    clear = uv[500:][gap > 0.01][:300]
    occ = np.array([face.isPartOfDomain(a, b) for a, b in clear])
    assert len(clear) > 100 and occ.any() and not occ.all()
    np.testing.assert_array_equal(tester.inside(clear), occ)
