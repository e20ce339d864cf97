"""NurbsPatch: a tensor-product NURBS surface as numpy arrays, evaluated for many (u, v) at once.

Pure numpy: no FreeCAD import, so worker processes can load it quickly. Units are mm; parameters
``uv`` lie in ``bounds`` (the face's parameter range).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from .bspline import KnotBasis, design_matrices


if TYPE_CHECKING:
    from numpy.typing import ArrayLike

DEGENERATE_STEPS = (1e-7, 1e-5, 1e-3)
DEGENERATE_RATIO = 1e-8


class NurbsPatch:
    """Poles, weights and knots of one surface, with vectorised evaluation.

    degrees: (k_u, k_v); poles: (n_u, n_v, 3) mm; weights: (n_u, n_v); uknots, vknots: full knot
    vectors; bounds: (u0, u1, v0, v1) parameter range used; reversed: flip normals (a Reversed
    face), so that they point out of the material. rational: weights not all equal.
    """

    def __init__(self, degrees: Sequence[int], poles: ArrayLike, weights: ArrayLike, uknots: ArrayLike,
                 vknots: ArrayLike, bounds: Sequence[float], reversed_face: bool = False) -> None:
        self.degrees = tuple(int(d) for d in degrees)
        self.poles = np.asarray(poles, dtype=float)
        self.weights = np.asarray(weights, dtype=float)
        self.uknots = np.asarray(uknots, dtype=float)
        self.vknots = np.asarray(vknots, dtype=float)
        self.bounds = tuple(float(b) for b in bounds)
        self.reversed = bool(reversed_face)
        self.rational = not np.allclose(self.weights, self.weights.flat[0], rtol=0, atol=1e-14)
        self._homogeneous = np.concatenate(
            [self.poles * self.weights[..., None], self.weights[..., None]], axis=2
        )
        self.u_basis = KnotBasis(self.uknots, self.degrees[0])
        self.v_basis = KnotBasis(self.vknots, self.degrees[1])
        by_v = self._homogeneous if self.rational else self.poles
        self._by_v = np.ascontiguousarray(by_v.transpose(1, 2, 0)).reshape(-1, by_v.shape[0])

    def patch(self) -> NurbsPatch:
        """This surface as a plain NurbsPatch (what a worker process needs)."""
        return NurbsPatch(self.degrees, self.poles, self.weights, self.uknots, self.vknots,
                          self.bounds, self.reversed)

    @property
    def span(self) -> tuple[float, float]:
        """(du, dv): the lengths of the parameter range."""
        u0, u1, v0, v1 = self.bounds
        return (u1 - u0, v1 - v0)

    def speed_bounds(self) -> tuple[float, ...]:
        """(L_u, L_v) mm per parameter unit: |F_u| <= L_u and |F_v| <= L_v over the knot range, so
        |F(a) - F(b)| <= L_u |a_u - b_u| + L_v |a_v - b_v| for parameters a, b of the range.

        A B-spline's derivative is a B-spline of one degree less whose poles are the scaled
        differences of the poles, and lies in their convex hull. With A and w measured about the
        poles' centre c, F = A / w and F_u = (A_u - (F - c) w_u) / w, where |F - c| is at most the
        poles' largest distance from c and w at least the smallest weight (equal weights, of any
        value, make w_u zero and the bound the plain one).
        """
        centre = self.poles.reshape(-1, 3).mean(axis=0)
        reach = float(np.linalg.norm(self.poles - centre, axis=-1).max())
        homogeneous = (self.poles - centre) * self.weights[..., None]
        bounds = []
        for axis, knots, degree in ((0, self.uknots, self.degrees[0]), (1, self.vknots, self.degrees[1])):
            along = np.moveaxis(homogeneous, axis, 0)
            weights = np.moveaxis(self.weights, axis, 0)
            speed = float(np.linalg.norm(_derivative_poles(along, knots, degree), axis=-1).max(initial=0.0))
            spread = float(np.abs(_derivative_poles(weights, knots, degree)).max(initial=0.0))
            bounds.append((speed + reach * spread) / float(self.weights.min()))
        return tuple(bounds)

    def _homogeneous_derivatives(self, uv: np.ndarray, order: int) -> dict[tuple[int, int], np.ndarray]:
        """Derivatives of the homogeneous surface A(u, v) = sum w P N, w(u, v) = sum w N.

        uv: (N, 2). Returns dict {(a, b): (N, 4)} for all a + b <= order.
        """
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        bu = design_matrices(self.uknots, self.degrees[0], uv[:, 0], order)
        bv = design_matrices(self.vknots, self.degrees[1], uv[:, 1], order)
        n_u, n_v = self.weights.shape
        flat = self._homogeneous.reshape(n_u, n_v * 4)
        out = {}
        for a in range(order + 1):
            along_u = (bu[a] @ flat).reshape(-1, n_v, 4)
            for b in range(order + 1 - a):
                out[(a, b)] = np.einsum("njc,nj->nc", along_u, bv[b])
        return out

    def derivatives(self, uv: np.ndarray, order: int = 1) -> dict[tuple[int, int], np.ndarray]:
        """Surface point and partial derivatives up to ``order`` (0, 1 or 2), rational-exact.

        uv: (N, 2) in the parameter range. Returns dict {(a, b): (N, 3)} with the a-th u- and
        b-th v-derivative, in mm per parameter unit.
        """
        h = self._homogeneous_derivatives(uv, order)
        w = {key: value[:, 3:] for key, value in h.items()}
        a = {key: value[:, :3] for key, value in h.items()}
        s = {(0, 0): a[(0, 0)] / w[(0, 0)]}
        if order >= 1:
            s[(1, 0)] = (a[(1, 0)] - w[(1, 0)] * s[(0, 0)]) / w[(0, 0)]
            s[(0, 1)] = (a[(0, 1)] - w[(0, 1)] * s[(0, 0)]) / w[(0, 0)]
        if order >= 2:
            base = s[(0, 0)]
            s[(2, 0)] = (a[(2, 0)] - 2 * w[(1, 0)] * s[(1, 0)] - w[(2, 0)] * base) / w[(0, 0)]
            s[(0, 2)] = (a[(0, 2)] - 2 * w[(0, 1)] * s[(0, 1)] - w[(0, 2)] * base) / w[(0, 0)]
            s[(1, 1)] = (
                a[(1, 1)] - w[(1, 0)] * s[(0, 1)] - w[(0, 1)] * s[(1, 0)] - w[(1, 1)] * base
            ) / w[(0, 0)]
        return s

    def points_by_coordinate(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Surface points, coordinate before the points: u, v (..., N) parameters -> (..., 3, N) mm.

        The poles are first contracted with the u basis (one matrix product per leading index),
        then each point's v basis weighs its column of the result.
        """
        along_u = np.matmul(self._by_v, self.u_basis.values(u))
        bv = self.v_basis.values(v)
        width = self._by_v.shape[0] // bv.shape[-2]
        along_u = along_u.reshape(bv.shape[:-2] + (bv.shape[-2], width, bv.shape[-1]))
        combined = np.einsum("...jcm,...jm->...cm", along_u, bv)
        if self.rational:
            return combined[..., :3, :] / combined[..., 3:, :]
        return combined

    def points(self, uv: np.ndarray) -> np.ndarray:
        """Surface points, uv: (..., 2) -> (..., 3) mm."""
        uv = np.asarray(uv, dtype=float)
        flat = uv.reshape(-1, 2)
        xyz = self.points_by_coordinate(flat[:, 0], flat[:, 1]).T
        return xyz.reshape(uv.shape[:-1] + (3,))

    def normals(self, uv: np.ndarray) -> np.ndarray:
        """Unit normals pointing out of the material (face orientation respected).

        uv: (..., 2) -> (..., 3). On a degenerate edge (a pole row collapsed to one point, a
        sphere's pole) su x sv vanishes (below DEGENERATE_RATIO of |su|^2 + |sv|^2); there the
        normal is the limit from inside the face, taken a small step across the edge towards the
        middle of the parameter range (steps DEGENERATE_STEPS of the range, the last one in both
        directions). Where even that finds no normal it stays NaN.
        """
        uv = np.asarray(uv, dtype=float)
        flat = uv.reshape(-1, 2)
        normals, degenerate, across = self._plain_normals(flat)
        for attempt, step in enumerate(DEGENERATE_STEPS):
            if not degenerate.any():
                break
            if attempt == len(DEGENERATE_STEPS) - 1:
                across = np.ones_like(across)
            moved = self._towards_middle(flat[degenerate], across[degenerate], step)
            found, still, _ = self._plain_normals(moved)
            index = np.flatnonzero(degenerate)
            normals[index[~still]] = found[~still]
            degenerate[index[~still]] = False
        return normals.reshape(uv.shape[:-1] + (3,))

    def _plain_normals(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Normals from su x sv at uv: (M, 2) -> (normals (M, 3), degenerate (M,) bool,
        across (M, 2): the parameter to move along to leave a degenerate edge)."""
        d = self.derivatives(uv, 1)
        normals = unit_normals(d[(1, 0)], d[(0, 1)], self.reversed)
        cross = np.linalg.norm(np.cross(d[(1, 0)], d[(0, 1)]), axis=1)
        scale = (d[(1, 0)] ** 2).sum(1) + (d[(0, 1)] ** 2).sum(1)
        degenerate = ~(cross > DEGENERATE_RATIO * scale)
        along_v_vanishes = (d[(0, 1)] ** 2).sum(1) <= (d[(1, 0)] ** 2).sum(1)
        across = np.where(along_v_vanishes[:, None], [1.0, 0.0], [0.0, 1.0])
        return normals, degenerate, across

    def _towards_middle(self, uv: np.ndarray, across: np.ndarray, step: float) -> np.ndarray:
        """uv: (M, 2) moved ``step`` of the parameter range along ``across`` towards the middle."""
        u0, u1, v0, v1 = self.bounds
        span = np.array([u1 - u0, v1 - v0])
        towards = np.where(np.array([u0 + u1, v0 + v1]) / 2 >= uv, 1.0, -1.0)
        return uv + step * span * across * towards

    def curvatures(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and Gaussian curvature at uv: (N, 2) -> (H, K), each (N,), in 1/mm and 1/mm^2.

        The sign of H follows the outward normal.
        """
        d = self.derivatives(uv, 2)
        su, sv = d[(1, 0)], d[(0, 1)]
        n = unit_normals(su, sv, self.reversed)
        e, f, g = (su * su).sum(1), (su * sv).sum(1), (sv * sv).sum(1)
        l_, m_, n_ = (d[(2, 0)] * n).sum(1), (d[(1, 1)] * n).sum(1), (d[(0, 2)] * n).sum(1)
        det = e * g - f * f
        mean = (e * n_ - 2 * f * m_ + g * l_) / (2 * det)
        gauss = (l_ * n_ - m_ * m_) / det
        return mean, gauss

    def raster(self, size: tuple[int, int]) -> np.ndarray:
        """A regular raster of the parameter range: size (n_u, n_v) -> uv (n_u, n_v, 2)."""
        u0, u1, v0, v1 = self.bounds
        u = np.linspace(u0, u1, size[0])
        v = np.linspace(v0, v1, size[1])
        return np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)



def _derivative_poles(poles: np.ndarray, knots: np.ndarray, degree: int) -> np.ndarray:
    """Poles of a B-spline's derivative along the first axis: poles (n, ...) with the full knot
    vector ``knots`` -> (n - 1, ...), degree (P_{i+1} - P_i) / (t_{i+k+1} - t_{i+1}) (0 where the
    knots coincide: that basis function is zero)."""
    gaps = knots[degree + 1:degree + len(poles)] - knots[1:len(poles)]
    scale = np.divide(degree, gaps, out=np.zeros_like(gaps), where=gaps > 0)
    return np.diff(poles, axis=0) * scale.reshape((-1,) + (1,) * (poles.ndim - 1))


def unit_normals(su: np.ndarray, sv: np.ndarray, reversed_face: bool) -> np.ndarray:
    """Normalised su x sv, flipped for a Reversed face. su, sv: (N, 3) -> (N, 3)."""
    n = np.cross(su, sv)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return -n if reversed_face else n
