"""The scripting entry points: :func:`sample` runs a strategy, :func:`evaluate` judges any point set."""
import os
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from ..access.probe import Probe
from ..access.reach import Reachability
from ..fitting.crosscheck import occ_cross_check
from ..fitting.deviation import DEFAULT_GRID, DeviationStats
from ..fitting.occ_surface import substitute_surface
from ..fitting.substitute import DEFAULT_DEGREE, DEFAULT_SMOOTHING
from ..geometry.domain import face_domain
from ..geometry.freecad_env import import_part
from ..geometry.surface import SurfaceModel
from ..geometry.validation import check_choice, check_int, check_pair, check_real, check_uv
from . import blind, handover, memory
from .blind import StrategyOutcome
from .optimal import default_min_spacing, descend
from .problem import SamplingProblem, resolve_fit_poles
from .pso import SwarmSettings, particle_swarm
from .result import EXACT_FIT, SamplingResult
from .threads import blas_threads

Part = import_part()

MIN_POINTS = 4
SIGNIFICANT_MM = 1e-9
MIN_AREA_RATIO = 1e-12
# Swarms timed by time_needed (the first one warms the caches and is not counted).
TIMED_SWARMS = 4


@dataclass(frozen=True)
class Setting:
    """An option of a strategy that the command line and the comparison panel offer.

    option: its keyword in sample(); kind: int or float; help: one line, with its unit.
    """

    option: str
    kind: type
    help: str


@dataclass(frozen=True)
class Strategy:
    """Everything the project knows of one strategy, said once; every other module reads it here.

    name: the identifier sample() takes; run: (problem, progress, **options) -> StrategyOutcome;
    description: one line (tooltips, --help); label: its name in tables, figures and reports;
    options: its own options with their defaults; check: options (merged with the defaults) ->
    the cleaned options, raising ValueError or TypeError, or None when any value goes;
    optimiser: it searches with the objective and reports progress (iteration, best max mm);
    progress_unit: what one of those progress steps is; progress_total: the option that says how
    many there will be (None: unknown in advance); seeded: its points depend on the seed, so a
    study runs it once per seed; figures: the report draws its deviation histogram; reference:
    a layout the others are drawn against in the convergence figures; baseline: the layout the
    studies' and tables' ratios divide by (one strategy has it);
    settings: the options the command line and the comparison panel offer (Setting);
    memory: (n, poles (n_u, n_v), grid nodes, options, workers) -> bytes it needs beyond every
    run's base (cmmsampling.strategies.memory), None for nothing that grows with N.
    Every strategy keeps the same default minimum spacing (cmmsampling.strategies.optimal.default_min_spacing).
    """

    name: str
    run: object
    description: str
    label: str
    options: dict = field(default_factory=dict)
    check: object = None
    optimiser: bool = False
    progress_unit: str = "step"
    progress_total: str = None
    seeded: bool = False
    figures: bool = False
    reference: bool = False
    baseline: bool = False
    settings: tuple = ()
    memory: object = None

    def checked_options(self, options):
        """The defaults updated by ``options``, validated: TypeError for an option it does not take."""
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            takes = ", ".join(self.options) or "no options"
            raise TypeError(f"strategy {self.name!r} does not take {', '.join(unknown)}; it takes {takes}")
        merged = {**self.options, **options}
        return self.check(merged) if self.check else merged

    def progress_steps(self, options):
        """How many progress steps a run with ``options`` (given ones; the rest default) will
        report, or None when that is not known in advance."""
        if self.progress_total is None:
            return None
        return options.get(self.progress_total, self.options.get(self.progress_total))


def _blind(function):
    """Adapter: a blind strategy ignores progress and takes no options."""
    return lambda problem, progress: function(problem)


def run_pso(problem, progress, population, iterations, w1, w2, c1, c2, velocity_limit,
            start_from_uniform):
    """The paper's PSO (eq. 7-9) on the problem's maximum-deviation objective.

    The swarm scores point sets by the expanded deviation (cmmsampling.fitting.deviation). With
    start_from_uniform, particles 0 and 1 start at the uniform parametric and uniform Cartesian
    layouts (the latter where it covers the face), and the swarm's best is judged against them by
    the exact deviation, so the result is never worse than either.
    """
    settings = SwarmSettings(population, iterations, w1, w2, c1, c2, velocity_limit, problem.seed)
    seeds = _uniform_seeds(problem) if start_from_uniform else {}
    objective = problem.swarm_objective()
    swarm = particle_swarm(
        objective, problem.domain.lower, problem.domain.upper, problem.n, settings,
        seeds=list(seeds.values()), project=problem.project, progress=progress,
        admissible=problem.spaced if problem.min_spacing > 0 else None,
    )
    if not np.isfinite(swarm.best_value):
        raise ValueError(
            f"no particle kept its points {problem.min_spacing:g} mm apart ({problem.spacing_advice()}) or "
            "use start_from_uniform=True")
    notes, details = _process_notes(problem, objective)
    if swarm.cancelled:
        return StrategyOutcome(swarm.best, swarm.history, swarm.evaluations, True, details=details, notes=notes)
    best, exact_notes = _best_exact(problem, swarm.best, seeds)
    return StrategyOutcome(best, swarm.history, swarm.evaluations, False, details=details, notes=notes + exact_notes)


def _process_notes(problem, objective):
    """(notes, details) on the processes that scored the swarm: details {"processes": 1 or 2},
    2 when the second process took part; a note when it was asked for (workers=2) but could not
    help, with the reason."""
    used = 2 if getattr(objective, "remote", 0) > 0 else 1
    fallback = getattr(objective, "fallback", None)
    notes = [f"the swarm ran in this process alone, with the same result, only slower: {fallback}"] \
        if problem.workers == 2 and fallback else []
    return notes, {"processes": used}


def _uniform_seeds(problem):
    """{label: uv (N, 2)} of the uniform layouts that fit the face (uniform Cartesian may refuse)."""
    layouts = _layouts(problem, required=("uniform_parametric",), optional=("uniform_cartesian",))
    return {STRATEGIES[name].label: uv for name, uv in layouts.items()}


def _layouts(problem, required=(), optional=()):
    """{name: uv (N, 2)} of the named strategies' layouts with their default options, in the order
    given; a refusal (ValueError) of a required one is raised, an optional one is left out."""
    layouts = {}
    for name in (*required, *optional):
        try:
            layouts[name] = STRATEGIES[name].run(problem, None, **STRATEGIES[name].options).uv
        except ValueError:
            if name in required:
                raise
    return layouts


def _best_exact(problem, found, seeds):
    """The swarm's best point set, or a seed layout where that is better by the exact deviation.

    found: (N, 2); seeds: {name: (N, 2)} the uniform layouts it started from (or none).
    Returns (uv (N, 2), notes).
    """
    names = list(seeds)
    maxima = [problem.exact_maximum(uv) for uv in [found, *seeds.values()]]
    best = int(np.argmin(maxima))
    if maxima[best] >= maxima[0] - SIGNIFICANT_MM:
        return found, []
    return seeds[names[best - 1]], [f"the swarm ended no better than its {names[best - 1]} start "
                                    f"({maxima[best]:.4g} mm against {maxima[0]:.4g} mm); that layout is returned"]


def run_optimal(problem, progress, start, time_limit, max_evaluations):
    """Near-optimal points by gradient descent on a smoothed maximum (see cmmsampling.strategies.optimal).

    start: "best" (the best of BEST_STARTS by the exact deviation), a strategy name or an (N, 2)
    uv array; time_limit: s; max_evaluations: surrogate evaluations (None: no limit). Points keep
    problem.min_spacing and the feasible domain: a start that does not is repaired first (its
    crowded points moved to free places). The result is never worse than the start; ``notes`` say
    what was done.
    """
    notes = []
    if isinstance(start, str):
        start_uv, name = _start_layout(problem, start)
        notes.append(f"started from the {name} layout")
    else:
        start_uv = check_uv(start, problem.n)
    start_uv, moved = blind.respace(problem, problem.project(start_uv))
    objective = problem.objective
    result = descend(objective, start_uv, problem.domain.lower, problem.domain.upper,
                     problem.exact, problem.min_spacing, time_limit, max_evaluations,
                     progress, problem.project)
    if moved:
        notes.append(f"the start had points closer than min_spacing {problem.min_spacing:.3g} mm: "
                     f"{moved} of them were moved to free places before the descent")
    if result.uv is start_uv and not result.cancelled:
        notes.append("the descent found no point set better than its start; the start is returned")
    return StrategyOutcome(result.uv, result.history, result.evaluations, result.cancelled,
                           details={"closest": result.closest}, notes=notes)


def _start_layout(problem, start):
    """(uv (N, 2), name) of the start named ``start``; for "best", the BEST_STARTS layout of
    smallest exact maximum deviation (layouts a strategy refuses for this face are skipped)."""
    layouts = _layouts(problem, optional=BEST_STARTS) if start == "best" else _layouts(problem, required=(start,))
    if len(layouts) == 1:
        return next(iter(layouts.values())), next(iter(layouts))
    name = min(layouts, key=lambda key: problem.exact_maximum(layouts[key]))
    return layouts[name], name


def _pso_memory(n, poles, nodes, options, workers):
    """PSO fits its whole swarm at once: about 1.25 (P/W, K, K) float64 arrays in each of its W
    processes, and each process beyond the first holds a copy of the problem (bytes)."""
    count = poles[0] * poles[1]
    share = -(-options["population"] // workers)
    return workers * 10 * share * count ** 2 + (workers - 1) * (memory.FIXED_BYTES + 16 * count ** 2)


def _optimal_memory(n, poles, nodes, options, workers):
    """The descent's linearisation: (N, K) rows with their two derivatives and (G, K) grid rows."""
    count = poles[0] * poles[1]
    return 8 * count * (3 * n + nodes)


def _check_optimal_options(options):
    """Validate the options of the 'optimal' strategy (merged with defaults)."""
    clean = dict(options)
    if options["time_limit"] is not None:
        clean["time_limit"] = check_real("time_limit", options["time_limit"], above=0.0)
    if options["max_evaluations"] is not None:
        clean["max_evaluations"] = check_int("max_evaluations", options["max_evaluations"], 1)
    if isinstance(options["start"], str):
        starts = ["best"] + [name for name, entry in STRATEGIES.items() if not entry.optimiser]
        check_choice("start", options["start"], starts)
    return clean


def _check_pso_options(options):
    """Validate PSO options (already merged with defaults); returns the cleaned dict."""
    clean = dict(options)
    clean["population"] = check_int("population", options["population"], 2)
    clean["iterations"] = check_int("iterations", options["iterations"], 1)
    clean["w1"] = check_real("w1", options["w1"], 0.0, 1.2)
    clean["w2"] = check_real("w2", options["w2"], 0.0, 1.2)
    if clean["w2"] > clean["w1"]:
        raise ValueError(f"inertia must decrease: w1 ({clean['w1']}) must be >= w2 ({clean['w2']})")
    clean["c1"] = check_real("c1", options["c1"], 0.0)
    clean["c2"] = check_real("c2", options["c2"], 0.0)
    clean["velocity_limit"] = check_real("velocity_limit", options["velocity_limit"], maximum=1.0, above=0.0)
    clean["start_from_uniform"] = bool(options["start_from_uniform"])
    return clean


OPTIMAL_DEFAULTS = {"start": "best", "time_limit": None, "max_evaluations": None}
BEST_STARTS = ("uniform_parametric", "uniform_cartesian", "halton", "hammersley")

PSO_DEFAULTS = {
    "population": 25, "iterations": 3000, "w1": 0.5, "w2": 0.0, "c1": 2.0, "c2": 2.0,
    "velocity_limit": 0.1, "start_from_uniform": True,
}
PSO_SETTINGS = (Setting("iterations", int, "PSO iterations (default 3000, the paper's)"),
                Setting("population", int, "PSO particles (default 25, the paper's)"))
OPTIMAL_SETTINGS = (Setting("time_limit", float, "seconds the optimal strategy may take (default: until it "
                                                 "converges)"),)

STRATEGIES = {}


def register_strategy(strategy):
    """Add a Strategy record (replacing one of the same name): sample(), compare(), the report, the
    command line and both panels offer it from then on. Returns the record."""
    if not isinstance(strategy, Strategy):
        raise TypeError(f"register takes a cmmsampling Strategy record, got {type(strategy).__name__}")
    STRATEGIES[strategy.name] = strategy
    return strategy


def unregister_strategy(name):
    """Remove the strategy named ``name`` (KeyError when there is none)."""
    del STRATEGIES[name]


for _record in (
    Strategy("uniform_cartesian", _blind(blind.uniform_cartesian),
             "regular grid over the face's footprint in machine X/Y/Z (paper eq. 3-4)",
             "uniform Cartesian", figures=True, reference=True),
    Strategy("uniform_parametric", _blind(blind.uniform_parametric),
             "regular grid in the face's (u, v) (paper eq. 5-6)", "uniform parametric",
             figures=True, reference=True, baseline=True),
    Strategy("random", _blind(blind.random_uniform), "uniform random (u, v), seeded", "random",
             seeded=True),
    Strategy("hammersley", _blind(blind.hammersley), "Hammersley set in (u, v)", "Hammersley"),
    Strategy("halton", _blind(blind.halton), "Halton sequence in (u, v), bases 2 and 3", "Halton"),
    Strategy("curvature_mean", _blind(blind.curvature_adaptive),
             "more points on patches of high mean curvature", "mean curvature"),
    Strategy("curvature_gaussian", _blind(blind.curvature_gaussian),
             "more points on patches of high Gaussian curvature", "Gaussian curvature"),
    Strategy("pso", run_pso, "the paper's particle swarm optimisation of the maximum deviation",
             "PSO (paper)", PSO_DEFAULTS, _check_pso_options, optimiser=True, progress_unit="iteration",
             progress_total="iterations", figures=True, settings=PSO_SETTINGS, memory=_pso_memory),
    Strategy("optimal", run_optimal,
             "gradient descent on a smoothed maximum deviation, to a local optimum",
             "optimal (this project)", OPTIMAL_DEFAULTS, _check_optimal_options, optimiser=True,
             progress_unit="surrogate evaluation", progress_total="max_evaluations", figures=True,
             settings=OPTIMAL_SETTINGS, memory=_optimal_memory),
):
    register_strategy(_record)
DEFAULT_STRATEGY = "pso"
# What the command line starts with: the strategy that goes furthest.
BEST_STRATEGY = "optimal"
# The edge offset the command line and the panel start with, mm: a probe ball's radius plus
# a margin (sample() itself defaults to 0, the paper's setting).
PROBE_EDGE_OFFSET_MM = 1.5


def strategy_label(name):
    """The display name of a strategy (its record's label; the name itself for one not registered,
    e.g. a result of ``evaluate(strategy="given")``)."""
    return STRATEGIES[name].label if name in STRATEGIES else name


def baseline():
    """The name of the layout the studies' and tables' ratios divide by (its record says baseline)."""
    return next(name for name, entry in STRATEGIES.items() if entry.baseline)


def strategy_options(strategy, options):
    """The strategy's options: defaults updated by ``options``, validated.

    Raises TypeError for an option the strategy does not take (listing those it does).
    """
    return STRATEGIES[strategy].checked_options(options)


def make_problem(face, n, fit_degree=DEFAULT_DEGREE, fit_poles=None, smoothing=DEFAULT_SMOOTHING,
                 grid=DEFAULT_GRID, seed=0, workers=None, edge_offset=0.0, min_spacing=0.0,
                 strategy=None, options=None, part=None, probe=None):
    """Validate the common inputs and build a SamplingProblem (see :func:`sample`).

    min_spacing None: the default (cmmsampling.strategies.optimal.default_min_spacing), lowered where the
    face's feasible part cannot hold N points that far apart. strategy, options (checked): the
    run it is for, whose memory is checked (:func:`memory_needed`) before anything is built;
    None checks every run's base.
    """
    n = check_int("n", n, MIN_POINTS)
    degree = check_pair("fit_degree", fit_degree, 1)
    given_poles = None if fit_poles is None else check_pair("fit_poles", fit_poles, 2)
    poles = resolve_fit_poles(given_poles, n, degree)
    for axis, (d, p) in enumerate(zip(degree, poles)):
        if p < d + 1:
            raise ValueError(
                f"fit_poles along {'uv'[axis]} ({p}) must be at least fit_degree + 1 ({d + 1})"
            )
    smoothing = check_real("smoothing", smoothing, above=0.0)
    grid = check_pair("grid", grid, 2)
    seed = check_int("seed", seed, 0)
    workers = _check_workers(workers)
    _check_memory(n, degree, given_poles, grid, workers, strategy, options or {})
    edge_offset = check_real("edge_offset", edge_offset, 0.0)
    if min_spacing is not None:
        min_spacing = check_real("min_spacing", min_spacing, 0.0)
    model = SurfaceModel.from_face(face)
    _check_area(model)
    problem = SamplingProblem(model, n, degree, poles, smoothing, grid, seed, workers, edge_offset,
                              min_spacing or 0.0, _reachability(part, probe))
    if min_spacing is None:
        problem.min_spacing = default_min_spacing(model.area, n, problem.domain.feasible_area)
        problem.spacing_by_default = True
    _check_room(problem)
    return problem


def _reachability(part, probe):
    """The Reachability of a probe on a part (part itself when it is one), None without a part;
    TypeError for a part that is no shape or a probe that is no Probe."""
    if part is None:
        if probe is not None:
            raise ValueError("a probe is checked against the part its face belongs to: give part= (the "
                             "solid or shape) with probe=")
        return None
    if isinstance(part, Reachability):
        if probe is not None and probe != part.probe:
            raise ValueError("part= is a Reachability with its own probe; give no other probe=")
        return part
    if not isinstance(part, Part.Shape) or part.isNull() or not part.Faces:
        raise TypeError(f"part must be the Part.Shape the face belongs to (a solid, a shell), got {part!r}")
    if probe is not None and not isinstance(probe, Probe):
        raise TypeError(f"probe must be a cmmsampling.Probe, got {probe!r}")
    return Reachability(part, probe)


def memory_needed(n, strategy=DEFAULT_STRATEGY, *, fit_degree=DEFAULT_DEGREE, fit_poles=None,
                  grid=DEFAULT_GRID, workers=None, **options):
    """Estimated peak memory (bytes) of :func:`sample` with these arguments, before any run.

    The arguments as in :func:`sample` (strategy None: what every run needs). sample() refuses
    a run whose estimate exceeds 80 % of the memory the machine has free (cmmsampling.strategies.memory).
    """
    n = check_int("n", n, MIN_POINTS)
    degree = check_pair("fit_degree", fit_degree, 1)
    given_poles = None if fit_poles is None else check_pair("fit_poles", fit_poles, 2)
    checked = strategy_options(strategy, options) if strategy is not None else {}
    return _memory_bytes(n, degree, given_poles, check_pair("grid", grid, 2), _check_workers(workers),
                         strategy, checked)


def time_needed(face, n=81, strategy=DEFAULT_STRATEGY, *, fit_degree=DEFAULT_DEGREE, fit_poles=None,
                grid=DEFAULT_GRID, edge_offset=0.0, min_spacing=None, workers=None, part=None, probe=None,
                **options):
    """Estimated seconds of :func:`sample` with these arguments on this face, before the run.

    The problem is built (as sample() builds it, the probe's reach on ``part`` included: that
    time counts) and the objective the
    strategy iterates is timed on a few random swarms; its cost times the strategy's progress
    steps (PSO: iterations over its workers) is added. None when the number of steps is not
    known in advance (the optimal strategy without max_evaluations or time_limit: until it
    converges). Raises what sample() would raise for these arguments.
    """
    check_choice("strategy", strategy, list(STRATEGIES))
    entry = STRATEGIES[strategy]
    options = strategy_options(strategy, options)
    start = time.perf_counter()
    problem = make_problem(face, n, fit_degree, fit_poles, grid=grid, workers=workers,
                           edge_offset=edge_offset, min_spacing=min_spacing, strategy=strategy,
                           options=options, part=part, probe=probe)
    built_s = time.perf_counter() - start
    if not entry.optimiser:
        return built_s
    if options.get("time_limit") is not None:
        return built_s + options["time_limit"]
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
    per_step = (time.perf_counter() - start) / (TIMED_SWARMS - 1) / problem.workers
    return built_s + steps * per_step


def _one_step(problem, positions):
    """What an optimiser's step costs: the objective of point sets positions (P, N, 2) and,
    with a spacing, their spacing check."""
    problem.objective(positions)
    if problem.min_spacing > 0:
        problem.spaced(positions)


def _memory_bytes(n, degree, given_poles, grid, workers, strategy, options):
    """Estimated bytes of a run (see :func:`memory_needed`); arguments already checked."""
    poles = resolve_fit_poles(given_poles, n, degree)
    needed = memory.base_bytes(poles)
    entry = STRATEGIES.get(strategy)
    if entry is not None and entry.memory is not None:
        needed += entry.memory(n, poles, grid[0] * grid[1], options, workers)
    return needed


def _check_memory(n, degree, given_poles, grid, workers, strategy, options):
    """ValueError, before anything is built, when the run would not fit in the free memory.
    The arguments already checked (grid: the (g_u, g_v) pair)."""
    needed = _memory_bytes(n, degree, given_poles, grid, workers, strategy, options)
    poles = resolve_fit_poles(given_poles, n, degree)
    what = f"{strategy or 'the fit'}, a substitute of {poles[0]} x {poles[1]} poles"

    def largest_n(free):
        low, high = MIN_POINTS, n
        if _memory_bytes(low, degree, given_poles, grid, workers, strategy, options) > free:
            return None
        while low < high:
            middle = (low + high + 1) // 2
            if _memory_bytes(middle, degree, given_poles, grid, workers, strategy, options) <= free:
                low = middle
            else:
                high = middle - 1
        return low
    memory.check_fits(needed, n, largest_n, what)


def _check_room(problem):
    """ValueError when the face cannot hold N points with the edge offset and spacing asked for,
    or the probe reaches none of them."""
    domain = problem.domain
    if domain.empty and problem.reachability is not None and not face_domain(problem.model,
                                                                              domain.edge_offset).empty:
        raise ValueError("the probe reaches no point of this face on the part: choose a smaller stylus or a "
                         "larger max_tilt, or leave part= out to sample without the probe's reach")
    if domain.empty:
        raise ValueError(
            f"the face is too narrow for edge_offset {domain.edge_offset:g} mm: none of its points "
            f"is farther than {domain.reach + domain.margin:.2g} mm from its edges; edge_offset "
            f"{_round_down(domain.reach):g} mm fits (measured to within {domain.margin:.2g} mm)")
    if problem.min_spacing > 0:
        room = int(domain.feasible_area / (np.sqrt(3) / 2 * problem.min_spacing ** 2)) + 1
        if problem.n > room:
            raise ValueError(
                f"{problem.n} points {problem.min_spacing:g} mm apart do not fit on the "
                f"{domain.feasible_area:.4g} mm^2 of the face that keeps edge_offset "
                f"{domain.edge_offset:g} mm (at most about {room}); {problem.spacing_advice()}")


def _round_down(value):
    """value (mm, >= 0) rounded down to two significant digits, 0 for none left."""
    if value <= 0:
        return 0.0
    scale = 10.0 ** (np.floor(np.log10(value)) - 1)
    return float(f"{np.floor(value / scale) * scale:.2g}")


def _check_workers(workers):
    """1 or 2 processes for the optimisers; None picks 2 where the machine has 2 or more cores."""
    if workers is None:
        return 2 if (os.cpu_count() or 1) >= 2 else 1
    workers = check_int("workers", workers, 1)
    if workers > 2:
        raise ValueError(f"workers must be 1 or 2, got {workers}")
    return workers


def _check_area(model):
    """ValueError for a face (its SurfaceModel) without usable area."""
    diagonal = model.diagonal
    if not np.isfinite(model.area) or model.area <= MIN_AREA_RATIO * max(diagonal, 1e-300) ** 2:
        raise ValueError(
            f"the face has no usable area ({model.area:.3g} mm^2 for a {diagonal:.3g} mm bounding box); "
            "pick a face that is not degenerate"
        )


def sample(face, n=81, strategy=DEFAULT_STRATEGY, *, fit_degree=DEFAULT_DEGREE, fit_poles=None,
           smoothing=DEFAULT_SMOOTHING, grid=DEFAULT_GRID, seed=0, progress=None, occ_check=True,
           workers=None, edge_offset=0.0, min_spacing=None, part=None, probe=None, **options):
    """Place n probe points on a face with a strategy and judge them.

    face: a Part.Face (or a Shape holding one face), e.g. ``cmmsampling.reference_face()``;
    n: number of probe points (>= 4); strategy: a key of :data:`STRATEGIES`;
    fit_degree, fit_poles: degree and pole count of the substitute B-spline per direction
    (an int or a (u, v) pair; poles default to round(2 sqrt(n) / 3)); smoothing: relative weight
    of its second-difference smoothing; grid: evaluation raster (int or pair, default 60 x 60);
    seed: for random parts; progress: callable (iteration, best_max_mm) for the optimisers, returning
    True to stop (the best so far is kept); occ_check: cross-check the final maximum with OCC;
    workers: processes the optimisers spread each swarm over (1 or 2; None = 2 on a multi-core
    machine; the results are identical); edge_offset: mm every point keeps from the face's edges
    (3D; 0, the paper's setting, allows points on the edges); min_spacing: mm between any two
    points (None: a tenth of the even spacing sqrt(area / n), at least 5 um, lowered where the
    face cannot hold N points that far apart; 0 allows any); part: the Part.Shape the face
    belongs to (a solid), or a cmmsampling.access.reach.Reachability of it (kept for many runs),
    whose other faces may block the probe: the face's points the probe
    cannot reach become infeasible, and each final point's probe pose is measured with OCC
    (``result.access``); probe: a cmmsampling.Probe (default: a 2 mm ball on a 20 mm stylus);
    options: the strategy's own (see ``STRATEGIES[name].options``; PSO: population, iterations, w1,
    w2, c1, c2, velocity_limit, start_from_uniform).
    Returns a SamplingResult.
    """
    handed = handover.take(sample, face, {"n": n, "strategy": strategy, "fit_degree": fit_degree,
                                      "fit_poles": fit_poles, "smoothing": smoothing, "grid": grid,
                                      "seed": seed, "occ_check": occ_check, "workers": workers,
                                      "edge_offset": edge_offset, "min_spacing": min_spacing, "part": part,
                                      "probe": probe, **options})
    if handed is not None:
        return handed
    check_choice("strategy", strategy, list(STRATEGIES))
    options = strategy_options(strategy, options)
    n = check_int("n", n, MIN_POINTS)
    problem = make_problem(face, n, fit_degree, fit_poles, smoothing, grid, seed, workers, edge_offset,
                           min_spacing, strategy, options, part, probe)
    start = time.perf_counter()
    with blas_threads(1):
        outcome = _exact_outcome(problem, strategy) or STRATEGIES[strategy].run(problem, progress, **options)
    _move_onto_face(problem, outcome)
    outcome.notes += _fit_notes(problem)
    strategy_s = time.perf_counter() - start
    settings = {"strategy": strategy, "n": problem.n, **_common_settings(problem),
                **_json_friendly({**options, **outcome.details})}
    return _judge(problem, outcome, strategy, settings, strategy_s, occ_check)


def hand_over(face, arguments, result):
    """Let the next ``sample(face, **arguments)`` in this process return ``result`` at once (the
    task panel's run, echoed in the console: see :mod:`cmmsampling.strategies.handover`).

    arguments: the keyword arguments of sample() other than face and progress.
    """
    handover.give(sample, face, arguments, result)


def _exact_outcome(problem, strategy):
    """For an optimiser on a face the substitute reproduces exactly (a plane, a face of the fit's
    own space): the uniform parametric layout with a note, since no point set can do better;
    otherwise (or for a blind strategy) None, and the strategy runs."""
    if not STRATEGIES[strategy].optimiser:
        return None
    name = baseline()
    uv = STRATEGIES[name].run(problem, None, **STRATEGIES[name].options).uv
    maximum = problem.exact_maximum(uv)
    if maximum > EXACT_FIT * problem.model.diagonal:
        return None
    return StrategyOutcome(uv, notes=[f"{strategy} was not run: the {STRATEGIES[name].label} layout "
                                      "already fits this face exactly"])


def probe_edge_offset(face, cap=None):
    """The edge offset (mm) the panel and the command line start with on this face.

    cap (mm, default PROBE_EDGE_OFFSET_MM: a probe ball's radius plus a margin) where the face
    is wide enough; on a narrower face (a strip, a blade) half the largest clearance any of its
    points has from the edges, rounded down to two digits, which leaves a band for the points.
    face: a Part.Face.
    """
    cap = PROBE_EDGE_OFFSET_MM if cap is None else check_real("cap", cap, 0.0)
    if cap == 0:
        return 0.0
    reach = face_domain(SurfaceModel.from_face(face), cap).reach
    return cap if reach >= 2 * cap else _round_down(0.5 * reach)


def _move_onto_face(problem, outcome):
    """Move the outcome's points that lie off the face (OCC) onto it, with a note saying so.

    Points moved onto the same stretch of boundary (two grid points past a trimmed corner) can
    land closer than min_spacing: those are moved to free places (blind.respace), and checked
    on the face again."""
    outcome.uv, moved, off = problem.model.onto_face(outcome.uv)
    if not moved.any():
        return
    outcome.notes.append(
        f"{moved.sum()} point(s) lay up to {off[moved].max():.2g} mm off the face at its boundary "
        "and were moved onto it")
    outcome.uv, crowded = blind.respace(problem, outcome.uv)
    if crowded:
        outcome.uv = problem.model.onto_face(outcome.uv)[0]
        outcome.notes.append(f"{crowded} point(s) then lay closer than min_spacing to others and "
                             "were moved to free places")


def _fit_notes(problem):
    """Sentences on a substitute with more poles than points: between the points its shape then
    comes from the smoothing, not from the measurement."""
    poles = problem.space.poles
    if poles[0] * poles[1] <= problem.n:
        return []
    usual = resolve_fit_poles(None, problem.n, problem.space.degrees)
    return [f"the substitute has {poles[0]} x {poles[1]} poles for {problem.n} points: between the "
            f"points its shape comes from the smoothing, not from the measurement (the default for "
            f"{problem.n} points is {usual[0]} x {usual[1]})"]


def _json_friendly(options):
    """Options with arrays (e.g. a start layout) replaced by lists, for settings and documents."""
    return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in options.items()}


def lower_bound(face, n=81, *, fit_degree=DEFAULT_DEGREE, fit_poles=None, smoothing=DEFAULT_SMOOTHING,
                grid=DEFAULT_GRID, check=False):
    """The local bound about the reference fit on this face (cmmsampling.fitting.bound): the least
    first-order maximum deviation that reshaping the fit to very many points along its normals
    reaches. A yardstick, not a lower bound of what n points can reach: point sets reach other
    surfaces of the substitute space, and results may end below it.

    The substitute space (fit_degree, fit_poles from n) and grid as in :func:`sample`; check=True
    uses the check grid (3x denser). Returns a MinimaxBound: ``lower`` (mm), ``upper`` (a reshaped
    surface that reaches it within ``gap``), ``converged``.
    """
    problem = make_problem(face, n, fit_degree, fit_poles, smoothing, grid)
    with blas_threads(1):
        return problem.bounds()["check" if check else "grid"]


def evaluate(face, uv, *, strategy="given", fit_degree=DEFAULT_DEGREE, fit_poles=None,
             smoothing=DEFAULT_SMOOTHING, grid=DEFAULT_GRID, occ_check=True):
    """Judge a given point set: fit the substitute to the face's points at uv and measure it.

    uv: (N, 2) parameters on the face (as in SamplingResult.uv); the other arguments as in
    :func:`sample`. Returns a SamplingResult labelled with ``strategy``.
    """
    uv = check_uv(uv)
    problem = make_problem(face, len(uv), fit_degree, fit_poles, smoothing, grid)
    settings = {"strategy": strategy, "n": problem.n, **_common_settings(problem)}
    return _judge(problem, StrategyOutcome(uv), strategy, settings, 0.0, occ_check)


def _check_reach(problem, result):
    """The probe's pose at each final point, measured with OCC (result.access), its settings,
    and notes on the points tilted or refused."""
    started = time.perf_counter()
    result.access, refused = problem.reachability.final(result.points, result.normals)
    result.access.unreached = problem.domain.unreached_rectangles()
    result.access.unreached_area = problem.domain.unreached_area
    result.settings["probe"] = asdict(problem.reachability.probe)
    if problem.domain.unreached_area > 0:
        share = problem.domain.unreached_area / problem.model.area
        result.notes.append(f"the probe cannot reach {problem.domain.unreached_area:.4g} mm^2 of the face "
                            f"({100 * share:.3g} %) without touching the part elsewhere: no point was placed there")
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
    result.timings["reach_s"] = time.perf_counter() - started


def _common_settings(problem):
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


def _judge(problem, outcome, strategy, settings, strategy_s, occ_check):
    """Points, normals, fit and deviation statistics for a strategy's outcome."""
    start = time.perf_counter()
    uv = np.asarray(outcome.uv, dtype=float)
    with blas_threads(1):
        poles = problem.objective.fit(uv[None])[0]
        exact = problem.judge(poles)
        stats = DeviationStats.from_exact(exact)
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
        occ_cross_check(stats, exact, substitute_surface(problem.space, poles), problem.model.source_face)
        occ_s = time.perf_counter() - start
    result.timings = {"strategy_s": strategy_s, "evaluation_s": evaluation_s, "occ_check_s": occ_s,
                      "total_s": strategy_s + evaluation_s + occ_s}
    if problem.reachability is not None:
        _check_reach(problem, result)
    if result.exact:
        result.notes.append(
            f"the substitute reproduces this face exactly (maximum deviation {stats.maximum:.1e} mm, "
            "a millionth of its size at most): it lies in the fit's space, e.g. a plane, so any point "
            "set is as good as another and optimising cannot improve it")
    return result
