"""The certified lower bound and the near-optimal strategy (issue: beyond the paper)."""
import numpy as np
import pytest

import cmmsampling
from cmmsampling import strategies
from cmmsampling.bound import minimax_bound
from cmmsampling.optimal import surrogate
from cmmsampling.sampling import make_problem
from cmmsampling.surface import make_bspline_surface


@pytest.fixture(scope="module")
def small():
    """The reference face, N = 25 (4 x 4 bicubic), a 30 x 30 grid."""
    return make_problem(cmmsampling.reference_face(), 25, grid=30)


def test_bound_is_below_the_maximum_of_any_surface_of_the_space(small):
    bound = minimax_bound(small.space, small.grid)
    assert 0 < bound.lower <= bound.upper
    rng = np.random.default_rng(0)
    fitted = small.objective.fit(rng.random((40, 25, 2)))
    maxima = np.sqrt(small.objective.squared_field(fitted).reshape(40, -1).max(axis=1))
    assert maxima.min() >= bound.lower
    near = fitted[0] + 1e-3 * rng.standard_normal(fitted[0].shape)
    assert small.objective.grid_error(near)[1].max() >= bound.lower


@pytest.mark.parametrize("strategy", sorted(cmmsampling.STRATEGIES))
def test_no_strategy_beats_the_bound(strategy):
    options = {"pso": {"iterations": 30, "population": 10}, "optimal": {"max_evaluations": 300}}
    result = cmmsampling.sample(cmmsampling.reference_face(), 25, strategy, grid=30, occ_check=False,
                                **options.get(strategy, {}))
    assert result.deviation.maximum >= result.bounds()["grid"].lower
    assert result.check.maximum >= result.bounds()["check"].lower
    assert result.multiple_of_bound() >= 1.0 and result.multiple_of_bound(check=True) >= 1.0


def test_bound_is_zero_when_the_face_lies_in_the_fit_space():
    x, y = np.meshgrid(np.linspace(0, 60, 6), np.linspace(0, 40, 6), indexing="ij")
    z = np.random.default_rng(3).normal(0, 4, x.shape)
    face = make_bspline_surface(np.stack([x, y, z], -1), (3, 3)).toShape()
    bound = cmmsampling.lower_bound(face, 81, grid=40)
    assert bound.upper < 1e-9 and bound.lower < 1e-9


def test_bound_converges_on_the_reference_surface():
    bound = cmmsampling.lower_bound(cmmsampling.reference_face(), 81)
    assert bound.converged and bound.gap <= 1e-4
    assert bound.lower == pytest.approx(0.7618, abs=2e-4)


@pytest.mark.parametrize("spacing", [0.0, 4.0])
def test_surrogate_gradient_matches_finite_differences(small, spacing):
    uv0 = strategies.uniform_parametric(small).uv
    uv = np.clip(uv0 + 0.03 * np.random.default_rng(1).standard_normal(uv0.shape), 0, 1)
    tau, penalty, h = 15.0, 0.5, 1e-6
    exact = surrogate(small.objective, uv, tau, spacing, penalty).gradient
    for i in (0, 7, 18, 24):
        for k in range(2):
            step = np.zeros_like(uv)
            step[i, k] = h
            plus = surrogate(small.objective, uv + step, tau, spacing, penalty).value
            minus = surrogate(small.objective, uv - step, tau, spacing, penalty).value
            assert (plus - minus) / (2 * h) == pytest.approx(exact[i, k], rel=1e-5, abs=1e-7)


def test_surrogate_tends_to_the_true_maximum(small):
    uv = strategies.halton(small).uv
    coarse = surrogate(small.objective, uv, 1.0)
    sharp = surrogate(small.objective, uv, 1e4)
    assert sharp.value >= sharp.maximum >= sharp.value - np.log(900) / 1e4
    assert coarse.value > sharp.value


def test_optimal_reaches_the_bound_on_the_reference_surface():
    """N = 81, default fit and grid: within 1.02x of the certified bound on the 3x check grid."""
    result = cmmsampling.sample(cmmsampling.reference_face(), 81, "optimal")
    assert result.multiple_of_bound(check=True) <= 1.02
    pso_like = cmmsampling.sample(cmmsampling.reference_face(), 81, "uniform_cartesian")
    assert result.deviation.maximum < pso_like.deviation.maximum
    spacing = result.settings["min_spacing"]
    gaps = np.linalg.norm(result.points[:, None] - result.points[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    assert gaps.min() >= spacing - 1e-9
    assert np.all(np.diff(result.history) <= 0)


def test_optimal_honours_min_spacing_and_budget(reference):
    result = cmmsampling.sample(reference, 25, "optimal", grid=30, min_spacing=12.0, max_evaluations=150,
                                occ_check=False)
    gaps = np.linalg.norm(result.points[:, None] - result.points[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    assert gaps.min() >= 12.0 and result.evaluations == 150


def test_optimal_starts_from_a_given_layout_and_never_ends_worse(reference):
    start = cmmsampling.sample(reference, 25, "hammersley", grid=30, occ_check=False)
    result = cmmsampling.sample(reference, 25, "optimal", grid=30, start=start.uv, max_evaluations=100,
                                min_spacing=0.0, occ_check=False)
    assert result.deviation.maximum <= start.deviation.maximum
    named = cmmsampling.sample(reference, 25, "optimal", grid=30, start="hammersley", max_evaluations=100,
                               min_spacing=0.0, occ_check=False)
    assert named.deviation.maximum == pytest.approx(result.deviation.maximum)


def test_optimal_can_be_cancelled(reference):
    calls = []
    result = cmmsampling.sample(reference, 25, "optimal", grid=30, occ_check=False,
                                progress=lambda k, best: calls.append(best) or k >= 20)
    assert result.cancelled and len(calls) == 20
    assert result.deviation.maximum == pytest.approx(calls[-1])


@pytest.mark.parametrize("options, message", [
    ({"min_spacing": -1.0}, "min_spacing must be at least 0"),
    ({"time_limit": 0}, "time_limit must be greater than 0"),
    ({"start": "optimal"}, "unknown start 'optimal'"),
    ({"start": np.zeros((3, 2))}, "expected 25 \\(u, v\\) pairs, got 3"),
])
def test_optimal_bad_options(reference, options, message):
    with pytest.raises((ValueError, TypeError), match=message):
        cmmsampling.sample(reference, 25, "optimal", grid=30, **options)
