"""SamplingProblem: everything a strategy needs to place N points on one face."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..fitting.bound import minimax_bound, minimax_bracket
from ..fitting.deviation import DeviationObjective, DeviationStats, EvaluationGrid, deviation_objective
from ..fitting.exact import exact_deviation
from ..fitting.substitute import SubstituteSpace
from ..geometry.domain import FaceDomain
from ..geometry.surface import SurfaceModel
from ..runtime.parallel import TwoProcessObjective
from .settings import SampleSettings

if TYPE_CHECKING:   # for the annotations only
    from ..access.reach import Reachability
    from ..fitting.bound import MinimaxBound
    from ..fitting.exact import ExactDeviation


CHECK_DENSITY = 3
# Substitutes whose exact deviation a problem keeps per grid: the blind layouts the optimal
# strategy chooses its start from, the one it starts with, a result's deviation and its bound.
JUDGED_KEPT = 4


class SamplingProblem:
    """A face, N, the substitute space, the evaluation grid and the seed.

    model: SurfaceModel; settings: the checked SampleSettings (n, the substitute's degree,
    poles and smoothing, the grid, seed, workers), whose n, seed and workers the problem
    reads as properties; domain: the face's FaceDomain (cmmsampling.geometry.domain: the
    trim, the edge offset, what the probe reaches); min_spacing: mm between any two points, the
    settings' or the face's default (spacing_by_default True); measured_split: workers is the
    default, so a swarm is split only where that is measured faster; reachability: None, or
    where a probe reaches the part the face belongs to (cmmsampling.access.reach.Reachability),
    the one the domain was built with; grid: the EvaluationGrid, when one of settings.grid is at
    hand.
    """

    def __init__(self, model: SurfaceModel, settings: SampleSettings, domain: FaceDomain, *,
                 min_spacing: float, spacing_by_default: bool = False,
                 reachability: Reachability | None = None, grid: EvaluationGrid | None = None) -> None:
        self.model = model
        self.settings = settings
        self.reachability = reachability
        self.min_spacing = min_spacing
        self.spacing_by_default = spacing_by_default
        self.domain = domain
        self.space = SubstituteSpace(settings.fit_degree, settings.fit_poles, model.bounds, settings.smoothing)
        self.grid = EvaluationGrid(model, settings.grid) if grid is None else grid
        self._objective: DeviationObjective | None = None
        self._check: DeviationObjective | None = None
        self._bounds: LocalBounds | None = None
        self._judged: dict[bool, list] = {}

    def with_poles(self, poles: tuple[int, int]) -> SamplingProblem:
        """The same face, N, domain, grid and spacing with a substitute of ``poles`` (n_u, n_v):
        the grid's nodes on the face are shared, not found again."""
        other = SamplingProblem(self.model, replace(self.settings, fit_poles=tuple(poles)), self.domain,
                                min_spacing=self.min_spacing, spacing_by_default=self.spacing_by_default,
                                reachability=self.reachability, grid=self.grid)
        other._objective = DeviationObjective(self.model, other.space, self.grid, self.objective.nodes)
        return other

    @property
    def n(self) -> int:
        """Points wanted (the settings')."""
        return self.settings.n

    @property
    def seed(self) -> int:
        """The seed of the strategies' random parts (the settings')."""
        return self.settings.seed

    @property
    def workers(self) -> int:
        """Processes an optimiser's swarm is spread over, 1 or 2 (the settings')."""
        return self.settings.workers

    @property
    def measured_split(self) -> bool:
        """True where workers is the default: a swarm is split only where that is measured faster."""
        return not self.settings.workers_given

    @property
    def reached(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """uv (..., 2) -> (...) bool, where the probe reaches the face, the only part of it a
        substitute is judged over; None when no probe was asked (the whole face is judged)."""
        return None if self.domain.unreached is None else self.domain.reached

    @property
    def counts(self) -> Callable[[np.ndarray], np.ndarray] | None:
        """uv (..., 2) -> (...) bool, where a substitute's deviation counts: on the face (its trim)
        and where the probe reaches it; None where it counts everywhere on the rectangle."""
        tests = [test for test in (self.domain.on_face, self.reached) if test is not None]
        if not tests:
            return None
        return lambda uv: np.logical_and.reduce([np.asarray(test(uv), dtype=bool) for test in tests])

    def spacing_advice(self) -> str:
        """How to let more points in, in words that say whether the caller chose the spacing."""
        if self.spacing_by_default:
            return (f"the default spacing of {self.min_spacing:.3g} mm applies; lower n or pass a "
                    "smaller min_spacing (0 allows any)")
        return "lower n or min_spacing"

    @property
    def objective(self) -> DeviationObjective:
        """The batched maximum-deviation objective on the grid's nodes (built on first use)."""
        if self._objective is None:
            self._objective = self._reference_objective(self.grid)
        return self._objective

    @property
    def check_objective(self) -> DeviationObjective:
        """The objective on the check grid, CHECK_DENSITY times denser per direction (built on first use).

        Optimising on a grid partly fits its nodes; every result is also judged here.
        """
        if self._check is None:
            size = tuple(CHECK_DENSITY * g for g in self.grid.size)
            self._check = self._reference_objective(EvaluationGrid(self.model, size))
        return self._check

    def _reference_objective(self, grid: EvaluationGrid) -> DeviationObjective:
        """A DeviationObjective on ``grid``'s nodes of the face."""
        return deviation_objective(self.model, self.space, grid, self.domain.on_face, self.reached)

    def judge(self, poles: np.ndarray, check: bool = False) -> ExactDeviation:
        """The exact two-sided deviation (cmmsampling.fitting.exact.ExactDeviation) of the substitute
        with ``poles`` (n_u, n_v, 3) mm at the nodes of the grid or the check grid (the last
        JUDGED_KEPT judged on each are kept and not judged again)."""
        poles = np.asarray(poles, dtype=float)
        kept = self._judged.setdefault(check, [])
        for judged_poles, exact in kept:
            if np.array_equal(judged_poles, poles):
                return exact
        objective = self.check_objective if check else self.objective
        exact = exact_deviation(self.space, poles, objective.nodes, objective.model, self.domain.on_face,
                                self.reached)
        kept.append((poles.copy(), exact))
        del kept[:-JUDGED_KEPT]
        return exact

    def bound_bracket(self, poles: np.ndarray, level: float | None = None) -> tuple[float, float]:
        """(lower, upper) mm around the local bound on the grid about the substitute with ``poles``
        (n_u, n_v, 3) mm, in milliseconds; level: mm, stop once it lies outside
        (cmmsampling.fitting.bound.minimax_bracket)."""
        return minimax_bracket(self.space, self.judge(poles), level)

    def exact(self, uv: np.ndarray) -> ExactDeviation:
        """The ExactDeviation, on the grid, of the substitute fitted at uv (N, 2)."""
        return self.judge(self.objective.fit(np.asarray(uv, dtype=float)[None])[0])

    def exact_maximum(self, uv: np.ndarray) -> float:
        """Exact maximum deviation (mm) of the substitute fitted at uv (N, 2), on the grid."""
        return self.exact(uv).maximum

    def deviation(self, poles: np.ndarray, check: bool = False) -> DeviationStats:
        """Exact deviation statistics (DeviationStats, mm) of a substitute on the grid or check grid."""
        return DeviationStats.from_exact(self.judge(poles, check), self.space)

    def bounds(self, poles: np.ndarray | None = None) -> LocalBounds:
        """Local bounds (MinimaxBound, mm) about a substitute on the grid and on the check grid: the
        least first-order maximum deviation that moving its poles along its normals could reach
        (see cmmsampling.fitting.bound: a local figure, not a bound over every point set). poles:
        (n_u, n_v, 3) mm, default the reference fit's (then computed once). Returns LocalBounds:
        {"grid": MinimaxBound, "check": MinimaxBound}, each computed when first asked for (the
        check grid's programme takes seconds).
        """
        if poles is None and self._bounds is not None:
            return self._bounds
        about = self.objective.reference_poles() if poles is None else poles

        def compute(check: bool) -> MinimaxBound:
            grid = (self.check_objective if check else self.objective).grid.size
            return minimax_bound(self.space, self.judge(about, check), grid)

        found = LocalBounds(compute)
        if poles is None:
            self._bounds = found
        return found

    def swarm_objective(self) -> DeviationObjective | TwoProcessObjective:
        """The objective for whole swarms: split over two processes when workers == 2 (where
        that is faster, measured as it runs, when the caller left workers to the default)."""
        if self.workers == 2:
            return TwoProcessObjective(self.objective, measured=self.measured_split)
        return self.objective

    def spaced(self, uv: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """True for the point sets uv[rows] (uv: (P, N, 2)) that keep min_spacing: (len(rows),) bool,
        all P when rows is None."""
        return self.objective.spaced(uv, self.min_spacing, rows)

    def project(self, uv: np.ndarray) -> np.ndarray:
        """Map uv: (..., 2) onto the face's domain."""
        return self.domain.project(np.asarray(uv, dtype=float))


class LocalBounds(dict):
    """{"grid": MinimaxBound, "check": MinimaxBound}, each computed on first access by
    compute(check: bool)."""

    def __init__(self, compute: Callable[[bool], MinimaxBound]) -> None:
        super().__init__()
        self._compute = compute

    def __missing__(self, key: str) -> MinimaxBound:
        if key not in ("grid", "check"):
            raise KeyError(key)
        self[key] = self._compute(key == "check")
        return self[key]

