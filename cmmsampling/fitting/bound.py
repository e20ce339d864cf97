"""Lower bound of the maximum deviation reachable by moving the reference fit along its normals.

The reference substitute S_ref is the fit to the face's points at every grid node (what a fit to
very many probe points tends to), with feet f*, F* = F(f*) and n* = n_F(f*) on the face
(cmmsampling.fitting.deviation). The surfaces considered are S_x = S_ref + sum_m x_m N_m nu_m: each pole m
moved by x_m mm along the unit normal nu_m of S_ref at the pole's Greville point. They keep the
reference's parametrisation, which a least-squares fit at the face's own parameters also keeps,
so their first-order deviation d_lin(g) = n*(g) . (S_x(g) - F*(g)) is linear in x and close to the
exact one. For any probability weights w on the grid nodes,

    L(w) = sqrt( min_x sum_g w_g d_lin(g)^2 )  <=  E* = min_x max_g |d_lin(g)|   (weak duality),

and the maximum U of any x is >= E*. Lawson's algorithm reweights w_g <- w_g r_g^beta (r: the
residual of the weighted least-squares surface) and converges to E* from both sides; the bound
returned is the best L(w) seen, never the best maximum (that is the upper bound U).

What it certifies: no surface S_x deviates less than ``lower`` (first order) on the grid. Point
sets reach surfaces of the whole substitute space, not only S_x, so a result may end slightly
below it; the study reports every result as a multiple of it.
"""
from dataclasses import dataclass

import numpy as np

from ..geometry.bspline import greville_abscissae, kron_rows
from .deviation import substitute_distances
from .substitute import FittedSurface

DEFAULT_TOLERANCE = 1e-3
DEFAULT_ITERATIONS = 4000
ACTIVE_WEIGHT = 1e-6


@dataclass
class MinimaxBound:
    """lower: the bound (mm, see the module docstring); upper: maximum first-order deviation of
    the best surface found (mm, an upper bound of the minimax); iterations; converged: the
    relative gap (upper - lower) / upper reached the tolerance; grid: (g_u, g_v) nodes used;
    poles: (n_u, n_v, 3) mm of the best surface found."""

    lower: float
    upper: float
    iterations: int
    converged: bool
    grid: tuple
    poles: np.ndarray = None

    @property
    def gap(self):
        """Relative gap (upper - lower) / upper."""
        return (self.upper - self.lower) / self.upper if self.upper > 0 else 0.0


class _GridResiduals:
    """First-order deviations of the surfaces S_x at the objective's nodes, all or selected.

    objective: a DeviationObjective (its nodes); reference: poles (n_u, n_v, 3) mm of the surface
    reshaped. With p_g the closest point of S_ref to node g, d_g its exact deviation and
    w_g = (S_ref(p_g) - F_g) / d_g the direction it is measured along (the face's normal where
    d_g = 0), d(x)_g = d_g + sum_m x_m N_m(p_g) (w_g . nu_m) to first order: the row of node g
    is N_m(p_g) (w_g . nu_m) over the poles m, its target -d_g.
    """

    def __init__(self, objective, reference):
        space = objective.space
        self.reference = np.asarray(reference, dtype=float)
        surface = FittedSurface(space, self.reference)
        signed, closest = substitute_distances(surface, objective.feet, objective.grid.uv)
        self.inside = np.flatnonzero(np.isfinite(signed).ravel())
        signed, closest = signed.ravel()[self.inside], closest.reshape(-1, 2)[self.inside]
        offsets = surface.points(closest) - objective.feet.points.reshape(-1, 3)[self.inside]
        along = objective.feet.normals.reshape(-1, 3)[self.inside].copy()
        measured = np.abs(signed) > 1e-12 * max(1.0, float(np.abs(signed).max()))
        along[measured] = offsets[measured] / signed[measured, None]
        bu, bv = space.bases(closest)
        directions = pole_normals(space, self.reference)
        self._rows = kron_rows(bu[0], bv[0]) * (along @ directions.T)
        self._target = -signed
        self.directions = directions

    def rows(self, nodes):
        """Rows (len(nodes), n_u n_v) at indices into the measured nodes."""
        return self._rows[nodes]

    def target(self, nodes):
        """Targets (len(nodes),) mm at indices into the measured nodes."""
        return self._target[nodes]

    def everywhere(self, x):
        """Squared first-order deviations at every measured node: (K,) mm^2, for x (n_u n_v,)."""
        return (self._rows @ x - self._target) ** 2

    def poles(self, x):
        """The poles (n_u, n_v, 3) of S_x."""
        moved = self.reference.reshape(-1, 3) + x[:, None] * self.directions
        return moved.reshape(self.reference.shape)


def pole_normals(space, poles):
    """Unit normals nu (n_u n_v, 3) of the surface with ``poles`` at its poles' Greville points."""
    gu = greville_abscissae(space.uknots, space.degrees[0])
    gv = greville_abscissae(space.vknots, space.degrees[1])
    uv = np.stack(np.meshgrid(gu, gv, indexing="ij"), axis=-1).reshape(-1, 2)
    bu, bv = space.bases(uv, 1)
    flat = poles.reshape(-1, 3)
    normal = np.cross(kron_rows(bu[1], bv[0]) @ flat, kron_rows(bu[0], bv[1]) @ flat)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    return np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)


def minimax_bound(objective, reference, tolerance=DEFAULT_TOLERANCE, iterations=DEFAULT_ITERATIONS, beta=1.5,
                  check_every=10):
    """Lower and upper bound of min_x max_g |d_lin(g)| over the nodes the objective counts.

    objective: a DeviationObjective expanded at the feet of ``reference``, the reference fit's
    poles (n_u, n_v, 3) mm (see the module docstring); tolerance: stop when
    (upper - lower) / upper <= tolerance; iterations: at most this many reweightings;
    beta: exponent of Lawson's update (1 is Lawson's own; 1.5 converged about 5x faster on the
    reference surface, 2 oscillated); check_every: iterations between evaluations on the whole grid.
    Returns a MinimaxBound (mm).

    The reweighting runs on an active set: nodes whose weight falls below ACTIVE_WEIGHT of the largest get
    weight exactly 0 and leave it, and at every whole-grid check the nodes whose residual exceeds
    the active set's largest come back in. Weights on any subset give a valid lower bound.
    """
    residuals = _GridResiduals(objective, reference)
    nodes = np.arange(len(residuals.inside))
    weights = np.full(len(nodes), 1.0 / len(nodes))
    rows = residuals.rows(nodes)
    ridge = 1e-13 * np.eye(rows.shape[1])
    lower, upper, best = 0.0, np.inf, None
    done = 0
    for done in range(1, iterations + 1):
        weighted = rows * weights[:, None]
        x = np.linalg.solve(rows.T @ weighted + ridge, weighted.T @ residuals.target(nodes))
        squared = (rows @ x - residuals.target(nodes)) ** 2
        lower = max(lower, float(np.sqrt(max(weights @ squared, 0.0))))
        if done % check_every == 1 or check_every == 1:
            everywhere = residuals.everywhere(x)
            if np.sqrt(everywhere.max()) < upper:
                upper, best = float(np.sqrt(everywhere.max())), x
            if upper - lower <= tolerance * upper:
                break
            nodes, weights, rows, squared = _exchange(residuals, nodes, weights, rows, squared, everywhere)
        weights = weights * squared ** (beta / 2)
        keep = weights > ACTIVE_WEIGHT * weights.max()
        nodes, weights, rows = nodes[keep], weights[keep] / weights[keep].sum(), rows[keep]
    return MinimaxBound(lower, upper, done, upper - lower <= tolerance * upper, objective.grid.size,
                        residuals.poles(best))


def _exchange(residuals, nodes, weights, rows, squared, everywhere):
    """Bring back the nodes outside the active set whose residual exceeds its largest one.

    They enter with the mean active weight (then renormalised) and their current residuals.
    """
    outside = np.setdiff1d(np.arange(len(residuals.inside)), nodes)
    worse = outside[everywhere[outside] > squared.max()]
    if len(worse) == 0:
        return nodes, weights, rows, squared
    added = worse
    nodes = np.concatenate([nodes, added])
    weights = np.concatenate([weights, np.full(len(added), weights.mean())])
    rows = np.concatenate([rows, residuals.rows(added)])
    squared = np.concatenate([squared, everywhere[worse]])
    return nodes, weights / weights.sum(), rows, squared
