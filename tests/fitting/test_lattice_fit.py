"""The swarm's fits from lattice tables (cmmsampling.fitting.lattice) against fits from bases
evaluated anew at the same rounded parameters, on a polynomial and a rational face, a strip and
a face with a collapsed edge; and the fallback for faces whose tables would be too large."""
import numpy as np
import pytest

from cmmsampling.fitting import deviation
from cmmsampling.fitting.lattice import LATTICE_STEPS, LatticeFit
from cmmsampling.strategies.sampling import make_problem
from support.faces import collapsed_face, rational_patch_face, strip_face

FACES = {"reference": None, "rational": rational_patch_face, "strip": strip_face, "collapsed": collapsed_face}


@pytest.fixture(scope="module", params=sorted(FACES))
def problem(request, reference):
    face = reference if FACES[request.param] is None else FACES[request.param]()
    return make_problem(face, 49, grid=30, workers=1)


def swarm(problem, count=7, seed=2):
    """Random point sets (count, N, 2) inside the problem's domain box."""
    rng = np.random.default_rng(seed)
    box = problem.domain
    return box.lower + rng.random((count, problem.n, 2)) * (box.upper - box.lower)


def test_the_lattice_fit_is_the_fit_at_the_rounded_parameters(problem):
    objective = problem.objective
    fit = objective.lattice
    assert fit is not None and fit.model.rational == problem.model.patch().rational
    uv = swarm(problem)
    rounded = fit.rounded(uv)
    span = np.array(objective.model.span)
    assert (np.abs(rounded - uv).max(axis=(0, 1)) <= 0.5 * span / LATTICE_STEPS * (1 + 1e-9)).all()
    assert np.abs(rounded - uv).max() > 0
    points, poles = fit.points_and_poles(uv)
    exact_points = objective.points(rounded)
    size = np.abs(exact_points).max()
    assert np.abs(points - exact_points).max() <= 1e-12 * size
    assert np.abs(poles - objective.fit(rounded)).max() <= 1e-9 * size


def whole_raster(objective, uv):
    """The expanded deviation's maximum over every node of the substitutes fitted at uv: (P,) mm."""
    poles = objective.fit(uv)
    whole = np.abs(objective.expanded_field(poles)).reshape(len(uv), -1).max(axis=1)
    if objective.nodes.edge_uv.size:
        whole = np.maximum(whole, np.abs(objective.expanded_edges(poles)).max(axis=1))
    return whole


def test_the_swarm_objective_scores_the_rounded_point_sets(problem):
    objective = problem.objective
    uv = swarm(problem)
    assert objective(uv) == pytest.approx(whole_raster(objective, objective.lattice.rounded(uv)), rel=1e-5)


def test_tables_are_the_size_they_are_budgeted_at(problem):
    fit = problem.objective.lattice
    assert fit.u_table.nbytes + fit.v_table.nbytes == LatticeFit.table_bytes(fit.model, fit.space)


def test_a_face_with_too_large_tables_is_fitted_from_its_bases(reference, monkeypatch):
    monkeypatch.setattr(deviation, "LATTICE_LIMIT_BYTES", 1024)
    problem = make_problem(reference, 49, grid=30, workers=1)
    objective = problem.objective
    assert objective.lattice is None
    uv = swarm(problem)
    assert objective(uv) == pytest.approx(whole_raster(objective, uv), rel=1e-5)
    assert objective.spaced(uv, 0.1).shape == (len(uv),)


def test_a_worker_builds_its_own_tables(problem):
    import pickle

    objective = problem.objective
    uv = swarm(problem)
    expected = objective(uv)
    copy = pickle.loads(pickle.dumps(objective))
    assert copy._lattice is None
    assert np.array_equal(copy(uv), expected)


def test_the_reach_bounds_how_far_rounding_moves_a_face_point(problem):
    """The lattice's reach against the largest move of a face point to its rounded parameters,
    over many points; the face's speed bounds against its sampled derivatives."""
    objective = problem.objective
    fit = objective.lattice
    uv = swarm(problem, count=40, seed=5).reshape(-1, 2)
    moved = np.linalg.norm(objective.model.points(uv) - objective.model.points(fit.rounded(uv)), axis=1)
    assert moved.max() <= fit.reach
    speeds = objective.model.derivatives(uv, 1)
    bounds = objective.model.speed_bounds()
    for key, bound in zip(((1, 0), (0, 1)), bounds):
        assert np.linalg.norm(speeds[key], axis=1).max() <= bound * (1 + 1e-12)


def test_the_spacing_decided_from_rounded_points_is_the_exact_one(problem):
    """min_spacing right at each set's closest pair (the rounded points cannot decide that set) and
    beyond every pair by more than the lattice's reach: the swarm's spacing check (rounded points,
    exact ones where they cannot decide) says what the exact points say, and evaluates the face
    anew only for the sets it cannot decide."""
    objective = problem.objective
    uv = swarm(problem, count=12, seed=6)
    objective(uv)
    squared = deviation.closest_squared(objective.points(uv))
    exact = np.sqrt(squared)
    calls = []
    points = objective.points
    objective.points = lambda at: calls.append(len(at)) or points(at)
    try:
        for level in exact:
            calls.clear()
            assert objective.spaced(uv, level).tolist() == (squared >= level ** 2).tolist()
            assert 1 <= sum(calls) < len(uv)
        calls.clear()
        assert not objective.spaced(uv, exact.max() + 3 * objective.lattice.reach).any()
        assert calls == []
    finally:
        del objective.points


def test_a_set_with_two_points_at_one_place_is_not_spaced(problem):
    """Two points at the same parameters: their squared distance, a difference of squares, can
    round below zero; the check says 'not spaced' without a warning."""
    objective = problem.objective
    uv = swarm(problem, count=3, seed=7)
    uv[:, 1] = uv[:, 0]
    objective(uv)
    with np.errstate(all="raise"):
        assert not objective.spaced(uv, 0.01).any()


@pytest.mark.parametrize("weight", [1.0, 0.25])
def test_speed_bounds_hold_for_equal_weights_of_any_value(weight):
    """A polynomial patch whose poles all carry the same weight, 1 or not: its bounds are at least
    its sampled derivatives (equal weights other than 1 once scaled the bound by the weight)."""
    from cmmsampling.geometry.bspline import clamped_uniform_knots
    from cmmsampling.geometry.nurbs import NurbsPatch

    rng = np.random.default_rng(1)
    knots = clamped_uniform_knots(3, 5)
    patch = NurbsPatch((3, 3), 10.0 * rng.normal(size=(5, 5, 3)), np.full((5, 5), weight), knots, knots, (0, 1, 0, 1))
    speeds = patch.derivatives(rng.random((20000, 2)), 1)
    for key, bound in zip(((1, 0), (0, 1)), patch.speed_bounds()):
        assert np.linalg.norm(speeds[key], axis=1).max() <= bound
