"""The scripting entry points: :func:`sample` runs a strategy, :func:`evaluate` judges any point set.

The built-in strategies' records (blind, pso, optimal, part_error) are registered here, in the order the
tables and panels list them; the registry's names are the public ones (``__all__``)."""
from __future__ import annotations

import time
from dataclasses import asdict
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..access.probe import Probe, check_probe
from ..access.reach import EXACT_SECONDS, Reachability
from ..fitting.crosscheck import occ_cross_check
from ..fitting.deviation import DEFAULT_GRID, DeviationStats
from ..fitting.occ_surface import substitute_surface
from ..fitting.substitute import DEFAULT_DEGREE, DEFAULT_SMOOTHING
from ..geometry.domain import face_domain
from ..geometry.freecad_env import import_part
from ..geometry.surface import lies_on
from ..geometry.validation import InputError, InputTypeError, check_choice, check_real, check_uv
from ..runtime import memory
from ..runtime.threads import blas_threads
from . import blind, optimal, part_error, pso
from .face_setup import setup_of
from .problem import SamplingProblem
from .registry import (STRATEGIES, Progress, Setting, Strategy, StrategyOutcome, baseline, register_strategy,
                       self_contained, strategy_label, strategy_options, unregister_strategy)
from .result import EXACT_FIT, SamplingResult
from .space_choice import chosen_space
from .settings import (BALL_SEPARATION_MM, BEST_STRATEGY, DEFAULT_STRATEGY, KEYWORDS, MIN_POINTS, Pair, SampleSettings,
                       default_min_spacing, resolve_fit_poles)

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from ..fitting.bound import MinimaxBound
    from ..geometry.surface import SurfaceModel
else:
    Part = import_part()

__all__ = ["STRATEGIES", "Setting", "Strategy", "StrategyOutcome", "register_strategy", "unregister_strategy",
           "strategy_label", "strategy_options", "baseline", "self_contained", "SampleSettings", "make_problem",
           "problem_for", "sample", "evaluate", "lower_bound", "probe_edge_offset", "check_arguments",
           "DEFAULT_STRATEGY", "BEST_STRATEGY", "PROBE_EDGE_OFFSET_MM", "MIN_POINTS", "Progress"]

# sample()'s keyword arguments that every strategy takes (the others are the strategy's options):
# those SampleSettings checks whatever the face, and these.
COMMON_ARGUMENTS = KEYWORDS + ("progress", "occ_check", "part", "probe")
MIN_AREA_RATIO = 1e-12


for _record in (*blind.RECORDS, pso.RECORD, optimal.RECORD, part_error.RECORD):
    register_strategy(_record)
# The edge offset the command line and the panel start with, mm: a probe ball's radius plus
# a margin (sample() itself defaults to 0, the paper's setting).
PROBE_EDGE_OFFSET_MM = 1.5


def make_problem(face: Part.Face, n: int, *, strategy: str | None = None, options: dict | None = None,
                 part: Part.Shape | None = None, probe: Probe | None = None, out_of_reach: np.ndarray | None = None,
                 **settings: Any) -> SamplingProblem:
    """Validate the common inputs and build a SamplingProblem (see :func:`sample`).

    settings: sample()'s common settings by name (fit_degree, fit_poles, smoothing, grid, seed,
    workers, edge_offset, min_spacing), checked once into a SampleSettings; min_spacing defaults
    to 0 here (any spacing: a given point set is judged as it is), None asks for sample()'s
    default; the rest as in :func:`problem_for`.
    """
    settings.setdefault("min_spacing", 0.0)
    checked = SampleSettings.checked(n, **settings)
    return problem_for(face, checked, strategy=strategy, options=options, part=part, probe=probe,
                       out_of_reach=out_of_reach)


def problem_for(face: Part.Face, settings: SampleSettings, *, strategy: str | None = None,
                options: dict | None = None, part: Part.Shape | None = None,
                probe: Probe | None = None, out_of_reach: np.ndarray | None = None) -> SamplingProblem:
    """The SamplingProblem of checked settings on a face.

    min_spacing None: the default (cmmsampling.strategies.settings.default_min_spacing), lowered where the
    face's feasible part cannot hold N points that far apart. strategy, options (checked): the
    run it is for, whose memory is checked (:func:`memory_needed`) before anything is built;
    None checks every run's base. part, probe: as in :func:`sample`; out_of_reach: instead,
    where a probe was found not to reach the face before (Access.out_of_reach, (K, 4) parameter
    rectangles), left out of the judged part of the face again.
    """
    _check_memory(settings, strategy, options or {})
    setup = setup_of(face)
    model = setup.model
    _check_area(model)
    reachability = reachability_of(part, probe, model.source_face)
    domain = setup.domain(settings.edge_offset, reachability, out_of_reach)
    by_default = settings.min_spacing is None
    min_spacing = (default_min_spacing(model.area, settings.n, domain.feasible_area) if by_default
                   else cast(float, settings.min_spacing))
    problem = SamplingProblem(model, settings, domain, min_spacing=min_spacing, spacing_by_default=by_default,
                              reachability=reachability)
    _check_room(problem)
    return problem


def check_arguments(strategy: str, arguments: dict, n: int = MIN_POINTS) -> None:
    """InputError (or InputTypeError) naming the first of sample()'s arguments it would refuse
    whatever the face, before a plan or a search runs any: the strategy, its options, the common
    settings, part= and probe=. arguments: sample()'s keyword arguments other than face, n and
    strategy (the options among them); n: the points of the runs to come."""
    check_choice("strategy", strategy, list(STRATEGIES))
    strategy_options(strategy, {name: value for name, value in arguments.items() if name not in COMMON_ARGUMENTS})
    SampleSettings.checked(n, **{name: arguments[name] for name in KEYWORDS if name in arguments})
    check_probe(arguments.get("probe"))


def reachability_of(part: Part.Shape | Reachability | None, probe: Probe | None,
                    face: Part.Face) -> Reachability | None:
    """The Reachability of a probe on a part (part itself when it is one), None without a part;
    TypeError for a part that is no shape or a probe that is no Probe, InputError for a part
    that face (a Part.Face) is not on."""
    if part is None:
        if probe is not None:
            raise InputError("a probe is checked against the part its face belongs to: give part= (the "
                             "solid or shape) with probe=")
        return None
    if isinstance(part, Reachability):
        if probe is not None and probe != part.probe:
            raise InputError("part= is a Reachability with its own probe; give no other probe=")
        _refuse_off_part(part.part, part.holds(face))
        return part
    if not isinstance(part, Part.Shape) or part.isNull() or not part.Faces:
        raise InputTypeError(f"part must be the Part.Shape the face belongs to (a solid, a shell), got {part!r}")
    check_probe(probe)
    _refuse_off_part(part, lies_on(face, part))
    return Reachability(part, probe)


def _refuse_off_part(part: Part.Shape, on: bool) -> None:
    """InputError unless the face lies on part (a Part.Shape), as ``on`` says: the probe's reach would
    be judged on another part."""
    if not on:
        box = part.BoundBox
        raise InputError(f"the face is not on part= (a part within x {box.XMin:.4g}..{box.XMax:.4g}, y "
                         f"{box.YMin:.4g}..{box.YMax:.4g}, z {box.ZMin:.4g}..{box.ZMax:.4g} mm); give the shape "
                         "the face belongs to")


def memory_bytes(settings: SampleSettings, strategy: str | None, options: dict) -> int:
    """Estimated bytes of a run (see :func:`memory_needed`); strategy and options checked."""
    cells = settings.grid[0] * settings.grid[1]
    needed = memory.base_bytes(settings.fit_poles, cells)
    entry = STRATEGIES.get(strategy) if strategy is not None else None
    if entry is not None and entry.memory is not None:
        needed += entry.memory(settings.n, settings.fit_poles, cells, options, settings.workers)
    return needed


def _check_memory(settings: SampleSettings, strategy: str | None, options: dict) -> None:
    """ValueError, before anything is built, when the run would not fit in the free memory."""
    needed = memory_bytes(settings, strategy, options)
    poles = settings.fit_poles
    what = f"{strategy or 'the fit'}, a substitute of {poles[0]} x {poles[1]} poles"

    def largest_n(free: float) -> int | None:
        low, high = MIN_POINTS, settings.n
        if memory_bytes(settings.with_n(low), strategy, options) > free:
            return None
        while low < high:
            middle = (low + high + 1) // 2
            if memory_bytes(settings.with_n(middle), strategy, options) <= free:
                low = middle
            else:
                high = middle - 1
        return low
    memory.check_fits(needed, settings.n, largest_n, what)


UNREACHABLE_FACE = ("the probe reaches no point of this face on the part (a face the part rests on, or one its "
                    "own material hides): to measure it choose a probe with a longer or thinner stylus or a head "
                    "that tilts further (max_tilt), or measure it in a second set-up with the part turned; to plan "
                    "it anyway, plan without the probe (Probe: none; part= left out)")


def _check_room(problem: SamplingProblem) -> None:
    """ValueError when the face cannot hold N points with the edge offset and spacing asked for,
    or the probe reaches none of them."""
    domain = problem.domain
    if domain.empty and problem.reachability is not None and not face_domain(problem.model,
                                                                              domain.edge_offset).empty:
        raise InputError(UNREACHABLE_FACE)
    if domain.empty:
        raise InputError(
            f"the face is too narrow for edge_offset {domain.edge_offset:g} mm: none of its points "
            f"is farther than {domain.reach + domain.margin:.2g} mm from its edges; edge_offset "
            f"{_round_down(domain.reach):g} mm fits (measured to within {domain.margin:.2g} mm)")
    if problem.min_spacing > 0:
        room = int(domain.feasible_area / (np.sqrt(3) / 2 * problem.min_spacing ** 2)) + 1
        if problem.n > room:
            raise InputError(
                f"{problem.n} points {problem.min_spacing:g} mm apart do not fit on the "
                f"{domain.feasible_area:.4g} mm^2 of the face that keeps edge_offset "
                f"{domain.edge_offset:g} mm (at most about {room}); {problem.spacing_advice()}")


def _round_down(value: float) -> float:
    """value (mm, >= 0) rounded down to two significant digits, 0 for none left."""
    if value <= 0:
        return 0.0
    scale = 10.0 ** (np.floor(np.log10(value)) - 1)
    return float(f"{np.floor(value / scale) * scale:.2g}")


def _check_area(model: SurfaceModel) -> None:
    """ValueError for a face (its SurfaceModel) without usable area."""
    diagonal = model.diagonal
    if not np.isfinite(model.area) or model.area <= MIN_AREA_RATIO * max(diagonal, 1e-300) ** 2:
        raise InputError(
            f"the face has no usable area ({model.area:.3g} mm^2 for a {diagonal:.3g} mm bounding box); "
            "pick a face that is not degenerate"
        )


def sample(face: Part.Face, n: int = 81, strategy: str = DEFAULT_STRATEGY, *, fit_degree: Pair = DEFAULT_DEGREE,
           fit_poles: Pair | None = None, smoothing: float = DEFAULT_SMOOTHING, grid: Pair = DEFAULT_GRID,
           seed: int = 0, progress: Progress | None = None, occ_check: bool = True, workers: int | None = None,
           edge_offset: float = 0.0, min_spacing: float | None = None, part: Part.Shape | None = None,
           probe: Probe | None = None, **options: Any) -> SamplingResult:
    """Place n probe points on a face with a strategy and judge them.

    face: a Part.Face (or a Shape holding one face), e.g. ``cmmsampling.reference_face()``;
    n: number of probe points (>= 4); strategy: a key of :data:`STRATEGIES`;
    fit_degree, fit_poles: degree and pole count of the substitute B-spline per direction
    (an int or a (u, v) pair; poles default to round(2 sqrt(n) / 3)); smoothing: relative weight
    of its second-difference smoothing; grid: evaluation raster (int or pair, default 60 x 60);
    seed: for random parts; progress: callable (iteration, best_max_mm) for the optimisers, returning
    True to stop (the best so far is kept); occ_check: cross-check the final maximum with OCC;
    workers: processes the optimisers spread each swarm over (1 or 2; None: 2 on a multi-core
    machine where they are faster, measured as the run goes, else 1; the results are identical); edge_offset: mm every point keeps from the face's edges
    (3D; 0, the paper's setting, allows points on the edges); min_spacing: mm between any two
    points (None: a tenth of the even spacing sqrt(area / n), at least 0.1 mm, lowered where the
    face cannot hold N points that far apart; 0 allows any); part: the Part.Shape the face
    belongs to (a solid), or a cmmsampling.access.reach.Reachability of it (kept for many runs),
    whose other faces may block the probe: the face's points the probe
    cannot reach become infeasible, and each final point's probe pose is measured with OCC
    (``result.access``); probe: a cmmsampling.Probe (default: a 2 mm ball on a 20 mm stylus);
    options: the strategy's own (see ``STRATEGIES[name].options``; PSO: population, iterations, w1,
    w2, c1, c2, velocity_limit, start_from_uniform).
    Returns a SamplingResult.
    """
    check_choice("strategy", strategy, list(STRATEGIES))
    options = strategy_options(strategy, options)
    settings = SampleSettings.checked(n, fit_degree=fit_degree, fit_poles=fit_poles, smoothing=smoothing, grid=grid,
                                      seed=seed, workers=workers, edge_offset=edge_offset, min_spacing=min_spacing)
    problem = problem_for(face, settings, strategy=strategy, options=options, part=part, probe=probe)
    start = time.perf_counter()
    default = problem
    with blas_threads(1):
        start_uv = _baseline_uv(problem) if STRATEGIES[strategy].optimiser else None
        outcome = None if start_uv is None else _exact_outcome(problem, strategy, start_uv)
        if outcome is None:
            problem, outcome = _run_in_spaces(problem, strategy, progress, options, start_uv)
        _move_onto_face(problem, outcome)
        if not settings.poles_given:
            problem, note = chosen_space(default, problem, outcome.uv)
            outcome.notes += [note] if note else []
    outcome.notes += _fit_notes(problem) + _spacing_notes(problem)
    strategy_s = time.perf_counter() - start
    recorded = {"strategy": strategy, "n": problem.n, **_common_settings(problem),
                **_json_friendly({**options, **outcome.details})}
    return _judge(problem, outcome, strategy, recorded, strategy_s, occ_check)


def _baseline_uv(problem: SamplingProblem) -> np.ndarray:
    """The baseline blind layout (registry.baseline) on the problem's face: (N, 2) uv."""
    name = baseline()
    return STRATEGIES[name].run(problem, None, **STRATEGIES[name].options).uv


def _run_in_spaces(problem: SamplingProblem, strategy: str, progress: Progress | None, options: dict[str, Any],
                   start_uv: np.ndarray | None) -> tuple[SamplingProblem, StrategyOutcome]:
    """The strategy's outcome and the problem it was placed for. An optimiser with the default
    poles runs in the default space and, where its baseline layout (``start_uv``, (N, 2), given
    for an optimiser) holds a coarser space better (space_choice.chosen_space: points that cannot
    spread over the face), there too, unless the first run was cancelled; the run whose points' substitute is nearer the face (exactly, on the
    grid) is kept, with a note on the other. Either space can win: on the Ventilator's Face61 the
    optimum in the default 5 x 5 space is 4x better than in the 5 x 4 one uniform points prefer,
    on its Face58 with the probe the coarser space's is 6x better."""
    outcome = STRATEGIES[strategy].run(problem, progress, **options)
    if start_uv is None or problem.settings.poles_given or outcome.cancelled:
        return problem, outcome
    coarser = chosen_space(problem, problem, start_uv)[0]
    if coarser is problem:
        return problem, outcome
    other = STRATEGIES[strategy].run(coarser, _never_above(progress, outcome.history), **options)
    runs = sorted([(problem.exact_maximum(outcome.uv), 0, problem, outcome),
                   (coarser.exact_maximum(other.uv), 1, coarser, other)], key=lambda run: run[:2])
    (kept, _, chosen, best), (lost, _, loser, beaten) = runs
    best.evaluations += beaten.evaluations
    best.notes.append(f"also placed for a {loser.space.poles[0]} x {loser.space.poles[1]} substitute: its maximum "
                      f"deviation on the evaluation grid was {lost:.4g} mm, this one's {kept:.4g} mm")
    return chosen, best


def _never_above(progress: Progress | None, history: np.ndarray | None) -> Progress | None:
    """``progress`` for a second run, the best it is told never above the first run's best
    (``history``: its best maximum per iteration, mm), so that the best shown never rises."""
    if progress is None or history is None or not len(history):
        return progress
    told, floor = progress, float(np.min(history))
    return lambda iteration, best: told(iteration, min(best, floor))


def _exact_outcome(problem: SamplingProblem, strategy: str, start_uv: np.ndarray) -> StrategyOutcome | None:
    """For an optimiser on a face the substitute reproduces exactly (a plane, a face of the fit's
    own space): its baseline layout ``start_uv`` (N, 2) with a note, since no point set can do
    better; otherwise None, and the optimiser runs."""
    if problem.exact_maximum(start_uv) > EXACT_FIT * problem.model.diagonal:
        return None
    return StrategyOutcome(start_uv, notes=[f"{strategy} was not run: the {STRATEGIES[baseline()].label} layout "
                                            "already fits this face exactly"])


def probe_edge_offset(face: Part.Face, cap: float | None = None) -> float:
    """The edge offset (mm) the panel and the command line start with on this face.

    cap (mm, default PROBE_EDGE_OFFSET_MM: a probe ball's radius plus a margin) where the face
    is wide enough; on a narrower face (a strip, a blade) half the largest clearance any of its
    points has from the edges, rounded down to two digits, which leaves a band for the points.
    face: a Part.Face.
    """
    cap = PROBE_EDGE_OFFSET_MM if cap is None else check_real("cap", cap, 0.0)
    if cap == 0:
        return 0.0
    reach = setup_of(face).domain(cap).reach
    return cap if reach >= 2 * cap else _round_down(0.5 * reach)


def _move_onto_face(problem: SamplingProblem, outcome: StrategyOutcome) -> None:
    """Move the outcome's points that lie off the face (OCC) onto it (blind.onto_face), with
    notes saying so."""
    outcome.uv, notes = blind.onto_face(problem, outcome.uv)
    outcome.notes += notes


def _fit_notes(problem: SamplingProblem) -> list[str]:
    """Sentences on a substitute with more poles than points: between the points its shape then
    comes from the smoothing, not from the measurement."""
    poles = problem.space.poles
    if poles[0] * poles[1] <= problem.n:
        return []
    usual = resolve_fit_poles(None, problem.n, cast("tuple[int, int]", tuple(problem.space.degrees)))
    return [f"the substitute has {poles[0]} x {poles[1]} poles for {problem.n} points: between the "
            f"points its shape comes from the smoothing, not from the measurement (the default for "
            f"{problem.n} points is {usual[0]} x {usual[1]})"]


def _spacing_notes(problem: SamplingProblem) -> list[str]:
    """A sentence where the default spacing had to go below BALL_SEPARATION_MM: the face has no
    room for N points that far apart, and a ball may then touch one spot twice."""
    if not problem.spacing_by_default or problem.min_spacing >= BALL_SEPARATION_MM:
        return []
    return [f"the face has no room for {problem.n} points {BALL_SEPARATION_MM:g} mm apart: they keep "
            f"{problem.min_spacing:.3g} mm, and a probe ball may touch nearly one spot twice; lower n to keep them apart"]


def _json_friendly(options: dict[str, Any]) -> dict[str, Any]:
    """Options with arrays (e.g. a start layout) replaced by lists, for settings and documents."""
    return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in options.items()}


def lower_bound(face: Part.Face, n: int = 81, *, fit_degree: Pair = DEFAULT_DEGREE, fit_poles: Pair | None = None,
                smoothing: float = DEFAULT_SMOOTHING, grid: Pair = DEFAULT_GRID, check: bool = False) -> MinimaxBound:
    """The local bound about the reference fit on this face (cmmsampling.fitting.bound): the least
    first-order maximum deviation that reshaping the fit to very many points along its normals
    reaches. A yardstick, not a lower bound of what n points can reach: point sets reach other
    surfaces of the substitute space, and results may end below it.

    The substitute space (fit_degree, fit_poles from n) and grid as in :func:`sample`; check=True
    uses the check grid (3x denser). Returns a MinimaxBound: ``lower`` (mm), ``upper`` (a reshaped
    surface that reaches it within ``gap``), ``converged``.
    """
    problem = make_problem(face, n, fit_degree=fit_degree, fit_poles=fit_poles, smoothing=smoothing, grid=grid)
    with blas_threads(1):
        return problem.bounds()["check" if check else "grid"]


def evaluate(face: Part.Face, uv: np.ndarray, *, strategy: str = "given", fit_degree: Pair = DEFAULT_DEGREE,
             fit_poles: Pair | None = None, smoothing: float = DEFAULT_SMOOTHING, grid: Pair = DEFAULT_GRID,
             occ_check: bool = True, part: Part.Shape | None = None, probe: Probe | None = None,
             out_of_reach: np.ndarray | None = None) -> SamplingResult:
    """Judge a given point set: fit the substitute to the face's points at uv and measure it.

    uv: (N, 2) parameters on the face (as in SamplingResult.uv); part and probe: the probe's
    pose at each point judged on the part (``result.access``); out_of_reach: instead of part
    and probe, where a run found the probe cannot reach (its result's access.out_of_reach):
    the deviation is measured over the rest of the face, as that run's was; the other arguments
    as in :func:`sample`. Returns a SamplingResult labelled with ``strategy``.
    """
    uv = check_uv(uv)
    problem = make_problem(face, len(uv), fit_degree=fit_degree, fit_poles=fit_poles, smoothing=smoothing, grid=grid,
                           part=part, probe=probe, out_of_reach=out_of_reach)
    settings = {"strategy": strategy, "n": problem.n, **_common_settings(problem)}
    return _judge(problem, StrategyOutcome(uv), strategy, settings, 0.0, occ_check, given=True)


def measure_reach(result: SamplingResult, given: bool = False) -> None:
    """The probe's pose at each of a result's points, measured with OCC (result.access), its
    settings, and notes on the area out of reach and the points tilted, refused or left to the
    fast test; for a result of a run with part= (sample does it, unless its Reachability was
    ``unmeasured``). given: the points were given (:func:`evaluate`), not placed by a strategy
    that kept out of the unreached area."""
    started = time.perf_counter()
    problem = result.problem
    assert problem is not None and problem.reachability is not None   # a run with part=, as its callers' are
    result.access, refused, unmeasured = problem.reachability.final(result.points, result.normals)
    assert result.access is not None   # final() returns an Access
    result.access.unreached = problem.domain.unreached_rectangles()
    result.access.unreached_area = problem.domain.unreached_area
    result.access.out_of_reach = problem.domain.out_of_reach_rectangles()
    result.settings["probe"] = asdict(problem.reachability.probe)
    obstacles = problem.reachability.obstacles
    if obstacles.coarsened:
        result.notes.append(f"the part is large: it was modelled by points {obstacles.spacing:.2g} mm apart, so the "
                            f"probe's clearance was judged with a {obstacles.margin:.2g} mm margin (erring on the "
                            "side of blocking)")
    if problem.domain.unreached_area > 0:
        result.notes.append(_unreached_note(result, given))
    tilted = result.access.tilted
    if tilted.any():
        result.notes.append(f"{tilted.sum()} of {result.n} points are reached only with the stylus tilted: the head's "
                            f"orientation nearest their normal is blocked (up to {result.access.tilts[tilted].max():.1f} "
                            "deg off the normal)")
    blocked = np.flatnonzero(~result.access.reachable)
    if blocked.size:
        names = ", ".join(f"P{k + 1}" for k in blocked[:10]) + (" ..." if blocked.size > 10 else "")
        result.notes.append(f"{blocked.size} point(s) cannot be reached by the probe without touching the part "
                            f"elsewhere ({names}): measured with OCC at the final points")
    if unmeasured:
        result.notes.append(f"{unmeasured} point(s) whose stylus or body passes near the part were judged by the fast "
                            f"test only (OCC's checks took their {EXACT_SECONDS:g} s): it errs on the side of blocking")
    result.timings["reach_s"] = time.perf_counter() - started


def _common_settings(problem: SamplingProblem) -> dict[str, Any]:
    """The fit and grid settings of a problem, JSON-friendly."""
    return {
        "fit_degree": list(problem.space.degrees),
        "fit_poles": list(problem.space.poles),
        "smoothing": problem.space.smoothing,
        "grid": list(problem.grid.size),
        "seed": problem.seed,
        "workers": problem.workers,
        "edge_offset": problem.domain.edge_offset,
        "min_spacing": problem.min_spacing,
    }


def _unreached_note(result: SamplingResult, given: bool) -> str:
    """The note on the area of the face the probe cannot reach: that no point was placed there,
    or for given points how many lie there (result.access.unreached: (K, 4) rectangles u0, u1, v0,
    v1 of the face's parameters)."""
    problem = result.problem
    # measure_reach, the caller, has set them (unreached: unreached_rectangles() is an array)
    assert problem is not None and result.access is not None and result.access.unreached is not None
    area = problem.domain.unreached_area
    text = (f"the probe cannot reach {area:.4g} mm^2 of the face ({100 * area / problem.model.area:.3g} %) "
            "without touching the part elsewhere")
    if not given:
        return text + ": no point was placed there"
    u, v, boxes = result.uv[:, :1], result.uv[:, 1:], result.access.unreached
    inside = int(((u >= boxes[:, 0]) & (u <= boxes[:, 1]) & (v >= boxes[:, 2]) & (v <= boxes[:, 3])).any(1).sum())
    if not inside:
        return text + ": none of the given points lies there"
    return text + f": {inside} of the {result.n} given points {'lies' if inside == 1 else 'lie'} there"


def _judge(problem: SamplingProblem, outcome: StrategyOutcome, strategy: str, settings: dict[str, Any],
           strategy_s: float, occ_check: bool, given: bool = False) -> SamplingResult:
    """Points, normals, fit and deviation statistics for a strategy's outcome; given: the points
    were given, not placed by the strategy (:func:`evaluate`)."""
    start = time.perf_counter()
    uv = np.asarray(outcome.uv, dtype=float)
    with blas_threads(1):
        poles = problem.objective.fit(uv[None])[0]
        exact = problem.judge(poles)
        stats = DeviationStats.from_exact(exact, problem.space)
    evaluation_s = time.perf_counter() - start
    result = SamplingResult(
        strategy=strategy, uv=uv, points=problem.model.points(uv), normals=problem.model.normals(uv),
        poles=poles, space=problem.space, deviation=stats, model=problem.model,
        history=outcome.history, evaluations=outcome.evaluations, settings=settings,
        cancelled=outcome.cancelled, problem=problem, notes=list(outcome.notes),
    )
    occ_s = 0.0
    if occ_check:
        start = time.perf_counter()
        occ_cross_check(stats, exact, substitute_surface(problem.space, poles), problem.model.source_face,
                        problem.space, problem.counts)
        stats.maximum = stats.occ_maximum
        occ_s = time.perf_counter() - start
    result.timings = {"strategy_s": strategy_s, "evaluation_s": evaluation_s, "occ_check_s": occ_s,
                      "total_s": strategy_s + evaluation_s + occ_s}
    if problem.reachability is not None and problem.reachability.measures:
        measure_reach(result, given)
    if result.exact:
        result.notes.append(
            f"the substitute reproduces this face exactly (maximum deviation {stats.maximum:.1e} mm, "
            "a millionth of its size at most): it lies in the fit's space, e.g. a plane, so any point "
            "set is as good as another and optimising cannot improve it")
    return result
