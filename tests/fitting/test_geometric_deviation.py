"""The deviation is a distance in space (issue: judge and optimise the geometric deviation).

Every reported maximum is OpenCASCADE's closest-point distance from the face's nodes to the
substitute; the nodes lie on the face (trimmed faces too); on a rational face, where equal
parameters mislead, the optimisers beat uniform sampling in space; no strategy puts two points at
one place; the near-optimal descent is robust to bad starts.
"""
import os

import numpy as np
import pytest
from support.faces import TESTDATA, Part, holed_face, rational_saddle, strip_face

import cmmsampling
from cmmsampling.strategies.settings import default_min_spacing
from cmmsampling.strategies.sampling import make_problem


FACES = {
    "rational saddle": rational_saddle,
    "torus (converted)": lambda: Part.makeTorus(20, 5).Faces[0],
    "cylinder (converted)": lambda: Part.makeCylinder(10, 20).Faces[0],
    "holed plate (trimmed)": holed_face,
    "2 mm strip": strip_face,
}


@pytest.fixture(scope="module", params=sorted(FACES))
def sampled(request):
    """(face, result) of uniform parametric sampling, 36 points, 30 x 30 grid, OCC check on."""
    face = FACES[request.param]()
    return face, cmmsampling.sample(face, 36, "uniform_parametric", grid=30)


def test_reported_maximum_is_occs_closest_point_distance(sampled):
    """OCC's distance from the 50 worst nodes to the substitute equals the reported maximum."""
    _, result = sampled
    assert result.deviation.occ_maximum == pytest.approx(result.deviation.maximum, rel=1e-6)
    assert result.check.maximum >= 0.9 * result.deviation.maximum


def test_nodes_lie_on_the_face(sampled):
    """Every counted node is a point of the face (OCC distance), trimmed faces included."""
    face, result = sampled
    feet = result.problem.objective.nodes
    nodes = feet.points[feet.counted][::7]
    assert max(face.distToShape(Part.Vertex(*map(float, p)))[0] for p in nodes) < 1e-6


def test_trimmed_nodes_keep_out_of_the_hole():
    face = holed_face()
    feet = make_problem(face, 36, grid=40).objective.nodes
    hole_centre = np.array([40.0, 55.0])
    counted = feet.points[feet.counted]
    assert np.linalg.norm(counted[:, :2] - hole_centre, axis=1).min() >= 8.0 - 1e-6
    assert (np.linalg.norm(feet.points[..., :2] - hole_centre, axis=-1) < 7.9).any()


def equal_parameter_maximum(result):
    """The old measure, |S(h) - F(h)| at equal parameters, over the grid: mm."""
    uv = result.problem.grid.uv.reshape(-1, 2)
    return float(np.linalg.norm(result.space.evaluate(result.poles, uv) - result.model.points(uv), axis=1).max())


@pytest.fixture(scope="module")
def saddle_runs():
    """Uniform parametric, a short PSO and the near-optimal descent on the rational saddle, N = 81."""
    face = rational_saddle()
    return {name: cmmsampling.sample(face, 81, name, occ_check=False, **options)
            for name, options in (("uniform_parametric", {}), ("pso", {"iterations": 300}),
                                  ("optimal", {}))}


@pytest.mark.quality
def test_equal_parameters_overstate_the_rational_face(saddle_runs):
    """Equal parameters measure the parametrisation, not the form: several times the distance."""
    uniform = saddle_runs["uniform_parametric"]
    assert equal_parameter_maximum(uniform) > 3 * uniform.deviation.maximum


@pytest.mark.quality
def test_optimisers_beat_uniform_in_space_on_the_rational_face(saddle_runs):
    uniform = saddle_runs["uniform_parametric"].deviation.maximum
    assert saddle_runs["pso"].deviation.maximum < uniform
    assert saddle_runs["optimal"].deviation.maximum * 2 < uniform
    assert saddle_runs["optimal"].check.maximum * 2 < saddle_runs["uniform_parametric"].check.maximum


@pytest.mark.quality
@pytest.mark.parametrize("n", [49, 81, 144])
def test_optimal_ends_near_its_local_bound_on_the_rational_face(n, saddle_runs):
    result = saddle_runs["optimal"] if n == 81 else cmmsampling.sample(rational_saddle(), n, "optimal",
                                                                       occ_check=False)
    assert result.multiple_of_bound() <= 1.1


@pytest.mark.quality
def test_optimal_on_a_strip():
    result = cmmsampling.sample(strip_face(), 49, "optimal", occ_check=False)
    uniform = cmmsampling.sample(strip_face(), 49, "uniform_parametric", occ_check=False)
    assert result.deviation.maximum < uniform.deviation.maximum
    assert result.multiple_of_bound() <= 1.1


def closest_pair(points):
    """Smallest distance between two of the points (M, 3): mm."""
    gaps = np.linalg.norm(points[:, None] - points[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    return float(gaps.min())


FAST = {"pso": {"iterations": 30, "population": 10}, "optimal": {"max_evaluations": 200}}


@pytest.mark.parametrize("strategy", sorted(cmmsampling.self_contained()))
@pytest.mark.parametrize("name", ["sphere", "cylinder"])
def test_no_strategy_puts_two_points_at_one_place(strategy, name):
    """A sphere's collapsed poles and a cylinder's seam map many (u, v) to one place."""
    face = {"sphere": Part.makeSphere(10).Faces[0], "cylinder": Part.makeCylinder(10, 20).Faces[0]}[name]
    if (name, strategy) == ("cylinder", "uniform_cartesian"):
        with pytest.raises(ValueError, match="leaves part of the face without points"):
            cmmsampling.sample(face, 36, strategy, grid=24, occ_check=False)
        return
    result = cmmsampling.sample(face, 36, strategy, grid=24, occ_check=False, **FAST.get(strategy, {}))
    spacing = result.settings["min_spacing"]
    assert spacing == pytest.approx(default_min_spacing(face.Area, 36), rel=0.01)
    assert closest_pair(result.points) >= spacing - 1e-9


def test_optimal_repairs_a_crowded_start_and_says_so(reference):
    start = cmmsampling.sample(reference, 25, "uniform_parametric", grid=30, occ_check=False).uv.copy()
    start[1] = start[0] + 1e-6
    result = cmmsampling.sample(reference, 25, "optimal", grid=30, start=start, max_evaluations=300,
                                occ_check=False)
    assert any("closer than min_spacing" in note for note in result.notes)
    assert closest_pair(result.points) >= result.settings["min_spacing"] - 1e-9
    assert np.isfinite(result.history).all()


def test_optimal_never_ends_worse_than_its_start(reference):
    start = cmmsampling.sample(reference, 25, "halton", grid=30, occ_check=False)
    result = cmmsampling.sample(reference, 25, "optimal", grid=30, start=start.uv, max_evaluations=60,
                                occ_check=False)
    assert result.deviation.maximum <= start.deviation.maximum


@pytest.mark.skipif(not os.path.isdir(TESTDATA), reason="the shared CAD files are not beside the checkout")
def test_uniform_cartesian_refuses_a_face_its_footprint_grid_misses():
    face = Part.read(os.path.join(TESTDATA, "surf114.igs")).Faces[3]
    with pytest.raises(ValueError, match="uniform_cartesian leaves part of the face without points"):
        cmmsampling.sample(face, 81, "uniform_cartesian", occ_check=False)
    pso = cmmsampling.sample(face, 81, "pso", iterations=5, occ_check=False)
    assert np.isfinite(pso.deviation.maximum)


@pytest.mark.skipif(not os.path.isdir(TESTDATA), reason="the shared CAD files are not beside the checkout")
@pytest.mark.parametrize("index", [56, 60, 228])
def test_every_node_of_a_ventilator_blade_is_on_it(index):
    """OCC's isPartOfDomain agrees on every node, or the node is on the boundary (1e-9 mm)."""
    face = Part.read(os.path.join(TESTDATA, "Ventilator.stp")).Faces[index]
    feet = make_problem(face, 49).objective.nodes
    counted = np.flatnonzero(feet.counted.ravel())
    uv, points = feet.uv.reshape(-1, 2), feet.points.reshape(-1, 3)
    outside = [k for k in counted if not face.isPartOfDomain(*map(float, uv[k]))]
    assert len(counted) > 500
    assert all(face.distToShape(Part.Vertex(*map(float, points[k])))[0] < 1e-9 for k in outside)
