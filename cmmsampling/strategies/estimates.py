"""Estimates of a sample() run made before it starts: its peak memory and its time; durations in words."""
from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from ..access.probe import Probe
from ..fitting.deviation import DEFAULT_GRID
from ..fitting.substitute import DEFAULT_DEGREE
from ..geometry.freecad_env import import_part
from ..geometry.validation import check_choice
from ..runtime.threads import blas_threads
from .registry import STRATEGIES, StrategyOutcome, strategy_options
from .sampling import DEFAULT_STRATEGY, _baseline_uv, _exact_outcome, _judge, make_problem, memory_bytes
from .settings import Pair, SampleSettings
from .space_choice import chosen_space

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from .problem import SamplingProblem
else:
    Part = import_part()

# Swarms timed by time_needed (the first one warms the caches and is not counted).
TIMED_SWARMS = 4
# Exact judgings after an optimiser's run: its best and the (up to two) uniform layouts it
# started from (the result's own judging reuses the best's).
JUDGINGS = 3


def memory_needed(n: int, strategy: str | None = DEFAULT_STRATEGY, *, fit_degree: Pair = DEFAULT_DEGREE,
                  fit_poles: Pair | None = None, grid: Pair = DEFAULT_GRID, workers: int | None = None,
                  **options: Any) -> int:
    """Estimated peak memory (bytes) of :func:`sample` with these arguments, before any run.

    The arguments as in :func:`sample` (strategy None: what every run needs). sample() refuses
    a run whose estimate exceeds 80 % of the memory the machine has free (cmmsampling.runtime.memory).
    """
    settings = SampleSettings.checked(n, fit_degree=fit_degree, fit_poles=fit_poles, grid=grid, workers=workers)
    checked = strategy_options(strategy, options) if strategy is not None else {}
    return memory_bytes(settings, strategy, checked)


def time_needed(face: Part.Face, n: int = 81, strategy: str = DEFAULT_STRATEGY, *, fit_degree: Pair = DEFAULT_DEGREE,
                fit_poles: Pair | None = None, grid: Pair = DEFAULT_GRID, edge_offset: float = 0.0,
                min_spacing: float | None = None, workers: int | None = None, part: Part.Shape | None = None,
                probe: Probe | None = None, occ_check: bool = True, **options: Any) -> float | None:
    """Estimated seconds of :func:`sample` with these arguments on this face, before the run.

    The problem is built (as sample() builds it, the probe's reach on ``part`` included: that
    time counts) and what follows the placing of the points is timed once on the baseline
    layout: the choice of the substitute's space, the judging (the fit, the exact deviation,
    OCC's cross-check where occ_check, the probe's pose at each point). For an optimiser the
    objective it iterates is timed on a few random swarms; its cost times the strategy's
    progress steps (PSO: iterations over the processes that will share them, see
    :func:`sharing_processes`) is added, twice where sample() runs it in a coarser space too
    (:func:`cmmsampling.strategies.space_choice.chosen_space` prefers one for the baseline
    layout), with the exact judgings of its runs (JUDGINGS, one timed); nothing where the baseline
    layout fits the face exactly (the optimiser is not run). None when the number of steps is
    not known in advance (the optimal strategy without max_evaluations or time_limit: until it
    converges). Raises what sample() would raise for these arguments. On a machine that gets
    busier during the run it takes longer: the panels' progress gives the time left from the
    run's own pace. benchmarks/first_run_estimate.py measures how it holds on a first run.
    """
    check_choice("strategy", strategy, list(STRATEGIES))
    entry = STRATEGIES[strategy]
    options = strategy_options(strategy, options)
    start = time.perf_counter()
    problem = make_problem(face, n, fit_degree=fit_degree, fit_poles=fit_poles, grid=grid, workers=workers,
                           edge_offset=edge_offset, min_spacing=min_spacing, strategy=strategy,
                           options=options, part=part, probe=probe)
    uv = _baseline_uv(problem)
    spaces = 1 if problem.settings.poles_given or chosen_space(problem, problem, uv)[0] is problem else 2
    with blas_threads(1):
        _judge(problem, StrategyOutcome(uv), strategy, {}, 0.0, occ_check)
    built_s = time.perf_counter() - start
    if not entry.optimiser or _exact_outcome(problem, strategy, uv) is not None:
        return built_s
    built_s += spaces * JUDGINGS * _judging_seconds(problem, uv)
    if options.get("time_limit") is not None:
        return built_s + spaces * options["time_limit"]
    steps = entry.progress_steps(options)
    if steps is None:
        return None
    population = options.get("population", 1)
    swarm = problem.project(np.random.default_rng(0).uniform(
        problem.domain.lower, problem.domain.upper, (TIMED_SWARMS, population, n, 2)))
    with blas_threads(1):
        _one_step(problem, swarm[0])
        start = time.perf_counter()
        for positions in swarm[1:]:
            _one_step(problem, positions)
    per_step = (time.perf_counter() - start) / (TIMED_SWARMS - 1) / sharing_processes(problem.workers)
    return built_s + spaces * steps * per_step


def sharing_processes(workers: int, load: float | None = None, cores: int | None = None) -> int:
    """How many of a run's ``workers`` processes will share its steps: all of them where the
    machine has a core free for each beside what already runs (load: the 1-minute load average,
    default the machine's; cores: default the machine's), else 1, since the default measured
    split then keeps the swarm in one process and ``workers=2`` gains nothing."""
    load = os.getloadavg()[0] if load is None else load
    cores = (os.cpu_count() or 1) if cores is None else cores
    return workers if load + workers <= cores + 0.5 else 1


def _judging_seconds(problem: SamplingProblem, uv: np.ndarray) -> float:
    """Seconds of one exact deviation (the judging of a result) on this problem, timed on the
    substitute of the layout uv (N, 2)."""
    start = time.perf_counter()
    with blas_threads(1):
        problem.exact_maximum(uv)
    return time.perf_counter() - start


def _one_step(problem: SamplingProblem, positions: np.ndarray) -> None:
    """What an optimiser's step costs: the objective of point sets positions (P, N, 2) and,
    with a spacing, their spacing check."""
    problem.objective(positions)
    if problem.min_spacing > 0:
        problem.spaced(positions)


def duration_text(seconds: float) -> str:
    """A duration in seconds in words: "under a second", "40 s" (below 2 min), "3 min" (below an
    hour), "1 h 5 min"."""
    if seconds < 1:
        return "under a second"
    if seconds < 120:
        return f"{round(seconds)} s"
    minutes = round(seconds / 60)
    return f"{minutes} min" if minutes < 60 else f"{minutes // 60} h {minutes % 60} min"


def about_text(seconds: float) -> str:
    """An estimated duration in seconds in words: "about 40 s", or "under a second"."""
    return f"{'' if seconds < 1 else 'about '}{duration_text(seconds)}"


def time_left_text(seconds: float) -> str:
    """"about 40 s left", or "under a second left", for the time a run still needs (seconds)."""
    return f"{about_text(seconds)} left"
