"""Substitute geometry: batched least-squares B-spline fits to points at known (u, v).

The substitute surface is a tensor-product B-spline of degree (k_u, k_v) with (n_u, n_v) poles and
clamped uniform knots over the face's parameter range. For measured points Q_i at (u_i, v_i) its
poles C solve the normal equations

    (B^T B + lam R) C = B^T Q,      B[i] = kron(N(u_i), N(v_i)),

where R is the sum of squared second differences of the pole net along u and along v plus a much
smaller ridge, so the fit is unique for every point set (clustered ones included). lam is
``smoothing`` times N / (n_u n_v): the data term per pole, so the weight of the smoothing does not
depend on N. Many point sets are fitted in one call.

The normal matrix is banded (poles more than a degree apart along both directions never meet),
so the normal equations of a whole batch are solved as one block-diagonal banded system by one
LAPACK call (Cholesky, ``?pbsv``). Up to BANDED_LIMIT sub-diagonals LAPACK factors the band
column by column, so each point set's poles come out the same whatever else is in its batch;
wider bands are solved densely, one LU factorisation per point set.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.linalg import lapack

from ..geometry.bspline import KnotBasis, clamped_uniform_knots, design_matrices, kron_rows, second_difference_matrix

DEFAULT_DEGREE = 3
DEFAULT_SMOOTHING = 1e-8
RIDGE = 1e-6
# LAPACK's ?pbtrf factors bands up to 64 sub-diagonals unblocked (its ILAENV block size is 1
# there), column by column: the poles of each point set of a batch do not depend on the others.
BANDED_LIMIT = 64
# Each set's banded system is padded to a multiple of this many unknowns (32 bytes), so that
# every set's columns have the same alignment in any batch (OpenBLAS's dot kernels sum in an
# order that depends on the alignment of their vectors).
BLOCK_ALIGNMENT = 4


def default_pole_count(n_points: int, degree: int = DEFAULT_DEGREE) -> int:
    """Poles per direction for N points: round(2 sqrt(N) / 3), at least degree + 1.

    About 2.25 points per pole: 6 x 6 for N = 81, 5 x 5 for 49, 8 x 8 for 144, 4 x 4 for 25.
    """
    return max(degree + 1, int(round(2.0 * np.sqrt(n_points) / 3.0)))


class SubstituteSpace:
    """The space the substitute surface lives in, with its smoothing matrix.

    degrees: (k_u, k_v); poles: (n_u, n_v); bounds: (u0, u1, v0, v1) of the face.
    """

    def __init__(self, degrees: Sequence[int], poles: Sequence[int], bounds: Sequence[float],
                 smoothing: float = DEFAULT_SMOOTHING) -> None:
        self.degrees = tuple(int(d) for d in degrees)
        self.poles = tuple(int(p) for p in poles)
        self.bounds = tuple(float(b) for b in bounds)
        self.smoothing = float(smoothing)
        u0, u1, v0, v1 = self.bounds
        self.uknots = clamped_uniform_knots(self.degrees[0], self.poles[0], u0, u1)
        self.vknots = clamped_uniform_knots(self.degrees[1], self.poles[1], v0, v1)
        self.regulariser = _regulariser(self.poles)
        self.u_basis = KnotBasis(self.uknots, self.degrees[0])
        self.v_basis = KnotBasis(self.vknots, self.degrees[1])
        self._gram_index = _gram_index(self.poles, self.degrees)
        pad = _pair_count(self.poles[0], self.degrees[0]) * _pair_count(self.poles[1], self.degrees[1])
        self.bandwidth = _bandwidth(self._gram_index != pad, self.regulariser)
        self._block = -(-self.size // BLOCK_ALIGNMENT) * BLOCK_ALIGNMENT
        self._tail = -(-self.bandwidth // BLOCK_ALIGNMENT) * BLOCK_ALIGNMENT
        self._band_index = _padded_lower_band(self._gram_index, self.bandwidth, self._block, pad, pad + 1)
        self._band_regulariser = _padded_lower_band(self.regulariser, self.bandwidth, self._block, 0.0, 0.0)

    @property
    def size(self) -> int:
        """Number of poles n_u * n_v."""
        return self.poles[0] * self.poles[1]

    def bases(self, uv: np.ndarray, n_derivatives: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Basis matrices along u and v at uv: (..., 2).

        Returns (bu, bv): (n_derivatives + 1, M, n_u) and (n_derivatives + 1, M, n_v), M = uv.size / 2.
        """
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        return (design_matrices(self.uknots, self.degrees[0], uv[:, 0], n_derivatives),
                design_matrices(self.vknots, self.degrees[1], uv[:, 1], n_derivatives))

    def normal_matrix(self, along_u: np.ndarray, along_v: np.ndarray) -> np.ndarray:
        """B^T B + lam R from the bases along u and v: (..., n_u, N), (..., n_v, N) -> (..., M, M).

        B's row for point i is kron(N(u_i), N(v_i)), so (B^T B)[(a, b), (c, d)] is the sum over the
        points of N_a N_c (u) times N_b N_d (v). Products of basis functions more than a degree
        apart vanish, so only the band pairs (a, c) and (b, d) are formed, and one matrix
        product of the two pair-product arrays gives every non-zero entry.
        """
        return self.gram_from_pairs(self.pair_products(along_u, along_v),
                                    self.smoothing * along_u.shape[-1] / self.size)

    def pair_products(self, along_u: np.ndarray, along_v: np.ndarray) -> np.ndarray:
        """The pair-product matrix of :meth:`gram_from_pairs` from the bases along u and v,
        (..., n_u, N) and (..., n_v, N) -> (..., L_u, L_v)."""
        return np.matmul(band_products(along_u, self.degrees[0]),
                         np.swapaxes(band_products(along_v, self.degrees[1]), -1, -2))

    def gram_from_pairs(self, pairs: np.ndarray, weight: float) -> np.ndarray:
        """B^T B + weight R from the pair-product matrix: pairs (..., L_u, L_v), entry [row(a, c),
        row(b, d)] the sum over the points of N_a N_c (u) N_b N_d (v) (rows as in
        :func:`band_products`); weight: the smoothing's weight lam. Returns (..., M, M)."""
        flat = pairs.reshape(pairs.shape[:-2] + (-1,))
        padded = np.concatenate([flat, np.zeros(flat.shape[:-1] + (1,))], axis=-1)
        gram = np.take(padded, self._gram_index, axis=-1)
        gram += weight * self.regulariser
        return gram

    def solve_normal(self, pairs: np.ndarray, weight: float, rhs: np.ndarray) -> np.ndarray:
        """Poles from the normal equations of point sets: pairs (..., L_u, L_v) as in
        :meth:`gram_from_pairs`, weight the smoothing's lam, rhs B^T Q (..., M, 3) mm.

        Returns (..., M, 3) mm. Up to BANDED_LIMIT sub-diagonals the batch is one block-diagonal
        banded system (see :meth:`padded_band`; a point set whose block LAPACK finds not positive
        definite in rounding is solved by LU instead); wider bands are solved densely per point set.
        """
        if self.bandwidth > BANDED_LIMIT:
            return np.linalg.solve(self.gram_from_pairs(pairs, weight), rhs)
        pairs = pairs.reshape((-1,) + pairs.shape[-2:])
        sets, block = pairs.shape[0], self._block
        flat_rhs = rhs.reshape((sets,) + rhs.shape[-2:])
        padded_rhs = np.zeros((rhs.shape[-1], sets * block + self._tail))
        padded_rhs[:, :sets * block].reshape(-1, sets, block)[:, :, :self.size] = np.moveaxis(flat_rhs, -1, 0)
        poles = _banded_cholesky_solve(self.padded_band(pairs, weight), padded_rhs.T, sets, block,
                                       lambda index: self.gram_from_pairs(pairs[index], weight))
        poles = poles[:sets * block].T.reshape(-1, sets, block)[:, :, :self.size]
        return np.moveaxis(poles, 0, -1).reshape(rhs.shape)

    def padded_band(self, pairs: np.ndarray, weight: float) -> np.ndarray:
        """The lower band of the batch's block-diagonal B^T B + weight R from pairs (P, L_u, L_v):
        (P * block + tail, bandwidth + 1), row j the entries [j + d, j], d = 0..bandwidth.

        Set p's system takes rows p * block to p * block + M; its entries [j + d, j] below the
        system are zero (the sets do not meet). Its rows from M up to ``block`` (a multiple of
        BLOCK_ALIGNMENT) and the ``tail`` rows after the last set (the bandwidth, rounded up so
        that the whole system's length, the stride between the columns of its right-hand sides,
        is a multiple of BLOCK_ALIGNMENT too) are an identity. So every set's columns have the
        same alignment and run their LAPACK dot products and updates over the full band, whatever
        the set's place in the batch: each set's poles come out bit for bit the same in any batch.
        """
        flat = pairs.reshape(pairs.shape[0], -1)
        padded = np.concatenate([flat, np.broadcast_to([0.0, 1.0], (flat.shape[0], 2))], axis=-1)
        band = np.empty((pairs.shape[0] * self._block + self._tail, self.bandwidth + 1))
        sets = band[:pairs.shape[0] * self._block].reshape((pairs.shape[0],) + self._band_index.shape)
        np.take(padded, self._band_index, axis=-1, out=sets)
        sets += weight * self._band_regulariser
        band[sets.shape[0] * self._block:] = _identity_rows(self._tail, self.bandwidth)
        return band

    def right_hand_side(self, along_u: np.ndarray, along_v: np.ndarray, points: np.ndarray) -> np.ndarray:
        """B^T Q from the bases (..., n_u, N), (..., n_v, N) and points (..., 3, N) mm -> (..., M, 3)."""
        weighted = along_v[..., :, None, :] * points[..., None, :, :]
        weighted = weighted.reshape(weighted.shape[:-3] + (-1, weighted.shape[-1]))
        rhs = np.matmul(along_u, np.swapaxes(weighted, -1, -2))
        return rhs.reshape(rhs.shape[:-2] + (self.size, 3))

    def solve(self, along_u: np.ndarray, along_v: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Least-squares poles from the bases along u and v, (..., n_u, N) and (..., n_v, N), and
        the points coordinate first, (..., 3, N) mm. Returns poles (..., n_u, n_v, 3) mm."""
        weight = self.smoothing * along_u.shape[-1] / self.size
        poles = self.solve_normal(self.pair_products(along_u, along_v), weight,
                                  self.right_hand_side(along_u, along_v, points))
        return poles.reshape(points.shape[:-2] + self.poles + (3,))

    def fit(self, uv: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Least-squares poles for each point set.

        uv: (P, N, 2) or (N, 2) parameters; points: matching (..., N, 3) mm.
        Returns poles (..., n_u, n_v, 3) mm.
        """
        uv = np.asarray(uv, dtype=float)
        along_u, along_v = self.u_basis.values(uv[..., 0]), self.v_basis.values(uv[..., 1])
        return self.solve(along_u, along_v, np.swapaxes(np.asarray(points, dtype=float), -1, -2))

    def evaluate(self, poles: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """Substitute points at uv: poles (n_u, n_v, 3), uv (..., 2) -> (..., 3) mm."""
        uv = np.asarray(uv, dtype=float)
        bu, bv = self.bases(uv)
        along_u = (bu[0] @ np.asarray(poles).reshape(self.poles[0], -1)).reshape(-1, self.poles[1], 3)
        return np.einsum("njc,nj->nc", along_u, bv[0]).reshape(uv.shape[:-1] + (3,))


def _regulariser(poles: tuple[int, ...]) -> np.ndarray:
    """R = Du^T Du (x) I + I (x) Dv^T Dv + ridge I for a pole net of (n_u, n_v); (M, M)."""
    n_u, n_v = poles
    du = second_difference_matrix(n_u)
    dv = second_difference_matrix(n_v)
    r = np.kron(du.T @ du, np.eye(n_v)) + np.kron(np.eye(n_u), dv.T @ dv)
    return r + RIDGE * np.eye(n_u * n_v)


def _pair_count(count: int, degree: int) -> int:
    """Rows L of :func:`band_products` for ``count`` basis functions of ``degree``."""
    return sum(count - d for d in range(degree + 1))


def _bandwidth(paired: np.ndarray, regulariser: np.ndarray) -> int:
    """Sub-diagonals of the normal matrix: the largest |i - j| of an entry that can be non-zero,
    from paired (M, M) bool (a band pair's product) and the regulariser (M, M)."""
    rows, columns = np.nonzero(paired | (regulariser != 0))
    return int(np.abs(rows - columns).max())


def _padded_lower_band(matrix: np.ndarray, bandwidth: int, block: int, outside: float,
                       identity: float) -> np.ndarray:
    """The lower band of a symmetric (M, M) matrix padded to (block, block) with an identity, as
    (block, bandwidth + 1): row j holds the entries [j + d, j], d = 0..bandwidth; ``outside``
    off the matrix and ``identity`` on the padding's diagonal."""
    size = matrix.shape[0]
    below = np.arange(block)[:, None] + np.arange(bandwidth + 1)[None, :]
    inside = below < size
    band = np.full((block, bandwidth + 1), outside, dtype=matrix.dtype)
    band[inside] = matrix[below[inside], np.nonzero(inside)[0]]
    band[size:, 0] = identity
    return band


def _identity_rows(count: int, bandwidth: int) -> np.ndarray:
    """The lower band of a (count, count) identity: (count, bandwidth + 1)."""
    rows = np.zeros((count, bandwidth + 1))
    rows[:, 0] = 1.0
    return rows


def _banded_cholesky_solve(band: np.ndarray, rhs: np.ndarray, sets: int, size: int,
                           dense_gram: Callable[[int], np.ndarray]) -> np.ndarray:
    """Solve P symmetric positive definite banded systems, stacked as one block-diagonal system.

    band: (P * size + tail, bandwidth + 1), the lower band (row j: entries [j + d, j]) of the
    P systems of ``size`` unknowns each and a trailing identity of at least bandwidth unknowns
    (see :meth:`SubstituteSpace.padded_band`); rhs: (P * size + tail, c); sets, size: P and the
    unknowns of each set; dense_gram: a set's index -> its dense (M, M) matrix (M <= size: the
    rest is an identity), for a set LAPACK finds not positive definite in rounding, which is
    solved by LU (the sets before it are solved apart, with the same trailing identity).
    Returns (P * size + tail, c).
    """
    solution = np.zeros_like(rhs)
    start = 0
    while start < sets:
        rows = slice(start * size, None)
        solved, info = _pbsv(band[rows], rhs[rows])
        if info == 0:
            solution[rows] = solved
            break
        failed = start + (info - 1) // size
        if failed > start:
            before, tail = slice(start * size, failed * size), slice(sets * size, None)
            lower = np.concatenate([band[before], band[tail]])
            solved = _pbsv(lower, np.concatenate([rhs[before], rhs[tail]]))[0]
            solution[before] = solved[:(failed - start) * size]
        gram = dense_gram(failed)
        block = solution[failed * size:(failed + 1) * size]
        block[:] = 0.0
        block[:gram.shape[0]] = np.linalg.solve(gram, rhs[failed * size:failed * size + gram.shape[0]])
        start = failed + 1
    return solution


def _pbsv(band: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, int]:
    """LAPACK ?pbsv on one lower band (R, bandwidth + 1) and rhs (R, c): (solution (R, c), info),
    info > 0 the first row whose pivot was not positive."""
    _, solved, info = _PBSV(band.T, rhs, lower=1)
    if info < 0:
        raise ValueError(f"LAPACK ?pbsv refused its argument {-int(info)}")
    return solved, int(info)


_PBSV = lapack.get_lapack_funcs("pbsv", (np.zeros(1),))


def band_products(bases: np.ndarray, degree: int) -> np.ndarray:
    """Products N_a N_c of the band pairs a <= c <= a + k: bases (..., n, N) -> (..., L, N).

    Rows run by offset c - a = 0..k, then by a; L = sum over the offsets of n - offset.
    """
    count = bases.shape[-2]
    return np.concatenate([bases[..., :count - d, :] * bases[..., d:, :] for d in range(degree + 1)],
                          axis=-2)


def _band_pair_rows(count: int, degree: int) -> np.ndarray:
    """(count, count) row of the pair (a, c) in :func:`band_products`, -1 for pairs too far apart."""
    first = np.concatenate([np.arange(count - d) for d in range(degree + 1)])
    second = first + np.concatenate([np.full(count - d, d) for d in range(degree + 1)])
    rows = np.full((count, count), -1)
    rows[first, second] = rows[second, first] = np.arange(first.size)
    return rows


def _gram_index(poles: tuple[int, ...], degrees: tuple[int, ...]) -> np.ndarray:
    """(M, M) position of each normal-matrix entry in the flattened pair-product matrix.

    Entry [(a, b), (c, d)] is pair product [row(a, c), row(b, d)]; pairs too far apart point
    one past the end, where :meth:`SubstituteSpace.normal_matrix` puts a zero.
    """
    rows_u = _band_pair_rows(poles[0], degrees[0])
    rows_v = _band_pair_rows(poles[1], degrees[1])
    count_v = int(rows_v.max()) + 1
    pair_u = rows_u[:, None, :, None]
    pair_v = rows_v[None, :, None, :]
    index = np.where((pair_u >= 0) & (pair_v >= 0), pair_u * count_v + pair_v,
                     (int(rows_u.max()) + 1) * count_v)
    return index.reshape(poles[0] * poles[1], poles[0] * poles[1])


class FittedSurface:
    """A substitute surface: poles (n_u, n_v, 3) mm in a SubstituteSpace, evaluated at any uv of
    its parameter rectangle ``bounds`` (the space's: the substitute is never extended beyond it)."""

    def __init__(self, space: SubstituteSpace, poles: np.ndarray) -> None:
        self.space = space
        self.poles = np.asarray(poles, dtype=float)
        self.bounds = space.bounds
        self._flat = self.poles.reshape(-1, 3)

    def points(self, uv: np.ndarray) -> np.ndarray:
        """Surface points: uv (M, 2) -> (M, 3) mm."""
        return self.space.evaluate(self.poles, uv)

    def derivatives(self, uv: np.ndarray, order: int = 1) -> dict[tuple[int, int], np.ndarray]:
        """Point and partial derivatives up to ``order`` (1 or 2): {(a, b): (M, 3)} with the a-th
        u- and b-th v-derivative, mm per parameter unit."""
        bu, bv = self.space.bases(uv, order)
        return {(a, b): kron_rows(bu[a], bv[b]) @ self._flat
                for a in range(order + 1) for b in range(order + 1 - a)}
