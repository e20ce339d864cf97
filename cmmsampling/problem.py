"""SamplingProblem: everything a strategy needs to place N points on one face."""
import numpy as np

from .bound import minimax_bound
from .deviation import DeviationObjective, EvaluationGrid
from .domain import face_domain
from .fitting import SubstituteSpace, default_pole_count
from .parallel import TwoProcessObjective


CHECK_DENSITY = 3


class SamplingProblem:
    """A face, N, the substitute space, the evaluation grid and the seed.

    model: SurfaceModel; n: points wanted; fit_degree, fit_poles: (k_u, k_v), (n_u, n_v) of the
    substitute; smoothing: its second-difference weight; grid: (g_u, g_v) evaluation raster;
    seed: for the random parts of the strategies; workers: processes an optimiser's swarm is
    spread over (1 or 2); edge_offset: mm every point keeps from the face's edges; min_spacing:
    mm between any two points.
    """

    def __init__(self, model, n, fit_degree, fit_poles, smoothing, grid, seed, workers=1,
                 edge_offset=0.0, min_spacing=0.0):
        self.model = model
        self.n = n
        self.seed = seed
        self.workers = workers
        self.min_spacing = min_spacing
        self.domain = face_domain(model, edge_offset)
        self.space = SubstituteSpace(fit_degree, fit_poles, model.bounds, smoothing)
        self.grid = EvaluationGrid(model, grid, self.domain)
        self._objective = None
        self._check = None
        self._bounds = None

    @property
    def objective(self):
        """The batched maximum-deviation objective (built on first use)."""
        if self._objective is None:
            self._objective = DeviationObjective(self.model, self.space, self.grid)
        return self._objective

    @property
    def check_objective(self):
        """The objective on the check grid, CHECK_DENSITY times denser per direction (built on first use).

        Optimising on a grid partly fits its nodes; every result is also judged here.
        """
        if self._check is None:
            size = tuple(CHECK_DENSITY * g for g in self.grid.size)
            check_grid = EvaluationGrid(self.model, size, self.domain)
            self._check = DeviationObjective(self.model, self.space, check_grid)
        return self._check

    def bounds(self):
        """Certified lower bounds (MinimaxBound, mm) on the grid and on the check grid, computed once.

        Returns {"grid": MinimaxBound, "check": MinimaxBound}.
        """
        if self._bounds is None:
            self._bounds = {"grid": minimax_bound(self.space, self.grid),
                            "check": minimax_bound(self.space, self.check_objective.grid)}
        return self._bounds

    def swarm_objective(self):
        """The objective for whole swarms: split over two processes when workers == 2."""
        if self.workers == 2:
            return TwoProcessObjective(self.objective)
        return self.objective

    def project(self, uv):
        """Map uv: (..., 2) onto the face's domain."""
        return self.domain.project(np.asarray(uv, dtype=float))


def resolve_fit_poles(fit_poles, n, fit_degree):
    """(n_u, n_v): the given pole counts, or :func:`default_pole_count` for N in each direction."""
    if fit_poles is None:
        return (default_pole_count(n, fit_degree[0]), default_pole_count(n, fit_degree[1]))
    return fit_poles
