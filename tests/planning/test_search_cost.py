"""What a tolerance search builds once per face, and the local bound worked out only as far as
its decision needs (issue: a whole real part in minutes)."""
import math

import numpy as np
import pytest
from support.faces import FreeCAD, holed_face, rational_patch_face, rational_saddle

import cmmsampling
from cmmsampling.fitting.bound import minimax_bound, minimax_bracket
from cmmsampling.strategies import blind, face_setup
from cmmsampling.strategies.face_setup import reused, setup_of
from cmmsampling.strategies.sampling import make_problem

FAST = {"grid": 20}


def test_a_search_builds_the_face_domain_once(monkeypatch):
    """The probe edge offset and every N of the search share one domain (the trim raster and
    the edge distances); the answer is what a run built afresh gives."""
    built = []
    real = face_setup.face_domain
    monkeypatch.setattr(face_setup, "face_domain", lambda *args: built.append(args[1]) or real(*args))
    face = holed_face()
    answer = cmmsampling.points_needed(face, 0.02, "uniform_parametric", n_max=150, **FAST)
    assert len(answer.tried) >= 3 and built == [1.5]
    again = cmmsampling.sample(face, answer.n, "uniform_parametric", edge_offset=1.5, **FAST)
    np.testing.assert_array_equal(again.uv, answer.result.uv)
    assert again.deviation.maximum == answer.maximum
    assert len(built) == 2


def test_outside_a_block_a_changed_face_is_built_anew():
    """A face moved between two runs is never served from the first run's build."""
    face = holed_face()
    uv = np.array([[0.5, 0.5]])
    before = make_problem(face, 16, edge_offset=1.0).model.points(uv)
    face.translate(FreeCAD.Vector(0, 0, 5))
    after = make_problem(face, 16, edge_offset=1.0).model.points(uv)
    np.testing.assert_allclose(after - before, [[0, 0, 5]], atol=1e-9)


def test_a_block_hands_out_one_setup_per_face_object():
    first, second = holed_face(), rational_saddle()
    with reused():
        held = setup_of(first)
        with reused():
            assert setup_of(first) is held
        assert setup_of(second) is not held and setup_of(first) is held
        assert held.domain(1.0) is held.domain(1.0) and held.domain(1.0) is not held.domain(2.0)
    assert setup_of(first) is not held


@pytest.mark.parametrize("make_face", [rational_patch_face, rational_saddle, holed_face])
def test_the_bracket_holds_the_bound(make_face):
    """Reweighted least squares bracket the linear programme's optimum, within a few per cent."""
    face = make_face()
    for n in (16, 46, 96):
        problem = make_problem(face, n, grid=30, edge_offset=1.0)
        exact = problem.exact(blind.uniform_parametric(problem).uv)
        bound = minimax_bound(problem.space, exact, problem.grid.size)
        lower, upper = minimax_bracket(problem.space, exact)
        assert bound.converged
        assert 0.9 * bound.lower < lower <= bound.lower * (1 + 1e-7) + 1e-12
        assert bound.lower * (1 - 1e-7) <= upper < 1.3 * bound.lower


@pytest.mark.parametrize("n", [16, 46])
def test_the_search_decision_is_the_bound_s(n):
    """bound_exceeds answers as the whole bound does at levels around it; it gives the bound
    where it had to compute it, NaN where the bracket told (well away from the bound, as a
    search's tolerance mostly is)."""
    face = rational_patch_face()
    bound = cmmsampling.sample(face, n, "uniform_parametric", occ_check=False, **FAST).bounds()["grid"].lower
    for level in (0.2 * bound, 0.999 * bound, 1.001 * bound, 5 * bound):
        result = cmmsampling.sample(face, n, "uniform_parametric", occ_check=False, **FAST)
        exceeds, figure = result.bound_exceeds(level)
        assert exceeds == (bound > level)
        if level in (0.2 * bound, 5 * bound):
            assert math.isnan(figure)
        else:
            assert math.isnan(figure) or figure == pytest.approx(bound, rel=1e-9)


def test_the_deviation_judged_once_serves_the_bound_too():
    problem = make_problem(rational_saddle(), 25, grid=20)
    poles = problem.objective.fit(blind.uniform_parametric(problem).uv[None])[0]
    first = problem.judge(poles)
    assert problem.judge(poles.copy()) is first
    assert problem.judge(poles + 0.01) is not first and problem.judge(poles, check=True) is not first
