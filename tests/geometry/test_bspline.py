"""B-spline bases: the span-polynomial and Cox-de Boor routes against scipy, batch independence."""
import math

import numpy as np
import pytest
from scipy.interpolate import BSpline

from cmmsampling.geometry.bspline import KnotBasis, clamped_uniform_knots

KNOT_VECTORS = {
    "cubic uniform": (clamped_uniform_knots(3, 6), 3),
    "quintic shifted": (clamped_uniform_knots(5, 9, -2.0, 7.0), 5),
    "double interior knot": (np.array([0, 0, 0, 0, 0.1, 0.35, 0.35, 0.7, 1, 1, 1, 1.0]), 3),
    "discontinuous linear": (np.array([0, 0, 1, 2, 2, 3, 3.0]), 1),
    "piecewise constant": (np.array([0, 0.3, 0.7, 1.0]), 0),
    "degree 8, one span": (clamped_uniform_knots(8, 9), 8),
    "degree 21, one span": (clamped_uniform_knots(21, 22), 21),
    "many spans": (clamped_uniform_knots(3, 60), 3),
}


def power_form_tolerance(degree):
    """Rounding bound of a degree-k basis function evaluated from its power form on a span.

    On a span every basis function is a convex combination of the Bernstein polynomials
    C(k, i) s^i (1 - s)^(k - i), s in [0, 1], whose power-form coefficients add up, in absolute
    value, to C(k, i) 2^(k - i). Forming s^p and the (k + 1)-term sum errs by at most
    gamma_2k = 2k u of that sum (Higham, Accuracy and Stability of Numerical Algorithms, 5.1;
    u = eps / 2); the tabulated coefficients and scipy's recursion add a few u more: 2(k + 1) eps
    covers both. Degree 3: 1.6e-14, degree 8: 7.2e-12 (seen: 6.6e-14 with numpy 1.24, 1.15e-13
    with numpy 2.2 and 2.4, whose matrix product sums in another order).
    """
    condition = max(math.comb(degree, i) * 2 ** (degree - i) for i in range(degree + 1))
    return 2 * (degree + 1) * np.finfo(float).eps * condition


@pytest.mark.parametrize("name", KNOT_VECTORS)
def test_basis_values_match_scipy(name):
    """Random parameters and every knot itself (span changes): the power-form route within its
    rounding bound, the recursion (scipy's own algorithm) to 1e-13."""
    t, k = KNOT_VECTORS[name]
    x = np.concatenate([np.random.default_rng(0).uniform(t[k], t[-k - 1], 500), t[k:-k]])
    basis = KnotBasis(t, k)
    ours = basis.values(x)
    expected = BSpline.design_matrix(x, t, k).toarray().T
    assert ours.shape == expected.shape
    assert np.abs(ours - expected).max() < (power_form_tolerance(k) if basis.polynomial else 1e-13)


def test_both_routes_are_exercised():
    """The table route for few spans and low degrees, the recursion for many spans (where the
    table would cost more) and high degrees (where the power basis loses accuracy)."""
    assert KnotBasis(*KNOT_VECTORS["quintic shifted"]).polynomial
    assert KnotBasis(*KNOT_VECTORS["degree 8, one span"]).polynomial
    assert not KnotBasis(*KNOT_VECTORS["many spans"]).polynomial
    assert not KnotBasis(*KNOT_VECTORS["degree 21, one span"]).polynomial


@pytest.mark.parametrize("shape", [(0,), (2, 0), (0, 5)])
def test_no_parameters_give_empty_values(shape):
    basis = KnotBasis(*KNOT_VECTORS["cubic uniform"])
    assert basis.values(np.zeros(shape)).shape == shape[:-1] + (basis.count, shape[-1])


@pytest.mark.parametrize("name", ["cubic uniform", "many spans"])
def test_a_point_sets_values_do_not_depend_on_the_batch(name):
    """Bit for bit: the two-process swarm relies on it."""
    basis = KnotBasis(*KNOT_VECTORS[name])
    x = np.random.default_rng(1).random((9, 25))
    together = basis.values(x)
    assert together.shape == (9, basis.count, 25)
    assert np.array_equal(together[5:], basis.values(x[5:]))
    assert np.array_equal(together[3], basis.values(x[3]))
