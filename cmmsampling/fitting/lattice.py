"""The swarm's fits from tables on a lattice of parameters.

A swarm fits a substitute to every particle's point set at every iteration. Each fit needs the
face's points and the substitute's basis values at the set's parameters; evaluated anew, the
four bases (face and substitute, along u and v) cost about a third of a swarm's iteration, in
numpy calls on small arrays. Along each direction everything a fit needs is a function of that
one parameter: the face's poles contracted with its basis along u, its basis along v, the
substitute's basis and the band products of its basis (cmmsampling.fitting.substitute). They are
tabulated once on LATTICE_STEPS + 1 equally spaced parameters spanning the face's range, and a
point set is fitted at its parameters rounded to the lattice, from one row lookup per direction.

Rounded parameters are parameters of the face like any others: the fit is exact there (the
points lie on the face, the bases are those at the rounded parameters), only moved by at most
half a step, 1/32768 of the range. The swarm's figure is already an expansion (a few per cent of
the exact figure, see cmmsampling.fitting.deviation); every result is judged exactly at its own
parameters. A face whose tables would exceed LATTICE_LIMIT_BYTES (hundreds of poles along a
direction) is fitted from the bases evaluated anew.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .substitute import band_products

if TYPE_CHECKING:
    from .substitute import SubstituteSpace

LATTICE_STEPS = 1 << 14
LATTICE_LIMIT_BYTES = 16 * 2**20


class LatticeFit:
    """Face points and substitute poles of whole swarms from per-direction tables.

    model: the face's NurbsPatch (its bounds are the lattice's range); space: SubstituteSpace
    over the same range. reach: mm, at least the distance from a face point to the one at its
    rounded parameters (the face's speed bounds times a whole step, twice the rounding). Rows of
    the u table: the face's homogeneous (rational) or plain poles contracted with its u basis,
    (n_v, c) flattened; the substitute's u basis (n_u'); its band products (L_u). Rows of the v
    table: the face's v basis (n_v); the substitute's v basis (n_v'); its band products (L_v).
    """

    def __init__(self, model: Any, space: SubstituteSpace, steps: int = LATTICE_STEPS) -> None:
        self.model, self.space, self.steps = model, space, steps
        u0, u1, v0, v1 = model.bounds
        self.lower = np.array([u0, v0])
        self.scale = steps / np.array([u1 - u0, v1 - v0])
        along_u = np.linspace(u0, u1, steps + 1)[None]
        along_v = np.linspace(v0, v1, steps + 1)[None]
        poles = model._homogeneous if model.rational else model.poles
        self.face_columns = poles.shape[1] * poles.shape[2]
        self.coordinates = poles.shape[2]
        face_u = np.einsum("il,ijc->ljc", model.u_basis.values(along_u)[0], poles).reshape(steps + 1, -1)
        self.u_table = self._table(face_u, space.u_basis.values(along_u)[0], space.degrees[0])
        self.v_table = self._table(model.v_basis.values(along_v)[0].T, space.v_basis.values(along_v)[0],
                                   space.degrees[1])
        self.face_v = model.v_basis.count
        self.basis_u, self.basis_v = space.poles
        self._gram_scale = space.smoothing / space.size
        self.reach = float(np.dot(model.speed_bounds(), 1.0 / self.scale))

    @staticmethod
    def _table(face: np.ndarray, substitute: np.ndarray, degree: int) -> np.ndarray:
        """(steps + 1, columns): the face's columns, the substitute's basis (n, steps + 1) and its
        band products, one row per lattice parameter."""
        return np.ascontiguousarray(np.concatenate([face, substitute.T, band_products(substitute, degree).T],
                                                   axis=1))

    @staticmethod
    def table_bytes(model: Any, space: SubstituteSpace, steps: int = LATTICE_STEPS) -> int:
        """Bytes the two tables of a LatticeFit of ``model`` and ``space`` take."""
        count = model.weights.shape
        coordinates = 4 if model.rational else 3
        bands = [sum(n - d for d in range(k + 1)) for n, k in zip(space.poles, space.degrees)]
        columns = count[1] * coordinates + space.poles[0] + bands[0] + count[1] + space.poles[1] + bands[1]
        return 8 * (steps + 1) * columns

    def rounded(self, uv: np.ndarray) -> np.ndarray:
        """uv: (..., 2) rounded to the lattice, the parameters the fit is made at."""
        return self.lower + self._indices(uv) / self.scale

    def _indices(self, uv: np.ndarray) -> np.ndarray:
        """Lattice indices of uv: (..., 2) -> (..., 2) int in [0, steps]."""
        indices = np.rint((np.asarray(uv, dtype=float) - self.lower) * self.scale).astype(np.intp)
        return np.minimum(np.maximum(indices, 0), self.steps)

    def points_and_poles(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Face points and substitute poles of point sets at uv (P, N, 2) rounded to the lattice.

        Returns (points (P, 3, N) mm, coordinate first, poles (P, n_u, n_v, 3) mm).
        """
        indices = self._indices(uv)
        rows_u = self.u_table[indices[..., 0]]
        rows_v = self.v_table[indices[..., 1]]
        sets, count = uv.shape[:2]
        face = rows_u[..., :self.face_columns].reshape(sets, count, self.face_v, self.coordinates)
        points = np.matmul(rows_v[..., None, :self.face_v], face)[..., 0, :]
        points = np.ascontiguousarray(np.swapaxes(points, 1, 2))
        if self.model.rational:
            points = points[:, :3] / points[:, 3:]
        start_u, start_v = self.face_columns, self.face_v
        basis_u = rows_u[..., start_u:start_u + self.basis_u]
        basis_v = np.swapaxes(rows_v[..., start_v:start_v + self.basis_v], 1, 2)
        pairs = np.matmul(np.swapaxes(rows_u[..., start_u + self.basis_u:], 1, 2),
                          rows_v[..., start_v + self.basis_v:])
        weighted = (basis_v[:, :, None, :] * points[:, None, :, :]).reshape(sets, -1, count)
        rhs = np.matmul(np.swapaxes(basis_u, 1, 2), np.swapaxes(weighted, 1, 2)).reshape(sets, self.space.size, 3)
        poles = self.space.solve_normal(pairs, self._gram_scale * count, rhs)
        return points, poles.reshape((sets,) + self.space.poles + (3,))
