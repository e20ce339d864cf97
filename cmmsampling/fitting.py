"""Substitute geometry: batched least-squares B-spline fits to points at known (u, v).

The substitute surface is a tensor-product B-spline of degree (k_u, k_v) with (n_u, n_v) poles and
clamped uniform knots over the face's parameter range. For measured points Q_i at (u_i, v_i) its
poles C solve the normal equations

    (B^T B + lam R) C = B^T Q,      B[i] = kron(N(u_i), N(v_i)),

where R is the sum of squared second differences of the pole net along u and along v plus a much
smaller ridge, so the fit is unique for every point set (clustered ones included). lam is
``smoothing`` times N / (n_u n_v): the data term per pole, so the weight of the smoothing does not
depend on N. Many point sets are fitted in one call.
"""
import numpy as np

from .bspline import KnotBasis, clamped_uniform_knots, design_matrices, second_difference_matrix

DEFAULT_DEGREE = 3
DEFAULT_SMOOTHING = 1e-8
RIDGE = 1e-6


def default_pole_count(n_points, degree=DEFAULT_DEGREE):
    """Poles per direction for N points: round(2 sqrt(N) / 3), at least degree + 1.

    About 2.25 points per pole: 6 x 6 for N = 81, 5 x 5 for 49, 8 x 8 for 144, 4 x 4 for 25.
    """
    return max(degree + 1, int(round(2.0 * np.sqrt(n_points) / 3.0)))


class SubstituteSpace:
    """The space the substitute surface lives in, with its smoothing matrix.

    degrees: (k_u, k_v); poles: (n_u, n_v); bounds: (u0, u1, v0, v1) of the face.
    """

    def __init__(self, degrees, poles, bounds, smoothing=DEFAULT_SMOOTHING):
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

    @property
    def size(self):
        """Number of poles n_u * n_v."""
        return self.poles[0] * self.poles[1]

    def bases(self, uv, n_derivatives=0):
        """Basis matrices along u and v at uv: (..., 2).

        Returns (bu, bv): (n_derivatives + 1, M, n_u) and (n_derivatives + 1, M, n_v), M = uv.size / 2.
        """
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        return (design_matrices(self.uknots, self.degrees[0], uv[:, 0], n_derivatives),
                design_matrices(self.vknots, self.degrees[1], uv[:, 1], n_derivatives))

    def columns_by_basis(self, u, v):
        """The fit's design matrix transposed, B^T: u, v (..., N) parameters -> (..., n_u * n_v, N).

        Row a * n_v + b holds N_a(u) N_b(v), the product of the bases along u and v.
        """
        along_u, along_v = self.u_basis.values(u), self.v_basis.values(v)
        products = along_u[..., :, None, :] * along_v[..., None, :, :]
        return products.reshape(products.shape[:-3] + (self.size, products.shape[-1]))

    def normal_matrix(self, columns):
        """B^T B + lam R from the transposed design matrices, columns: (..., M, N) -> (..., M, M)."""
        n_points = columns.shape[-1]
        gram = np.matmul(columns, np.swapaxes(columns, -1, -2))
        gram += (self.smoothing * n_points / self.size) * self.regulariser
        return gram

    def solve(self, columns, points):
        """Least-squares poles from B^T: (..., M, N) and the points coordinate first (..., 3, N) mm.

        Returns poles (..., n_u, n_v, 3) mm.
        """
        rhs = np.matmul(columns, np.swapaxes(points, -1, -2))
        poles = np.linalg.solve(self.normal_matrix(columns), rhs)
        return poles.reshape(points.shape[:-2] + self.poles + (3,))

    def fit(self, uv, points):
        """Least-squares poles for each point set.

        uv: (P, N, 2) or (N, 2) parameters; points: matching (..., N, 3) mm.
        Returns poles (..., n_u, n_v, 3) mm.
        """
        uv = np.asarray(uv, dtype=float)
        columns = self.columns_by_basis(uv[..., 0], uv[..., 1])
        return self.solve(columns, np.swapaxes(np.asarray(points, dtype=float), -1, -2))

    def evaluate(self, poles, uv):
        """Substitute points at uv: poles (n_u, n_v, 3), uv (..., 2) -> (..., 3) mm."""
        uv = np.asarray(uv, dtype=float)
        bu, bv = self.bases(uv)
        along_u = (bu[0] @ np.asarray(poles).reshape(self.poles[0], -1)).reshape(-1, self.poles[1], 3)
        return np.einsum("njc,nj->nc", along_u, bv[0]).reshape(uv.shape[:-1] + (3,))


def _regulariser(poles):
    """R = Du^T Du (x) I + I (x) Dv^T Dv + ridge I for a pole net of (n_u, n_v); (M, M)."""
    n_u, n_v = poles
    du = second_difference_matrix(n_u)
    dv = second_difference_matrix(n_v)
    r = np.kron(du.T @ du, np.eye(n_v)) + np.kron(np.eye(n_u), dv.T @ dv)
    return r + RIDGE * np.eye(n_u * n_v)
