"""A local bound: the least maximum deviation that reshaping one substitute along its normals reaches.

About a substitute S0 (by default the reference fit: the fit to the face's points at every raster
node, what a fit to very many probe points tends to), the surfaces considered are
S_x = S0 + sum_m x_m N_m nu_m: each pole m moved by x_m mm along the unit normal nu_m of S0 at the
pole's Greville point. Each side of each node's exact two-sided deviation (cmmsampling.fitting.exact)
changes, to first order, by w . (S_x - S0)(at), so d_lin(x) is linear in x. For any probability
weights w on those terms,

    L(w) = sqrt( min_x sum_k w_k d_lin,k^2 )  <=  E* = min_x max_k |d_lin,k|   (weak duality),

so E* is the figure; it is found exactly as a linear programme (HiGHS, through scipy), ``lower`` its
optimum and ``upper`` the largest first-order deviation of the surface it finds.

What it certifies, and what not: no surface S_x deviates less than ``lower`` at first order at these
nodes. It is a local figure about S0: it is not a lower bound of what any point set can reach, since
point sets reach other surfaces of the substitute space (tangential reshaping, other
parametrisations) and the exact deviation is not linear; a result may end below it, and results
are reported as a multiple of it only as a yardstick.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..geometry.bspline import greville_abscissae, kron_rows
from .exact import Linearisation

if TYPE_CHECKING:
    from .exact import ExactDeviation
    from .substitute import SubstituteSpace

# Rounds of minimax_bracket's reweighting at most.
BRACKET_ROUNDS = 30


@dataclass
class MinimaxBound:
    """lower: the bound (mm, see the module docstring); upper: maximum first-order deviation of
    the best surface found (mm, an upper bound of the minimax); iterations: the solver's;
    converged: the programme was solved (else lower is 0 and upper the surface's own maximum);
    grid: (g_u, g_v) nodes used; poles: (n_u, n_v, 3) mm of the best surface found."""

    lower: float
    upper: float
    iterations: int
    converged: bool
    grid: tuple
    poles: np.ndarray | None = None

    @property
    def gap(self) -> float:
        """Relative gap (upper - lower) / upper."""
        return (self.upper - self.lower) / self.upper if self.upper > 0 else 0.0


class _GridResiduals:
    """First-order deviations of the surfaces S_x at every side of every node, all or selected.

    space: SubstituteSpace; exact: the ExactDeviation of S0 (its poles the reference). With d_k
    a side's exact deviation, w_k its direction and at_k its parameters on S0,
    d(x)_k = d_k + sum_m x_m N_m(at_k) (w_k . nu_m) to first order: the row of term k is
    N_m(at_k) (w_k . nu_m) over the poles m, its target -d_k.
    """

    def __init__(self, space: SubstituteSpace, exact: ExactDeviation) -> None:
        self.reference = np.asarray(exact.poles, dtype=float)
        linearisation = Linearisation(None, space, exact)
        values, along = linearisation.targets
        directions = pole_normals(space, self.reference)
        self._rows = linearisation.rows * (along @ directions.T)
        self._target = -values
        self.directions = directions
        self.inside = np.arange(len(values))

    def rows(self, nodes: np.ndarray) -> np.ndarray:
        """Rows (len(nodes), n_u n_v) at indices into the measured nodes."""
        return self._rows[nodes]

    def target(self, nodes: np.ndarray) -> np.ndarray:
        """Targets (len(nodes),) mm at indices into the measured nodes."""
        return self._target[nodes]

    def everywhere(self, x: np.ndarray) -> np.ndarray:
        """Squared first-order deviations at every measured node: (K,) mm^2, for x (n_u n_v,)."""
        return (self._rows @ x - self._target) ** 2

    def poles(self, x: np.ndarray) -> np.ndarray:
        """The poles (n_u, n_v, 3) of S_x."""
        moved = self.reference.reshape(-1, 3) + x[:, None] * self.directions
        return moved.reshape(self.reference.shape)


def pole_normals(space: SubstituteSpace, poles: np.ndarray) -> np.ndarray:
    """Unit normals nu (n_u n_v, 3) of the surface with ``poles`` at its poles' Greville points."""
    gu = greville_abscissae(space.uknots, space.degrees[0])
    gv = greville_abscissae(space.vknots, space.degrees[1])
    uv = np.stack(np.meshgrid(gu, gv, indexing="ij"), axis=-1).reshape(-1, 2)
    bu, bv = space.bases(uv, 1)
    flat = poles.reshape(-1, 3)
    normal = np.cross(kron_rows(bu[1], bv[0]) @ flat, kron_rows(bu[0], bv[1]) @ flat)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    return np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)


def minimax_bracket(space: SubstituteSpace, exact: ExactDeviation, level: float | None = None) -> tuple[float, float]:
    """(lower, upper) mm around :func:`minimax_bound`'s figure, in milliseconds, by Lawson's
    reweighted least squares: for probability weights w on the terms, sqrt(min_x sum_k w_k
    d_lin,k^2) is at most the minimax (weak duality, see the module docstring) and the largest
    |d_lin,k| of that x at least it; the weights then grow where the terms are largest.

    space, exact: as minimax_bound; level: mm, stop as soon as the bracket lies wholly above or
    below it (what a search asks: "can this space reach the tolerance?"), else after
    BRACKET_ROUNDS rounds.
    """
    residuals = _GridResiduals(space, exact)
    rows, target = residuals.rows(residuals.inside), residuals.target(residuals.inside)
    scale = float(np.abs(target).max(initial=0.0))
    if scale == 0:
        return 0.0, 0.0
    target = target / scale
    weights = np.full(len(rows), 1.0 / len(rows))
    lower, upper = 0.0, np.inf
    for _ in range(BRACKET_ROUNDS):
        weighted = rows * weights[:, None]
        x = np.linalg.lstsq(rows.T @ weighted, weighted.T @ target, rcond=None)[0]
        squared = (rows @ x - target) ** 2
        lower = max(lower, float(np.sqrt(weights @ squared)))
        upper = min(upper, float(np.sqrt(squared.max())))
        if level is not None and (lower * scale > level or upper * scale <= level):
            break
        weights = weights * np.sqrt(squared)
        weights /= weights.sum()
    return lower * scale, upper * scale


def minimax_bound(space: SubstituteSpace, exact: ExactDeviation, grid: Sequence[int]) -> MinimaxBound:
    """min_x max_k |d_lin,k| over both sides of every node, as a linear programme.

    space: SubstituteSpace; exact: the ExactDeviation of the substitute S0 the surfaces are
    reshaped from (see the module docstring); grid: (g_u, g_v) of its raster. The programme
    (minimise t subject to -t <= d_k + r_k x <= t) is solved by HiGHS (scipy.optimize.linprog);
    ``lower`` is its optimum, ``upper`` the largest |d_lin,k| of its solution (equal within
    HiGHS's tolerances). Returns a MinimaxBound (mm).
    """
    residuals = _GridResiduals(space, exact)
    rows, target = residuals.rows(residuals.inside), residuals.target(residuals.inside)
    count = rows.shape[1]
    answer = _programme(rows, target)
    if answer.status != 0:
        zero = np.zeros(count)
        own = float(np.sqrt(residuals.everywhere(zero).max()))
        return MinimaxBound(0.0, own, 0, False, tuple(grid), residuals.poles(zero))
    x = answer.x[:count]
    upper = float(np.sqrt(residuals.everywhere(x).max()))
    return MinimaxBound(min(float(answer.fun), upper), upper, int(answer.nit), True, tuple(grid), residuals.poles(x))


def _programme(rows: np.ndarray, target: np.ndarray) -> Any:
    """HiGHS's answer to: minimise t subject to |rows x - target| <= t; rows (K, M), target (K,)
    (scaled to about 1 by the caller where the figures are small); scipy's OptimizeResult, x =
    (x (M,), t)."""
    from scipy.optimize import linprog

    count, ones = rows.shape[1], np.ones((len(rows), 1))
    return linprog(np.r_[np.zeros(count), 1.0], A_ub=np.block([[rows, -ones], [-rows, -ones]]),
                   b_ub=np.r_[target, -target], bounds=[(None, None)] * count + [(0, None)], method="highs")
