"""Certified lower bound of the maximum deviation that any point set could reach.

Every substitute fitted in a SubstituteSpace is some surface S_C of that space, so its maximum
deviation on the grid is at least the minimax error  E* = min_C max_g |S_C(g) - F(g)|.
For any probability weights w on the grid nodes,

    L(w) = sqrt( min_C sum_g w_g |S_C(g) - F(g)|^2 )  <=  E*        (weak duality),

and the maximum deviation U of any C is >= E*. Lawson's algorithm reweights w_g <- w_g r_g^beta
(r: the residual of the weighted least-squares surface) and converges to E* from both sides; the
bound returned is the best L(w) seen, never the best maximum (that is the upper bound U).
"""
from dataclasses import dataclass

import numpy as np

from .bspline import design_matrices, kron_rows

DEFAULT_TOLERANCE = 1e-4
DEFAULT_ITERATIONS = 4000


@dataclass
class MinimaxBound:
    """lower: certified lower bound of the best maximum deviation (mm); upper: maximum deviation of
    the best surface found (mm, an upper bound of that optimum); iterations; converged: the
    relative gap (upper - lower) / upper reached the tolerance; grid: (g_u, g_v) nodes used."""

    lower: float
    upper: float
    iterations: int
    converged: bool
    grid: tuple

    @property
    def gap(self):
        """Relative gap (upper - lower) / upper."""
        return (self.upper - self.lower) / self.upper if self.upper > 0 else 0.0


class _GridResiduals:
    """Residuals |S_C(g) - F(g)|^2 of a substitute on a grid, whole grid or selected nodes."""

    def __init__(self, space, grid):
        self.space = space
        self.along_u = design_matrices(space.uknots, space.degrees[0], grid.uv[:, 0, 0])[0]
        self.along_v = design_matrices(space.vknots, space.degrees[1], grid.uv[0, :, 1])[0]
        self.target = grid.cad.reshape(-1, 3)
        self.inside = np.flatnonzero(grid.mask.ravel())

    def rows(self, nodes):
        """Collocation rows (len(nodes), n_u * n_v) at flat node indices."""
        count_v = self.along_v.shape[0]
        return kron_rows(self.along_u[nodes // count_v], self.along_v[nodes % count_v])

    def everywhere(self, poles):
        """Squared residuals at every node inside the face: (K,) mm^2, for poles (n_u * n_v, 3)."""
        by_coord = poles.reshape(self.space.poles + (3,)).transpose(2, 0, 1)
        surface = (self.along_u @ by_coord @ self.along_v.T).reshape(3, -1).T
        return ((surface[self.inside] - self.target[self.inside]) ** 2).sum(axis=1)


def minimax_bound(space, grid, tolerance=DEFAULT_TOLERANCE, iterations=DEFAULT_ITERATIONS, beta=1.5,
                  check_every=10):
    """Lower and upper bound of min_C max_g |S_C(g) - F(g)| over the grid nodes inside the face.

    space: SubstituteSpace; grid: EvaluationGrid (its ``cad`` holds F); tolerance: stop when
    (upper - lower) / upper <= tolerance; iterations: at most this many reweightings;
    beta: exponent of Lawson's update (1 is Lawson's own; 1.5 converged about 5x faster on the
    reference surface, 2 oscillated); check_every: iterations between evaluations on the whole grid.
    Returns a MinimaxBound (mm).

    The reweighting runs on an active set: nodes whose weight falls below 1e-16 of the largest get
    weight exactly 0 and leave it, and at every whole-grid check the nodes whose residual exceeds
    the active set's largest come back in. Weights on any subset give a valid lower bound.
    """
    residuals = _GridResiduals(space, grid)
    nodes = residuals.inside.copy()
    weights = np.full(len(nodes), 1.0 / len(nodes))
    rows = residuals.rows(nodes)
    ridge = 1e-13 * np.eye(space.size)
    lower, upper = 0.0, np.inf
    done = 0
    for done in range(1, iterations + 1):
        weighted = rows * weights[:, None]
        poles = np.linalg.solve(rows.T @ weighted + ridge, weighted.T @ residuals.target[nodes])
        squared = ((rows @ poles - residuals.target[nodes]) ** 2).sum(axis=1)
        lower = max(lower, float(np.sqrt(max(weights @ squared, 0.0))))
        if done % check_every == 1 or check_every == 1:
            everywhere = residuals.everywhere(poles)
            upper = min(upper, float(np.sqrt(everywhere.max())))
            if upper - lower <= tolerance * upper:
                break
            nodes, weights, rows, squared = _exchange(residuals, nodes, weights, rows, squared, everywhere)
        weights = weights * squared ** (beta / 2)
        keep = weights > 1e-16 * weights.max()
        nodes, weights, rows = nodes[keep], weights[keep] / weights[keep].sum(), rows[keep]
    return MinimaxBound(lower, upper, done, upper - lower <= tolerance * upper, grid.size)


def _exchange(residuals, nodes, weights, rows, squared, everywhere):
    """Bring back the nodes outside the active set whose residual exceeds its largest one.

    They enter with the mean active weight (then renormalised) and their current residuals.
    """
    outside = np.setdiff1d(np.arange(len(residuals.inside)), np.searchsorted(residuals.inside, nodes))
    worse = outside[everywhere[outside] > squared.max()]
    if len(worse) == 0:
        return nodes, weights, rows, squared
    added = residuals.inside[worse]
    nodes = np.concatenate([nodes, added])
    weights = np.concatenate([weights, np.full(len(added), weights.mean())])
    rows = np.concatenate([rows, residuals.rows(added)])
    squared = np.concatenate([squared, everywhere[worse]])
    return nodes, weights / weights.sum(), rows, squared
