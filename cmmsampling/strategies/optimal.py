"""Near-optimal probe points: gradient descent on a smooth surrogate of the maximum deviation.

For a point set uv: (N, 2) the substitute's poles C solve (B^T B + lam R) C = B^T Q with Q the face's
points at uv. The surrogate is the log-sum-exp  f = log(sum_g exp(tau d_g)) / tau  of the node
deviations d_g, which tends to max_g d_g as tau grows. The d_g are the exact deviations of the
best point set so far, linearised about its substitute (cmmsampling.fitting.deviation.Linearisation:
exact there in value and gradient). The gradient of f with respect to every (u_i, v_i) follows
from one adjoint solve A Z = B_g^T (s E / d) (s: the softmax weights; E: d_g times its direction):

    df/du_i = r_i . (dB_i/du Z) + y_i . (dQ_i/du - dB_i/du C),    r = Q - B C,  y = B Z,

and likewise for v. L-BFGS-B minimises it over the (u, v) box in stages of rising tau
(tau = kappa / current maximum, kappa from 10 to 10000), each in chunks from the best point set
so far: a chunk's best iterate is judged by the exact maximum and kept only if it is better,
and the linearisation then moves there (:func:`descend`). The best point set that keeps the
points at least ``min_spacing`` mm apart is returned; a quadratic penalty on closer pairs steers
the descent.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from scipy.optimize import minimize
from scipy.spatial import cKDTree
from scipy.special import logsumexp, softmax

from ..fitting.exact import Linearisation
from ..geometry.bspline import kron_rows
from ..geometry.validation import check_choice, check_int, check_real, check_uv
from . import blind
from .registry import STRATEGIES, Progress, Setting, Strategy, StrategyOutcome, layouts
from .settings import BEST_STARTS

if TYPE_CHECKING:
    from ..fitting.deviation import DeviationObjective
    from ..fitting.exact import ExactDeviation
    from .problem import SamplingProblem

KAPPAS = (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0)
STAGE_ITERATIONS = 800
CHUNK_ITERATIONS = 400
MIN_CHUNK_ITERATIONS = 5
# A run told where to stop (stop_at, a search for the fewest points) and given a time limit ends
# early when, this share of the limit in, its maximum is still this many times stop_at: measured
# on the Ventilator's faces, no run that far off after 30 % of its time met stop_at by its end
# (they fall by 3 to 14 times in the rest at most), and such runs took a quarter of a plan's time.
HOPELESS_AFTER = 0.3
HOPELESS_FACTOR = 20.0


class Stop(Exception):
    """Raised inside the objective to end the descent (budget spent or cancelled)."""


@dataclass
class Surrogate:
    """Value, gradient and true maximum of the smoothed objective at one point set."""

    value: float
    gradient: np.ndarray
    maximum: float
    closest: float


def surrogate(objective: Linearisation, uv: np.ndarray, tau: float, min_spacing: float = 0.0,
              penalty: float = 0.0) -> Surrogate:
    """Log-sum-exp surrogate of the maximum deviation and its exact gradient.

    objective: a Linearisation (model, space, grid_error, grid_transpose);
    uv: (N, 2); tau: 1/mm; min_spacing: mm; penalty: weight (mm per
    mm^2 of violation) of sum over pairs closer than min_spacing of (min_spacing - distance)^2.
    Returns a Surrogate with gradient (N, 2) in mm per parameter unit.
    """
    model, space = objective.model, objective.space
    d = model.derivatives(uv, 1)
    q, q_u, q_v = d[(0, 0)], d[(1, 0)], d[(0, 1)]
    bu, bv = space.bases(uv, 1)
    rows, rows_u, rows_v = kron_rows(bu[0], bv[0]), kron_rows(bu[1], bv[0]), kron_rows(bu[0], bv[1])
    lhs = space.normal_matrix(bu[0].T, bv[0].T)
    poles = np.linalg.solve(lhs, rows.T @ q)
    error, distance, inside = objective.grid_error(poles)
    scaled = tau * distance[inside]
    value = logsumexp(scaled) / tau
    weights = np.zeros_like(distance)
    weights[inside] = softmax(scaled)
    adjoint = np.linalg.solve(lhs, objective.grid_transpose(error * (weights / np.maximum(distance, 1e-300))))
    residual = q - rows @ poles
    back = rows @ adjoint
    gradient = np.column_stack([
        ((rows_u @ adjoint) * residual).sum(1) + (back * (q_u - rows_u @ poles)).sum(1),
        ((rows_v @ adjoint) * residual).sum(1) + (back * (q_v - rows_v @ poles)).sum(1),
    ])
    spacing_value, spacing_gradient, closest = _spacing_penalty(q, min_spacing, penalty)
    gradient += np.column_stack([(spacing_gradient * q_u).sum(1), (spacing_gradient * q_v).sum(1)])
    return Surrogate(value + spacing_value, gradient, float(distance[inside].max()), closest)


def _spacing_penalty(points: np.ndarray, min_spacing: float, weight: float) -> tuple[float, np.ndarray, float]:
    """Penalty on pairs closer than min_spacing: (value, d value / d points (N, 3), closest mm).

    value = weight * sum over pairs i < j of max(min_spacing - |p_i - p_j|, 0)^2. The close pairs
    come from a neighbour search (memory linear in N). Coincident points have no direction to be
    pushed apart; they add no gradient (and, being closer than min_spacing, are never accepted as
    a result)."""
    if len(points) < 2:
        return 0.0, np.zeros_like(points), np.inf
    tree = cKDTree(points)
    closest = float(tree.query(points, k=2)[0][:, 1].min())
    if weight <= 0 or min_spacing <= 0:
        return 0.0, np.zeros_like(points), closest
    pairs = tree.query_pairs(min_spacing, output_type="ndarray")
    gaps = points[pairs[:, 0]] - points[pairs[:, 1]]
    distance = np.sqrt((gaps ** 2).sum(-1))
    short = np.maximum(min_spacing - distance, 0.0)
    value = weight * float((short ** 2).sum())
    factor = np.where(distance > 0, -2.0 * weight * short / np.where(distance > 0, distance, 1.0), 0.0)
    push = factor[:, None] * gaps
    gradient = np.zeros_like(points)
    for axis in range(3):
        gradient[:, axis] = (np.bincount(pairs[:, 0], push[:, axis], len(points))
                             - np.bincount(pairs[:, 1], push[:, axis], len(points)))
    return value, gradient, closest


@dataclass
class DescentResult:
    """uv: (N, 2) best feasible point set; maximum: its maximum deviation (mm); history: best
    maximum after each evaluation; evaluations; cancelled; closest: smallest point distance (mm);
    hopeless: the run ended early, too far from stop_at to reach it (:func:`_hopeless`)."""

    uv: np.ndarray
    maximum: float
    history: np.ndarray
    evaluations: int
    cancelled: bool
    closest: float
    hopeless: bool = False


def descend(objective: DeviationObjective, start: np.ndarray, lower: np.ndarray, upper: np.ndarray,
            judge: Callable[[np.ndarray], ExactDeviation], min_spacing: float = 0.0, time_limit: float | None = None,
            max_evaluations: int | None = None, progress: Progress | None = None,
            project: Callable[[np.ndarray], np.ndarray] | None = None, began: float | None = None,
            stop_at: float | None = None) -> DescentResult:
    """Minimise the maximum deviation from the point set ``start`` (N, 2) inside the box.

    objective: DeviationObjective (its face model and substitute space);
    judge: uv (N, 2) -> the ExactDeviation (cmmsampling.fitting.exact) of its substitute at the
    objective's nodes;
    lower, upper: (2,) parameter box; project: maps uv (N, 2) onto the feasible set (every
    iterate is evaluated there; default: the box itself); min_spacing: mm between points; time_limit: s
    from ``began`` (a time.perf_counter() value, default: now); max_evaluations: surrogate evaluations; progress: callable (evaluation, best_max_mm) returning
    True to stop; stop_at: mm, end the descent as soon as the best exact maximum is at most this
    (None: never; the start itself may be enough), and early where it cannot get there in time
    (:func:`_hopeless`). Returns a DescentResult: the point set of
    smallest exact maximum seen among those that keep min_spacing (the start if none is better).

    The descent runs in chunks of L-BFGS-B iterations from the best point set so far, on the exact
    deviations linearised about its substitute (cmmsampling.fitting.deviation.Linearisation: exact there
    in value and gradient); the chunk's best iterate is then judged exactly and accepted only if
    it is better. Chunks shrink after a failure and grow after a success (:func:`_stage`).
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    scale = upper - lower
    start = np.asarray(start, dtype=float)
    began = time.perf_counter() if began is None else began
    best = _Best.judged(start, judge(start), objective,
                        _spacing_penalty(objective.model.points(start), min_spacing, 0.0)[2])
    tally = _Tally()
    penalty = 100.0 * best.maximum / max(min_spacing, 1e-12) ** 2

    def fun(x: np.ndarray, tau: float, chunk: _Chunk) -> tuple[float, np.ndarray]:
        uv = lower + x.reshape(-1, 2) * scale
        if project is not None:
            uv = project(uv)
        s = surrogate(best.model, uv, tau, min_spacing, penalty)
        tally.count += 1
        if s.maximum < chunk.maximum and s.closest >= min_spacing:
            chunk.uv, chunk.maximum, chunk.closest = uv.copy(), s.maximum, s.closest
        tally.history.append(best.maximum)
        stopped = progress is not None and progress(tally.count, best.maximum)
        elapsed = time.perf_counter() - cast(float, began)   # set above: the closure sees it as passed
        tally.hopeless = _hopeless(best.maximum, stop_at, elapsed, time_limit)
        out_of_budget = (max_evaluations is not None and tally.count >= max_evaluations) or (
            time_limit is not None and elapsed >= time_limit)
        if stopped or out_of_budget or tally.hopeless or _enough(best, stop_at):
            tally.cancelled = bool(stopped)
            raise Stop
        return s.value, (s.gradient * scale).ravel()

    def run_chunk(tau: float, length: int) -> bool:
        """One chunk of ``length`` iterations from the best point set; True when it improved on it."""
        chunk = _Chunk()
        try:
            minimize(fun, ((best.uv - lower) / scale).ravel(), args=(tau, chunk), jac=True,
                     method="L-BFGS-B", bounds=[(0.0, 1.0)] * start.size,
                     options={"maxiter": length, "ftol": 1e-15, "gtol": 1e-12})
        finally:
            if not tally.cancelled:
                _accept(chunk, best, judge, objective)
        return best.uv is chunk.uv

    try:
        for kappa in KAPPAS:
            if _enough(best, stop_at):
                break
            _stage(lambda length: run_chunk(kappa / max(best.maximum, 1e-12), length))
    except Stop:
        pass
    return DescentResult(best.uv, best.maximum, np.array(tally.history), tally.count, tally.cancelled, best.closest,
                         tally.hopeless)


@dataclass
class _Best:
    """A descent's best point set: uv (N, 2), its exact maximum deviation (mm), the deviations
    linearised about its substitute (model) and its smallest point distance (mm)."""

    uv: np.ndarray
    maximum: float
    model: Linearisation
    closest: float

    @classmethod
    def judged(cls, uv: np.ndarray, exact: ExactDeviation, objective: DeviationObjective, closest: float) -> _Best:
        """uv (N, 2) as the best point set, exact: the ExactDeviation of its substitute."""
        return cls(uv, exact.maximum, Linearisation(objective.model, objective.space, exact), closest)

    def take(self, other: _Best) -> None:
        """Make other the best point set."""
        self.uv, self.maximum, self.model, self.closest = other.uv, other.maximum, other.model, other.closest


@dataclass
class _Chunk:
    """The best iterate of one chunk of a descent: uv (N, 2) or None yet, its surrogate maximum
    (mm) and its smallest point distance (mm)."""

    uv: np.ndarray | None = None
    maximum: float = np.inf
    closest: float = np.inf


@dataclass
class _Tally:
    """A descent's course: surrogate evaluations, the best maximum (mm) after each, whether
    progress cancelled it and whether it ended hopeless (:func:`_hopeless`)."""

    count: int = 0
    history: list[float] = field(default_factory=list)
    cancelled: bool = False
    hopeless: bool = False


def _hopeless(maximum: float, stop_at: float | None, elapsed: float, time_limit: float | None) -> bool:
    """True when a run with both a stop_at and a time_limit (s) is HOPELESS_AFTER of its time in
    (elapsed s) and its best maximum (mm) is still over HOPELESS_FACTOR times stop_at (mm)."""
    return (stop_at is not None and time_limit is not None and elapsed >= HOPELESS_AFTER * time_limit
            and maximum > HOPELESS_FACTOR * stop_at)


def _enough(best: _Best, stop_at: float | None) -> bool:
    """True when the best point set's exact maximum (mm) is at most stop_at (mm, None: never)."""
    return stop_at is not None and best.maximum <= stop_at


def _stage(run_chunk: Callable[[int], bool]) -> None:
    """One stage: chunks of up to CHUNK_ITERATIONS iterations, halved after a chunk that does not
    improve (the linearisation was trusted too far) and doubled after one that does, until
    STAGE_ITERATIONS are spent or a chunk of MIN_CHUNK_ITERATIONS fails."""
    length, spent = CHUNK_ITERATIONS, 0
    while spent < STAGE_ITERATIONS:
        improved = run_chunk(length)
        spent += length
        if not improved and length <= MIN_CHUNK_ITERATIONS:
            return
        length = min(2 * length, CHUNK_ITERATIONS) if improved else max(length // 2, MIN_CHUNK_ITERATIONS)


def _accept(chunk: _Chunk, best: _Best, judge: Callable[[np.ndarray], ExactDeviation],
            objective: DeviationObjective) -> None:
    """Judge the chunk's best iterate exactly; make it the best point set, linearised about its
    substitute, when it is better."""
    if chunk.uv is None:
        return
    judged = judge(chunk.uv)
    if judged.maximum < best.maximum:
        best.take(_Best.judged(chunk.uv, judged, objective, chunk.closest))


# The strategy: the descent on a sampling problem, from the best blind layout.
OPTIMAL_DEFAULTS = {"start": "best", "time_limit": None, "max_evaluations": None, "stop_at": None}
OPTIMAL_SETTINGS = (Setting("time_limit", float, "seconds the optimal strategy may take (default: until it "
                                                 "converges; in a plan 10 s per run)"),)


def run_optimal(problem: SamplingProblem, progress: Progress | None, start: str | np.ndarray, time_limit: float | None,
                max_evaluations: int | None, stop_at: float | None) -> StrategyOutcome:
    """Near-optimal points by gradient descent on a smoothed maximum (see cmmsampling.strategies.optimal).

    start: "best" (the best of BEST_STARTS by the exact deviation), a strategy name or an (N, 2)
    uv array; time_limit: s from the call, choosing the start included (the descent stops there;
    the result is judged after it); max_evaluations: surrogate evaluations (None: no limit);
    stop_at: mm, stop as soon as the exact maximum is at most this (None: never; a search for
    the fewest points that meet a tolerance needs no more, cmmsampling.points_needed). Points keep
    problem.min_spacing and the feasible domain: a start that does not is repaired first (its
    crowded points moved to free places). The result is never worse than the start; ``notes`` say
    what was done.
    """
    began = time.perf_counter()
    notes = []
    if isinstance(start, str):
        start_uv, name = _start_layout(problem, start, time_limit is not None)
        notes.append(f"started from the {name} layout")
    else:
        start_uv = check_uv(start, problem.n)
    start_uv, moved = blind.respace(problem, problem.project(start_uv))
    objective = problem.objective
    result = descend(objective, start_uv, problem.domain.lower, problem.domain.upper,
                     problem.exact, problem.min_spacing, time_limit, max_evaluations,
                     progress, problem.project, began, stop_at)
    if moved:
        notes.append(f"the start had points closer than min_spacing {problem.min_spacing:.3g} mm: "
                     f"{moved} of them were moved to free places before the descent")
    if stop_at is not None and result.maximum <= stop_at:
        notes.append(f"stopped once the maximum deviation was at most stop_at = {stop_at:g} mm")
    elif result.hopeless:
        notes.append(f"stopped after {HOPELESS_AFTER:.0%} of the time limit, still over {HOPELESS_FACTOR:g} times "
                     f"stop_at = {stop_at:g} mm: too far to reach it in the time left")
    elif result.uv is start_uv and not result.cancelled:
        notes.append("the descent found no point set better than its start; the start is returned")
    return StrategyOutcome(result.uv, result.history, result.evaluations, result.cancelled,
                           details={"closest": result.closest}, notes=notes)


def _start_layout(problem: SamplingProblem, start: str, bounded: bool) -> tuple[np.ndarray, str]:
    """(uv (N, 2), name) of the start named ``start``; for "best", the BEST_STARTS layout of
    smallest maximum deviation (layouts a strategy refuses for this face are skipped): judged
    exactly, or, for a run bounded in time (``bounded``), by the swarm's expansion
    (cmmsampling.fitting.deviation: a few per cent of the exact figure, all the layouts in one
    call), since four exact judgements took up to 3 s of a 5 s run on small faces."""
    found = layouts(problem, optional=BEST_STARTS) if start == "best" else layouts(problem, required=(start,))
    names = list(found)
    if len(names) == 1:
        return found[names[0]], names[0]
    maxima: np.ndarray | list[float]
    if bounded:
        maxima = problem.objective(np.stack([problem.project(found[name]) for name in names]))
    else:
        maxima = [problem.exact_maximum(found[name]) for name in names]
    name = names[int(np.argmin(maxima))]
    return found[name], name


def _optimal_memory(n: int, poles: tuple[int, int], nodes: int, options: dict[str, Any], workers: int) -> int:
    """The descent's linearisation: (N, K) rows with their two derivatives and (G, K) grid rows."""
    count = poles[0] * poles[1]
    return 8 * count * (3 * n + nodes)


def _check_optimal_options(options: dict[str, Any]) -> dict[str, Any]:
    """Validate the options of the 'optimal' strategy (merged with defaults)."""
    clean = dict(options)
    if options["time_limit"] is not None:
        clean["time_limit"] = check_real("time_limit", options["time_limit"], above=0.0)
    if options["max_evaluations"] is not None:
        clean["max_evaluations"] = check_int("max_evaluations", options["max_evaluations"], 1)
    if options["stop_at"] is not None:
        clean["stop_at"] = check_real("stop_at", options["stop_at"], minimum=0.0)
    if isinstance(options["start"], str):
        starts = ["best"] + [name for name, entry in STRATEGIES.items() if not entry.optimiser and not entry.requires]
        check_choice("start", options["start"], starts)
    return clean


RECORD = Strategy(
    "optimal", run_optimal,
    "gradient descent on a smoothed maximum deviation, to a local optimum",
    "optimal (this project)", OPTIMAL_DEFAULTS, _check_optimal_options, optimiser=True,
    progress_unit="surrogate evaluation", progress_total="max_evaluations", figures=True,
    settings=OPTIMAL_SETTINGS, memory=_optimal_memory)
