"""Vectorised B-spline basis functions (Cox-de Boor) and tensor-product helpers.

Pure numpy. Knot vectors are full (every knot repeated by its multiplicity), as
``scipy.interpolate.BSpline`` takes them. The algorithms are those of Piegl and
Tiller, *The NURBS Book*, A2.1-A2.3, run over whole arrays of parameters at once.
"""
import numpy as np


def full_knots(knots, mults):
    """Expand distinct knots and multiplicities into a full knot vector.

    knots: (K,) distinct knot values; mults: (K,) positive integers.
    Returns a (sum(mults),) float array.
    """
    return np.repeat(np.asarray(knots, dtype=float), np.asarray(mults, dtype=int))


def clamped_uniform_knots(degree, n_poles, start=0.0, end=1.0):
    """Full clamped knot vector with uniformly spaced interior knots.

    degree: polynomial degree k >= 1; n_poles: number of poles n >= k + 1;
    start, end: the parameter interval. Returns (n + k + 1,) floats.
    """
    interior = np.linspace(start, end, n_poles - degree + 1)
    return np.concatenate([np.full(degree, start), interior, np.full(degree, end)])


def find_spans(t, degree, x):
    """Knot span index of every parameter: t[i] <= x < t[i+1], clamped to the valid range.

    t: (n + k + 1,) full knot vector; x: (N,) parameters. Returns (N,) int array in [k, n - 1],
    so the right end of the domain belongs to the last span.
    """
    n = len(t) - degree - 1
    return np.clip(np.searchsorted(t, x, side="right") - 1, degree, n - 1)


def _basis_table(t, degree, x, span):
    """The triangular table of The NURBS Book A2.3: basis values and knot differences.

    Returns ndu: (k + 1, k + 1, N); ndu[:, k] holds the k + 1 non-zero basis values,
    the strictly lower triangle holds knot differences used for derivatives.
    """
    k = degree
    count = x.shape[0]
    left = np.empty((k + 1, count))
    right = np.empty((k + 1, count))
    ndu = np.empty((k + 1, k + 1, count))
    ndu[0, 0] = 1.0
    for j in range(1, k + 1):
        left[j] = x - t[span + 1 - j]
        right[j] = t[span + j] - x
        saved = np.zeros(count)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    return ndu


def _derivatives_from_table(ndu, degree, n_derivatives):
    """Derivatives of the non-zero basis functions from the A2.3 table.

    Returns (n_derivatives + 1, k + 1, N): entry [d, r] is the d-th derivative of basis span - k + r.
    """
    k = degree
    count = ndu.shape[2]
    ders = np.zeros((n_derivatives + 1, k + 1, count))
    ders[0] = ndu[:, k]
    for r in range(k + 1):
        a_prev = np.zeros((n_derivatives + 1, count))
        a_prev[0] = 1.0
        for d in range(1, min(n_derivatives, k) + 1):
            a_next = np.zeros((n_derivatives + 1, count))
            rk, pk = r - d, k - d
            total = np.zeros(count)
            if r >= d:
                a_next[0] = a_prev[0] / ndu[pk + 1, rk]
                total += a_next[0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = d - 1 if r - 1 <= pk else k - r
            for j in range(j1, j2 + 1):
                a_next[j] = (a_prev[j] - a_prev[j - 1]) / ndu[pk + 1, rk + j]
                total += a_next[j] * ndu[rk + j, pk]
            if r <= pk:
                a_next[d] = -a_prev[d - 1] / ndu[pk + 1, r]
                total += a_next[d] * ndu[r, pk]
            ders[d, r] = total
            a_prev = a_next
    factor = k
    for d in range(1, n_derivatives + 1):
        ders[d] *= factor
        factor *= k - d
    return ders


def basis_derivatives(t, degree, x, n_derivatives=0):
    """Non-zero basis functions and their derivatives at many parameters.

    t: full knot vector; degree: k; x: (N,) parameters inside [t[k], t[-k-1]];
    n_derivatives: highest derivative order wanted.
    Returns (span, ders): span (N,) ints, ders (n_derivatives + 1, k + 1, N) where
    ders[d, r, i] is the d-th derivative of basis function span[i] - k + r at x[i].
    """
    x = np.asarray(x, dtype=float).ravel()
    span = find_spans(t, degree, x)
    ndu = _basis_table(t, degree, x, span)
    if n_derivatives == 0:
        return span, ndu[:, degree][None]
    return span, _derivatives_from_table(ndu, degree, n_derivatives)


def design_matrices(t, degree, x, n_derivatives=0):
    """Dense collocation matrices of all basis functions and their derivatives.

    t: full knot vector of n + k + 1 knots; x: (N,) parameters.
    Returns (n_derivatives + 1, N, n): entry [d, i, j] is the d-th derivative of basis j at x[i].
    """
    x = np.asarray(x, dtype=float).ravel()
    n = len(t) - degree - 1
    span, ders = basis_derivatives(t, degree, x, n_derivatives)
    out = np.zeros((n_derivatives + 1, x.shape[0], n))
    rows = np.arange(x.shape[0])[:, None]
    cols = span[:, None] - degree + np.arange(degree + 1)
    for d in range(n_derivatives + 1):
        out[d, rows, cols] = ders[d].T
    return out


def second_difference_matrix(n):
    """(n - 2, n) matrix of second differences c[i] - 2 c[i+1] + c[i+2] of a pole row."""
    d = np.zeros((max(n - 2, 0), n))
    idx = np.arange(n - 2)
    d[idx, idx] = 1.0
    d[idx, idx + 1] = -2.0
    d[idx, idx + 2] = 1.0
    return d


def radical_inverse(indices, base):
    """Van der Corput radical inverse of non-negative integers in a prime base.

    indices: (N,) ints. Returns (N,) floats in [0, 1).
    """
    i = np.asarray(indices, dtype=np.int64).copy()
    result = np.zeros(i.shape, dtype=float)
    scale = 1.0 / base
    while np.any(i > 0):
        result += (i % base) * scale
        i //= base
        scale /= base
    return result
