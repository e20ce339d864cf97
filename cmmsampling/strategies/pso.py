"""Particle swarm optimisation (Kennedy & Eberhart 1995) over sets of points in a box.

Generic: it knows nothing of surfaces. A particle is a set of N points ``(N, 2)``; the whole swarm
``(P, N, 2)`` is scored by one call of a batched objective ``f(X) -> (P,)``. The update is the
paper's eq. 7-9, per particle i and coordinate j:

    v[k+1] = w v[k] + c1 r1 (pbest - x[k]) + c2 r2 (gbest - x[k]),    x[k+1] = x[k] + v[k+1],

with r1, r2 uniform in [0, 1] drawn per coordinate, and an inertia decreasing linearly from w1 at
the first iteration to w2 at the last. Velocities are limited to ``velocity_limit`` times the box
size; a coordinate pushed out of the feasible set is projected back and its velocity zeroed.

Below the algorithm, the strategy: :func:`run_pso` runs it on a sampling problem and :data:`RECORD`
describes it to the rest of the project.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..fitting.lattice import LATTICE_LIMIT_BYTES
from ..geometry.validation import InputError, check_int, check_real
from ..runtime import memory
from . import blind
from .registry import STRATEGIES, Progress, Setting, Strategy, StrategyOutcome, layouts
from .settings import UNIFORM_LAYOUTS

if TYPE_CHECKING:
    from ..fitting.deviation import DeviationObjective
    from ..runtime.parallel import TwoProcessObjective
    from .problem import SamplingProblem


@dataclass
class SwarmSettings:
    """PSO parameters; the defaults are the paper's (population 25, 3000 iterations,
    w 0.5 -> 0, c1 = c2 = 2). velocity_limit: fraction of the box size per coordinate."""

    population: int = 25
    iterations: int = 3000
    w1: float = 0.5
    w2: float = 0.0
    c1: float = 2.0
    c2: float = 2.0
    velocity_limit: float = 0.1
    seed: int = 0


@dataclass
class SwarmResult:
    """best: (N, 2) best point set; best_value: its objective; history: (iterations run,) best
    objective after each iteration; evaluations: objective evaluations; cancelled: stopped early."""

    best: np.ndarray
    best_value: float
    history: np.ndarray
    evaluations: int
    cancelled: bool


def inertia(iteration: int, settings: SwarmSettings) -> float:
    """Inertia weight at iteration 1..iterations, linear from w1 to w2."""
    if settings.iterations == 1:
        return settings.w1
    fraction = (iteration - 1) / (settings.iterations - 1)
    return settings.w1 - fraction * (settings.w1 - settings.w2)


def _initial_swarm(rng: np.random.Generator, lower: np.ndarray, upper: np.ndarray, n_points: int,
                   settings: SwarmSettings, seeds: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random positions in the box, the first particles replaced by the given seed layouts."""
    shape = (settings.population, n_points, 2)
    positions = lower + rng.random(shape) * (upper - lower)
    for index, layout in enumerate(seeds[: settings.population]):
        positions[index] = layout
    limit = settings.velocity_limit * (upper - lower)
    velocities = (2 * rng.random(shape) - 1) * limit
    return positions, velocities, limit


def _attraction(positions: np.ndarray, personal: np.ndarray, best: np.ndarray, r1: np.ndarray, r2: np.ndarray,
                settings: SwarmSettings) -> np.ndarray:
    """c1 r1 (pbest - x) + c2 r2 (gbest - x) for the whole swarm, computed in r1 and r2 in place.

    positions, personal, r1, r2: (P, N, 2); best: (N, 2). Returns r1.
    """
    r1 *= settings.c1
    r1 *= personal - positions
    r2 *= settings.c2
    r2 *= best - positions
    r1 += r2
    return r1


def _screened(values: np.ndarray, positions: np.ndarray, personal_values: np.ndarray,
              admissible: Callable[[np.ndarray, np.ndarray], np.ndarray] | None) -> np.ndarray:
    """values (P,) with inf where a position that would improve its personal best is inadmissible."""
    if admissible is None:
        return values
    candidates = np.flatnonzero(values < personal_values)
    if len(candidates):
        values[candidates[~admissible(positions, candidates)]] = np.inf
    return values


def _scores(objective: Callable[..., np.ndarray], positions: np.ndarray, personal_values: np.ndarray) -> np.ndarray:
    """objective(positions), told the personal bests to beat where it takes them (its ``beats``
    attribute is True: values that do not beat them may come back as any lower value that still
    does not)."""
    if getattr(objective, "beats", False):
        return objective(positions, personal_values)
    return objective(positions)


def particle_swarm(objective: Callable[..., np.ndarray], lower: np.ndarray, upper: np.ndarray, n_points: int,
                   settings: SwarmSettings, seeds: Sequence[np.ndarray] = (),
                   project: Callable[[np.ndarray], np.ndarray] | None = None,
                   progress: Callable[[int, float, np.ndarray], bool | None] | None = None,
                   admissible: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> SwarmResult:
    """Minimise objective over sets of n_points points in the box [lower, upper].

    objective: callable (P, N, 2) -> (P,), or with a true ``beats`` attribute (uv, above (P,)) ->
    (P,) where values at or above ``above`` need not be exact (see :func:`_scores`); lower, upper:
    (2,) box corners; settings: SwarmSettings;
    seeds: layouts (N, 2) that start as particles 0, 1, ...; project: callable (P, N, 2) -> (P, N, 2)
    mapping positions onto the feasible set (default: clip to the box); progress: callable
    (iteration, best_value, best (N, 2)), called after every iteration, returning True to stop;
    admissible: callable (positions (P, N, 2), rows (M,) int) -> (M,) bool for positions[rows], a
    constraint checked only for the positions that would become a personal best (inadmissible
    ones never do), so that it costs little; it is given the array just passed to objective.
    Returns SwarmResult; when stopped early it holds the best found so far.
    """
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    project = project or (lambda x: np.minimum(np.maximum(x, lower), upper))
    rng = np.random.default_rng(settings.seed)
    positions, velocities, limit = _initial_swarm(rng, lower, upper, n_points, settings, seeds)
    positions = project(positions)
    values = _screened(objective(positions), positions, np.full(len(positions), np.inf), admissible)
    personal, personal_values = positions.copy(), values.copy()
    leader = int(np.argmin(values))
    best, best_value = positions[leader].copy(), float(values[leader])
    history = np.empty(settings.iterations)
    cancelled = False
    done = 0
    for iteration in range(1, settings.iterations + 1):
        r1, r2 = rng.random((2,) + positions.shape)
        velocities *= inertia(iteration, settings)
        velocities += _attraction(positions, personal, best, r1, r2, settings)
        np.maximum(velocities, -limit, out=velocities)
        np.minimum(velocities, limit, out=velocities)
        moved = positions + velocities
        positions = project(moved)
        velocities[positions != moved] = 0.0
        values = _screened(_scores(objective, positions, personal_values), positions, personal_values, admissible)
        improved = values < personal_values
        personal[improved] = positions[improved]
        personal_values[improved] = values[improved]
        leader = int(np.argmin(personal_values))
        if personal_values[leader] < best_value:
            best, best_value = personal[leader].copy(), float(personal_values[leader])
        history[iteration - 1] = best_value
        done = iteration
        if progress is not None and progress(iteration, best_value, best):
            cancelled = iteration < settings.iterations
            break
    evaluations = settings.population * (done + 1)
    return SwarmResult(best, best_value, history[:done], evaluations, cancelled)


# The strategy: the paper's swarm on a sampling problem, started from the uniform layouts.
SIGNIFICANT_MM = 1e-9
PSO_DEFAULTS = {
    "population": 25, "iterations": 3000, "w1": 0.5, "w2": 0.0, "c1": 2.0, "c2": 2.0,
    "velocity_limit": 0.1, "start_from_uniform": True,
}
PSO_SETTINGS = (Setting("iterations", int, "PSO iterations (default 3000, the paper's)"),
                Setting("population", int, "PSO particles (default 25, the paper's)"))


def run_pso(problem: SamplingProblem, progress: Progress | None, population: int, iterations: int, w1: float,
            w2: float, c1: float, c2: float, velocity_limit: float, start_from_uniform: bool) -> StrategyOutcome:
    """The paper's PSO (eq. 7-9) on the problem's maximum-deviation objective.

    The swarm scores point sets by the expanded deviation (cmmsampling.fitting.deviation). With
    start_from_uniform, particles 0 and 1 start at the uniform parametric and uniform Cartesian
    layouts (the latter where it covers the face), and the swarm's best is judged against them by
    the exact deviation, so the result is never worse than either. progress, where given, is told
    the exact figure the result would report (:class:`ExactProgress`), not the swarm's estimate.
    """
    settings = SwarmSettings(population, iterations, w1, w2, c1, c2, velocity_limit, problem.seed)
    seeds = _uniform_seeds(problem) if start_from_uniform else {}
    starts = [uv for uv, _ in seeds.values()]
    objective = problem.swarm_objective()
    watched = None if progress is None else ExactProgress(problem, progress, starts, iterations)
    swarm = particle_swarm(
        objective, problem.domain.lower, problem.domain.upper, problem.n, settings,
        seeds=starts, project=problem.project, progress=watched,
        admissible=problem.spaced if problem.min_spacing > 0 else None,
    )
    if not np.isfinite(swarm.best_value):
        raise InputError(
            f"no particle kept its points {problem.min_spacing:g} mm apart ({problem.spacing_advice()}) or "
            "use start_from_uniform=True")
    notes, details = _process_notes(problem, objective)
    if swarm.cancelled:
        return StrategyOutcome(swarm.best, swarm.history, swarm.evaluations, True, details=details, notes=notes)
    best, exact_notes = _best_exact(problem, swarm.best, seeds)
    return StrategyOutcome(best, swarm.history, swarm.evaluations, False, details=details, notes=notes + exact_notes)


class ExactProgress:
    """What a watched swarm reports: after each iteration, progress(iteration, maximum mm), where
    maximum is the exact deviation (the figure the result reports, the smaller of the swarm's
    best and the seed layouts) of the best point set judged so far.

    Judging costs far more than an iteration, so the best is judged again only once it has
    changed, and at most so often that judging takes about JUDGING_SHARE of the run's time (and
    not more often than every MIN_INTERVAL_S); the last iteration's best is always judged, so the
    last figure reported is the result's. problem: SamplingProblem; progress: callable
    (iteration, mm) -> True to stop; seeds: layouts (N, 2) the result may fall back on;
    iterations: the swarm's last iteration.
    """

    JUDGING_SHARE = 0.05
    MIN_INTERVAL_S = 0.5

    def __init__(self, problem: SamplingProblem, progress: Progress, seeds: Sequence[np.ndarray],
                 iterations: int) -> None:
        self.problem, self.progress, self.iterations = problem, progress, iterations
        self.floor = min((problem.exact_maximum(uv) for uv in seeds), default=np.inf)
        self.maximum: float | None = None
        self.judged_value: float | None = None
        self.next_time = 0.0

    def __call__(self, iteration: int, best_value: float, best: np.ndarray) -> bool | None:
        """Judge the swarm's best where due; returns what progress returns."""
        now = time.perf_counter()
        due = now >= self.next_time or iteration == self.iterations
        if best_value != self.judged_value and due:
            self.judged_value = best_value
            self.maximum = min(self.problem.exact_maximum(best), self.floor)
            spent = time.perf_counter() - now
            self.next_time = now + max(self.MIN_INTERVAL_S, spent / self.JUDGING_SHARE)
        return self.progress(iteration, self.maximum if self.maximum is not None else self.floor)


def _process_notes(problem: SamplingProblem,
                   objective: DeviationObjective | TwoProcessObjective) -> tuple[list[str], dict[str, Any]]:
    """(notes, details) on the processes that scored the swarm: details {"processes": 1 or 2},
    2 when the second process took part; a note when it was asked for (workers=2) but could not
    help, with the reason."""
    used = 2 if getattr(objective, "remote", 0) > 0 else 1
    if hasattr(objective, "check_worker"):
        objective.check_worker()
    fallback = getattr(objective, "fallback", None)
    notes = [f"the swarm ran in this process alone, with the same result, only slower: {fallback}"] \
        if problem.workers == 2 and fallback else []
    return notes, {"processes": used}


def _uniform_seeds(problem: SamplingProblem) -> dict[str, tuple[np.ndarray, list[str]]]:
    """{label: (uv (N, 2), notes)} of the uniform layouts that fit the face (uniform Cartesian
    may refuse), as their strategies deliver them: with the points OCC finds off the face moved
    onto it and notes saying so (blind.onto_face)."""
    found = layouts(problem, required=UNIFORM_LAYOUTS[:1], optional=UNIFORM_LAYOUTS[1:])
    return {STRATEGIES[name].label: blind.onto_face(problem, uv) for name, uv in found.items()}


def _best_exact(problem: SamplingProblem, found: np.ndarray,
                seeds: dict[str, tuple[np.ndarray, list[str]]]) -> tuple[np.ndarray, list[str]]:
    """The swarm's best point set, or a seed layout where that is better by the exact deviation
    (said in a note, as is a best that is a seed layout itself, unchanged), each as it is delivered (the swarm's best with the points OCC finds off the face moved onto
    it, blind.onto_face), so that the figures a note quotes are the result's.

    found: (N, 2); seeds: {name: (uv (N, 2), notes)} the uniform layouts it started from (or none).
    Returns (uv (N, 2), notes).
    """
    names = list(seeds)
    delivered = [blind.onto_face(problem, found), *seeds.values()]
    unmoved = [name for name, (uv, _) in seeds.items() if np.array_equal(uv, found)]
    if unmoved:
        uv, notes = seeds[unmoved[0]]
        return uv, [f"the swarm found no layout its measure ranks above its {unmoved[0]} start, which is "
                    "returned unchanged; more iterations, or the optimal strategy (a descent from that "
                    "start), may do better", *notes]
    maxima = [problem.exact_maximum(uv) for uv, _ in delivered]
    best = int(np.argmin(maxima))
    if maxima[best] >= maxima[0] - SIGNIFICANT_MM:
        return delivered[0]
    uv, notes = delivered[best]
    return uv, [f"the swarm ended no better than its {names[best - 1]} start ({maxima[best]:.4g} mm "
                f"against {maxima[0]:.4g} mm); that layout is returned", *notes]


def _pso_memory(n: int, poles: tuple[int, int], nodes: int, options: dict[str, Any], workers: int) -> int:
    """PSO fits its whole swarm at once: about 1.25 (P/W, K, K) float64 arrays and the fits'
    lattice tables (at most LATTICE_LIMIT_BYTES) in each of its W processes, and each process
    beyond the first holds a copy of the problem (bytes)."""
    count = poles[0] * poles[1]
    share = -(-options["population"] // workers)
    return (workers * (10 * share * count ** 2 + LATTICE_LIMIT_BYTES)
            + (workers - 1) * (memory.FIXED_BYTES + 16 * count ** 2))


def _check_pso_options(options: dict[str, Any]) -> dict[str, Any]:
    """Validate PSO options (already merged with defaults); returns the cleaned dict."""
    clean = dict(options)
    clean["population"] = check_int("population", options["population"], 2)
    clean["iterations"] = check_int("iterations", options["iterations"], 1)
    clean["w1"] = check_real("w1", options["w1"], 0.0, 1.2)
    clean["w2"] = check_real("w2", options["w2"], 0.0, 1.2)
    if clean["w2"] > clean["w1"]:
        raise InputError(f"inertia must decrease: w1 ({clean['w1']}) must be >= w2 ({clean['w2']})")
    clean["c1"] = check_real("c1", options["c1"], 0.0)
    clean["c2"] = check_real("c2", options["c2"], 0.0)
    clean["velocity_limit"] = check_real("velocity_limit", options["velocity_limit"], maximum=1.0, above=0.0)
    clean["start_from_uniform"] = bool(options["start_from_uniform"])
    return clean


RECORD = Strategy(
    "pso", run_pso, "the paper's particle swarm optimisation of the maximum deviation",
    "PSO (paper)", PSO_DEFAULTS, _check_pso_options, optimiser=True, progress_unit="iteration",
    progress_total="iterations", figures=True, settings=PSO_SETTINGS, memory=_pso_memory)
