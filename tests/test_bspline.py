"""B-spline bases: the span-polynomial and Cox-de Boor routes against scipy, batch independence."""
import numpy as np
import pytest
from scipy.interpolate import BSpline

from cmmsampling.bspline import KnotBasis, clamped_uniform_knots

KNOT_VECTORS = {
    "cubic uniform": (clamped_uniform_knots(3, 6), 3),
    "quintic shifted": (clamped_uniform_knots(5, 9, -2.0, 7.0), 5),
    "double interior knot": (np.array([0, 0, 0, 0, 0.1, 0.35, 0.35, 0.7, 1, 1, 1, 1.0]), 3),
    "discontinuous linear": (np.array([0, 0, 1, 2, 2, 3, 3.0]), 1),
    "many spans": (clamped_uniform_knots(3, 60), 3),
}


@pytest.mark.parametrize("name", KNOT_VECTORS)
def test_basis_values_match_scipy(name):
    """Random parameters and every knot itself (span changes), to 1e-13."""
    t, k = KNOT_VECTORS[name]
    x = np.concatenate([np.random.default_rng(0).uniform(t[k], t[-k - 1], 500), t[k:-k]])
    ours = KnotBasis(t, k).values(x)
    expected = BSpline.design_matrix(x, t, k).toarray().T
    assert ours.shape == expected.shape
    assert np.abs(ours - expected).max() < 1e-13


def test_both_routes_are_exercised():
    """The table route for few spans, the recursion for many (where the table would cost more)."""
    assert KnotBasis(*KNOT_VECTORS["quintic shifted"]).polynomial
    assert not KnotBasis(*KNOT_VECTORS["many spans"]).polynomial


@pytest.mark.parametrize("name", ["cubic uniform", "many spans"])
def test_a_point_sets_values_do_not_depend_on_the_batch(name):
    """Bit for bit: the two-process swarm relies on it."""
    basis = KnotBasis(*KNOT_VECTORS[name])
    x = np.random.default_rng(1).random((9, 25))
    together = basis.values(x)
    assert together.shape == (9, basis.count, 25)
    assert np.array_equal(together[5:], basis.values(x[5:]))
    assert np.array_equal(together[3], basis.values(x[3]))
