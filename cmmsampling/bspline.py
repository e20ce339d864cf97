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


def basis_values_many(channels):
    """Non-zero basis values of several knot vectors at once, in one Cox-de Boor pass.

    channels: list of (t, k, x): full knot vector t, degree k and parameters x: (N_c,).
    Each degree step runs once for all basis indices r and all channels not yet at their degree,
    so the Python work does not grow with the number of channels.
    Returns a list of (span (N_c,), values (k + 1, N_c)) in the order of channels; row r of values
    belongs to basis function span - k + r.
    """
    order = sorted(range(len(channels)), key=lambda c: -channels[c][1])
    spans, knots, xs, shifted = {}, [], [], []
    shift = 0
    for c in order:
        t, k, x = channels[c]
        x = np.asarray(x, dtype=float).ravel()
        spans[c] = find_spans(t, k, x)
        knots.append(t)
        xs.append(x)
        shifted.append(spans[c] + shift)
        shift += len(t)
    knots, x, span = np.concatenate(knots), np.concatenate(xs), np.concatenate(shifted)
    ends = np.cumsum([len(v) for v in xs])
    starts = ends - [len(v) for v in xs]
    degrees = [channels[c][1] for c in order]
    offsets = np.arange(1, degrees[0] + 1)[:, None]
    left = x - knots[np.clip(span + 1 - offsets, 0, len(knots) - 1)]
    right = knots[np.clip(span + offsets, 0, len(knots) - 1)] - x
    values = np.ones((1, x.shape[0]))
    results = {}
    for j in range(1, degrees[0] + 2):
        for i, k in enumerate(degrees):
            if k == j - 1:
                results[order[i]] = values[:, starts[i]:ends[i]]
        if j > degrees[0]:
            break
        active = ends[sum(k >= j for k in degrees) - 1]
        to_right = right[:j, :active]
        to_left = left[j - 1::-1, :active]
        temp = values[:, :active] / (to_right + to_left)
        values = np.empty((j + 1, active))
        values[:j] = to_right * temp
        values[j] = 0.0
        values[1:] += to_left * temp
    return [(spans[c], results[c]) for c in range(len(channels))]


def dense_from_local(span, values, degree, n):
    """Dense (N, n) collocation matrix from local values: (k + 1, N) at span: (N,)."""
    count = span.shape[0]
    out = np.zeros((count, n))
    flat = (np.arange(count) * n + span - degree)[None, :] + np.arange(degree + 1)[:, None]
    out.ravel()[flat.ravel()] = values.ravel()
    return out


def kron_rows(along_u, along_v):
    """Row-wise Kronecker products of dense bases: (N, n_u), (N, n_v) -> (N, n_u * n_v)."""
    return (along_u[:, :, None] * along_v[:, None, :]).reshape(along_u.shape[0], -1)


def tensor_rows_from_local(local_u, local_v, degrees, poles):
    """Rows kron(N(u_i), N(v_i)): (N, n_u * n_v) from local values along u and v.

    local_u, local_v: (span, values) pairs as :func:`basis_values_many` returns them;
    degrees: (k_u, k_v); poles: (n_u, n_v). Column a * n_v + b belongs to basis pair (a, b).
    """
    (span_u, along_u), (span_v, along_v) = local_u, local_v
    (ku, kv), (n_u, n_v) = degrees, poles
    count = span_u.shape[0]
    products = along_u[:, None, :] * along_v[None, :, :]
    first = np.arange(count) * (n_u * n_v) + (span_u - ku) * n_v + span_v - kv
    offsets = (np.arange(ku + 1)[:, None] * n_v + np.arange(kv + 1)[None, :])[:, :, None]
    rows = np.zeros((count, n_u * n_v))
    rows.ravel()[(first + offsets).ravel()] = products.ravel()
    return rows


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
    if n_derivatives == 0:
        span, values = basis_values_many([(t, degree, x)])[0]
        return span, values[None]
    span = find_spans(t, degree, x)
    return span, _derivatives_from_table(_basis_table(t, degree, x, span), degree, n_derivatives)


def design_matrices(t, degree, x, n_derivatives=0):
    """Dense collocation matrices of all basis functions and their derivatives.

    t: full knot vector of n + k + 1 knots; x: (N,) parameters.
    Returns (n_derivatives + 1, N, n): entry [d, i, j] is the d-th derivative of basis j at x[i].
    """
    x = np.asarray(x, dtype=float).ravel()
    span, ders = basis_derivatives(t, degree, x, n_derivatives)
    return np.stack([dense_from_local(span, d, degree, len(t) - degree - 1) for d in ders])


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
