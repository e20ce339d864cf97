"""Vectorised B-spline basis functions and tensor-product helpers.

Pure numpy. Knot vectors are full (every knot repeated by its multiplicity), as
``scipy.interpolate.BSpline`` takes them. :class:`KnotBasis` evaluates whole bases from
per-span polynomial tables; the recursions are those of Piegl and Tiller, *The NURBS Book*,
A2.1-A2.3, run over whole arrays of parameters at once.
"""
from __future__ import annotations

import functools

import numpy as np


def full_knots(knots: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """Expand distinct knots and multiplicities into a full knot vector.

    knots: (K,) distinct knot values; mults: (K,) positive integers.
    Returns a (sum(mults),) float array.
    """
    return np.repeat(np.asarray(knots, dtype=float), np.asarray(mults, dtype=int))


def clamped_uniform_knots(degree: int, n_poles: int, start: float = 0.0, end: float = 1.0) -> np.ndarray:
    """Full clamped knot vector with uniformly spaced interior knots.

    degree: polynomial degree k >= 1; n_poles: number of poles n >= k + 1;
    start, end: the parameter interval. Returns (n + k + 1,) floats.
    """
    interior = np.linspace(start, end, n_poles - degree + 1)
    return np.concatenate([np.full(degree, start), interior, np.full(degree, end)])


def find_spans(t: np.ndarray, degree: int, x: np.ndarray) -> np.ndarray:
    """Knot span index of every parameter: t[i] <= x < t[i+1], clamped to the valid range.

    t: (n + k + 1,) full knot vector; x: (N,) parameters. Returns (N,) int array in [k, n - 1],
    so the right end of the domain belongs to the last span.
    """
    n = len(t) - degree - 1
    return degree + np.searchsorted(t[degree + 1:n], x, side="right")


def _basis_table(t: np.ndarray, degree: int, x: np.ndarray, span: np.ndarray) -> np.ndarray:
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


def basis_values(t: np.ndarray, degree: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Non-zero basis values at many parameters (Cox-de Boor, The NURBS Book A2.2).

    t: full knot vector; degree: k; x: (...) parameters.
    Returns (span (...), values (k + 1, ...)); row r of values belongs to basis function span - k + r.
    """
    x = np.asarray(x, dtype=float)
    span = find_spans(t, degree, x)
    offsets = np.arange(1, degree + 1).reshape((-1,) + (1,) * x.ndim)
    left = x - t[span + 1 - offsets]
    right = t[span + offsets] - x
    values = np.ones((1,) + x.shape)
    for j in range(1, degree + 1):
        to_right = right[:j]
        to_left = left[j - 1::-1]
        temp = values / (to_right + to_left)
        values = np.empty((j + 1,) + x.shape)
        values[:j] = to_right * temp
        values[j] = 0.0
        values[1:] += to_left * temp
    return span, values


POLYNOMIAL_TABLE_LIMIT = 2048
POLYNOMIAL_MAX_DEGREE = 8


class KnotBasis:
    """All basis functions of one knot vector, evaluated densely at many parameters at once.

    t: full knot vector of n + k + 1 knots; degree: k. On knot span j the k + 1 non-zero basis
    functions are polynomials of degree k in the local parameter s = (x - t_j) / (t_{j+1} - t_j),
    s in [0, 1]. Their power-basis coefficients are tabulated once, from the exact derivatives at
    the span's left knot (a Taylor expansion). Evaluation is then one matrix product of the
    span-selected powers of s with the table: a few numpy operations whatever the degree. When
    the table has more than POLYNOMIAL_TABLE_LIMIT entries (many spans), the product would cost
    more than the recursion, and the Cox-de Boor recursion runs instead; it also runs above
    degree POLYNOMIAL_MAX_DEGREE, where the power basis loses accuracy (1e-13 at degree 9).
    """

    def __init__(self, t: np.ndarray, degree: int) -> None:
        self.knots = np.asarray(t, dtype=float)
        self.degree = int(degree)
        self.count = len(self.knots) - self.degree - 1
        k, n = self.degree, self.count
        self._spans = n - k
        self._inner = self.knots[k + 1:n]
        self.polynomial = (k <= POLYNOMIAL_MAX_DEGREE
                           and self._spans * (k + 1) * n <= POLYNOMIAL_TABLE_LIMIT)
        if self.polynomial:
            self._left = self.knots[k:n]
            width = self.knots[k + 1:n + 1] - self._left
            self._inverse_width = np.divide(1.0, width, out=np.zeros_like(width), where=width > 0)
            self._table = _span_polynomials(self.knots, k, width)

    def values(self, x: np.ndarray) -> np.ndarray:
        """Dense basis values, basis index before the points: x (..., N) -> (..., n, N).

        Entry [..., j, m] is N_j(x[..., m]); a single parameter (0-d x) gives (n, 1). Each leading index is one matrix product of the same
        shape, so a point set's values do not depend on how many sets are evaluated with it.
        """
        x = np.asarray(x, dtype=float)
        flat = x.reshape(int(np.prod(x.shape[:-1])), x.shape[-1]) if x.ndim else x.reshape(1, 1)
        if self.polynomial:
            dense = np.matmul(self._table, self._selected_powers(flat))
        else:
            dense = dense_from_local(*basis_values(self.knots, self.degree, flat), self.degree, self.count)
        return dense.reshape(x.shape[:-1] + (self.count, flat.shape[-1]))

    def _selected_powers(self, x: np.ndarray) -> np.ndarray:
        """Powers s^0..s^k of the local parameter, placed in the rows of each point's span.

        x: (B, N) -> (B, spans * (k + 1), N), zero outside the point's span.
        """
        span = np.searchsorted(self._inner, x, side="right")
        local = (x - self._left[span]) * self._inverse_width[span]
        order = self.degree + 1
        powers = np.empty((x.shape[0], order, x.shape[1]))
        powers[:, 0] = 1.0
        if order > 1:
            powers[:, 1] = local
        for p in range(2, order):
            np.multiply(powers[:, p - 1], local, out=powers[:, p])
        return _scatter_rows(powers, span * order, self._spans * order)


def _scatter_rows(values: np.ndarray, first_row: np.ndarray, rows: int) -> np.ndarray:
    """Zero array (B, rows, N) with values: (B, r, N) in rows first_row (B, N) .. first_row + r - 1."""
    batch, count, n = values.shape
    out = np.zeros((batch, rows, n))
    flat = _scatter_offsets(batch, count, n, rows) + (first_row * n)[:, None, :]
    out.ravel()[flat.ravel()] = values.ravel()
    return out


@functools.lru_cache(maxsize=16)
def _scatter_offsets(batch: int, count: int, n: int, rows: int) -> np.ndarray:
    """Flat offsets (B, r, N) of rows 0..r-1 of every point in a (B, rows, N) array."""
    return (np.arange(batch) * rows * n)[:, None, None] + (n * np.arange(count))[:, None] + np.arange(n)


def _span_polynomials(t: np.ndarray, degree: int, width: np.ndarray) -> np.ndarray:
    """(n, spans * (k + 1)) power-basis coefficients of every basis function on every span.

    Column j * (k + 1) + p holds the coefficient of s^p on span k + j, s the local parameter
    scaled to [0, 1] by the span's width; width: (n - k,) widths of spans k..n-1 (zero-width
    spans, never selected, are left 0).
    """
    k = degree
    n = len(t) - k - 1
    spans = np.flatnonzero(width > 0)
    table = np.zeros((n, n - k, k + 1))
    span, ders = basis_derivatives(t, k, t[k + spans], k)
    scale = width[spans] ** np.arange(k + 1)[:, None] / np.cumprod([1.0] + list(range(1, k + 1)))[:, None]
    for r in range(k + 1):
        table[span - k + r, spans] = (ders[:, r] * scale).T
    return table.reshape(n, -1)


def dense_from_local(span: np.ndarray, values: np.ndarray, degree: int, n: int) -> np.ndarray:
    """Dense basis values from local ones: values (k + 1, B, N) at span (B, N) -> (B, n, N)."""
    return _scatter_rows(np.moveaxis(values, 0, 1), span - degree, n)


def greville_abscissae(t: np.ndarray, degree: int) -> np.ndarray:
    """Greville abscissae of a full knot vector: the mean of each pole's k interior knots, (n,)."""
    t = np.asarray(t, dtype=float)
    count = len(t) - degree - 1
    return np.array([t[i + 1:i + degree + 1].mean() for i in range(count)])


def kron_rows(along_u: np.ndarray, along_v: np.ndarray) -> np.ndarray:
    """Row-wise Kronecker products of dense bases: (N, n_u), (N, n_v) -> (N, n_u * n_v)."""
    return (along_u[:, :, None] * along_v[:, None, :]).reshape(along_u.shape[0], -1)


def _derivatives_from_table(ndu: np.ndarray, degree: int, n_derivatives: int) -> np.ndarray:
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
    factor = float(k)
    for d in range(1, n_derivatives + 1):
        ders[d] *= factor
        factor *= k - d
    return ders


def basis_derivatives(t: np.ndarray, degree: int, x: np.ndarray,
                      n_derivatives: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Non-zero basis functions and their derivatives at many parameters.

    t: full knot vector; degree: k; x: (N,) parameters inside [t[k], t[-k-1]];
    n_derivatives: highest derivative order wanted.
    Returns (span, ders): span (N,) ints, ders (n_derivatives + 1, k + 1, N) where
    ders[d, r, i] is the d-th derivative of basis function span[i] - k + r at x[i].
    """
    x = np.asarray(x, dtype=float).ravel()
    if n_derivatives == 0:
        span, values = basis_values(t, degree, x)
        return span, values[None]
    span = find_spans(t, degree, x)
    return span, _derivatives_from_table(_basis_table(t, degree, x, span), degree, n_derivatives)


def design_matrices(t: np.ndarray, degree: int, x: np.ndarray, n_derivatives: int = 0) -> np.ndarray:
    """Dense collocation matrices of all basis functions and their derivatives.

    t: full knot vector of n + k + 1 knots; x: (N,) parameters.
    Returns (n_derivatives + 1, N, n): entry [d, i, j] is the d-th derivative of basis j at x[i].
    """
    x = np.asarray(x, dtype=float).ravel()
    span, ders = basis_derivatives(t, degree, x, n_derivatives)
    n = len(t) - degree - 1
    return np.stack([dense_from_local(span[None], d[:, None], degree, n)[0].T for d in ders])


def second_difference_matrix(n: int) -> np.ndarray:
    """(n - 2, n) matrix of second differences c[i] - 2 c[i+1] + c[i+2] of a pole row."""
    d = np.zeros((max(n - 2, 0), n))
    idx = np.arange(n - 2)
    d[idx, idx] = 1.0
    d[idx, idx + 1] = -2.0
    d[idx, idx + 2] = 1.0
    return d


def radical_inverse(indices: np.ndarray, base: int) -> np.ndarray:
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
