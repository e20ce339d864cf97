"""The swarm's screen: a point set that cannot beat its personal best is not scored over the
whole raster, and the swarm decides exactly as if every point set were (issue: a whole real part
in minutes, the paper's run)."""
import numpy as np
import pytest
from support.faces import collapsed_face, holed_face, rational_saddle, strip_face

import cmmsampling
from cmmsampling.runtime.parallel import TwoProcessObjective
from cmmsampling.strategies.pso import SwarmSettings, particle_swarm
from cmmsampling.strategies.sampling import make_problem
from cmmsampling.runtime.threads import blas_threads

FACES = {
    "reference": cmmsampling.reference_face,
    "rational saddle": rational_saddle,
    "holed plate (trimmed)": holed_face,
    "2 mm strip": strip_face,
    "collapsed edge": collapsed_face,
}


@pytest.fixture(scope="module", params=sorted(FACES))
def problem(request):
    return make_problem(FACES[request.param](), 36, grid=30, workers=1)


def random_swarm(problem, rng, population=25):
    """(population, N, 2) random point sets on the face's domain."""
    lower, upper = problem.domain.lower, problem.domain.upper
    return problem.project(lower + rng.random((population, problem.n, 2)) * (upper - lower))


def test_values_to_beat_are_decided_as_by_the_whole_raster(problem):
    """Where a point set beats the value given, its value is the whole raster's, to the bit;
    where it does not, the value returned does not beat it either; the screen learns nodes."""
    objective, rng = problem.objective, np.random.default_rng(4)
    with blas_threads(1):
        for _ in range(6):
            uv = random_swarm(problem, rng)
            whole = objective(uv)
            above = whole * rng.uniform(0.8, 1.2, len(whole))
            screened = objective(uv, above)
            beaten = screened < above
            assert np.array_equal(beaten, whole < above)
            assert np.array_equal(screened[beaten], whole[beaten])
    assert objective._screen.nodes.size > 0


def test_screen_values_are_lower_bounds_within_single_precision(problem):
    """The screen's figure never exceeds the double-precision maximum, and the swarm's
    single-precision maximum lies within the screen's margin of that (the swarm fits at the
    parameters rounded to its lattice: the double-precision fit is made there too)."""
    objective = problem.objective
    uv = random_swarm(problem, np.random.default_rng(5))
    with blas_threads(1):
        poles = objective.fit(objective.lattice.rounded(uv))
        exact = np.abs(objective.expanded_field(poles)).reshape(len(uv), -1).max(axis=1)
        if objective.nodes.edge_uv.size:
            exact = np.maximum(exact, np.abs(objective.expanded_edges(poles)).max(axis=1))
        objective(uv, np.zeros(len(uv)))
        lower = objective._screen.lower(poles)
        single = objective(uv)
    assert np.all(lower <= exact + 1e-12)
    assert np.all(np.abs(single - exact) < objective._screen.slack(exact))


def test_a_swarm_screened_runs_as_one_scored_whole(problem):
    """The same personal bests, the same best and the same history as a swarm whose every
    point set is scored over the whole raster, with far fewer point sets scored whole."""
    objective = problem.objective
    whole_only = lambda uv: objective(uv)  # noqa: E731 (no 'beats': every set scored whole)
    scored = []
    learn = objective._screen.learn
    objective._screen.learn = lambda found: (scored.append(len(found)), learn(found))
    settings = SwarmSettings(population=25, iterations=150, seed=2)
    arguments = (problem.domain.lower, problem.domain.upper, problem.n, settings)
    try:
        with blas_threads(1):
            screened = particle_swarm(objective, *arguments, project=problem.project)
            whole = particle_swarm(whole_only, *arguments, project=problem.project)
    finally:
        objective._screen.learn = learn
    assert np.array_equal(screened.best, whole.best)
    assert np.array_equal(screened.history, whole.history)
    assert sum(scored) < 0.6 * settings.population * settings.iterations


def test_the_worker_is_told_the_values_to_beat():
    problem = make_problem(cmmsampling.reference_face(), 25, grid=30, workers=2)
    objective = TwoProcessObjective(problem.objective)
    assert objective.parallel and objective.beats
    rng = np.random.default_rng(6)
    with blas_threads(1):
        for _ in range(4):
            uv = random_swarm(problem, rng, 10)
            whole = problem.objective(uv)
            above = whole * rng.uniform(0.8, 1.2, len(whole))
            both = objective(uv, above)
            beaten = both < above
            assert np.array_equal(beaten, whole < above)
            assert np.array_equal(both[beaten], whole[beaten])
    assert objective.remote > 0
