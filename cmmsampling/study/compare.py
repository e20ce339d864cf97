"""Strategy study: every strategy over a list of point counts N on one face (paper Table 1, Fig. 13).

:func:`compare` runs :func:`cmmsampling.sample` for each N and strategy (seed-dependent strategies
once per seed), computes once per N the local bound about the best substitute found at that N (the
least maximum deviation that reshaping it along its normals could reach, cmmsampling.fitting.bound) on the
optimisation grid and on the 3x denser check grid, and collects the deviations (mm), the run times
(s), the ratios to uniform parametric sampling and the multiples of the bound in a :class:`Study`.
Pure computation; :mod:`cmmsampling.study.figures` and :mod:`cmmsampling.study.html` draw it.
"""

import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from typing import NamedTuple

import numpy as np

from ..fitting.deviation import DEFAULT_GRID
from ..fitting.substitute import DEFAULT_DEGREE, DEFAULT_SMOOTHING
from ..geometry.validation import InputError, InputTypeError, check_choice, check_int
from ..runtime.threads import blas_threads
from ..strategies.face_setup import reused
from ..strategies.estimates import time_needed
from ..strategies.sampling import MIN_POINTS, STRATEGIES, Pair, Part, make_problem, sample, strategy_options
from ..strategies.sampling import baseline as baseline_strategy

DEFAULT_NS = (25, 36, 49, 64, 81, 100, 121, 144)
DEFAULT_SEEDS = (0, 1, 2, 3, 4)
PREFERRED_FIGURE_N = 81


@dataclass(frozen=True)
class Run:
    """One sample() run of a study; deviations in mm, time in s.

    max_mm, mean_mm, rms_mm: on the optimisation grid; check_max_mm: on the check grid;
    time_s: strategy and evaluation; ratio_max, ratio_mean, ratio_rms: max, mean and RMS over those
    of the baseline (uniform parametric) at the same N (NaN without a baseline run);
    bound_multiple, check_bound_multiple: max over the N's local bound on the grid, check max
    over the bound on the check grid.
    """

    strategy: str
    n: int
    seed: int
    max_mm: float
    mean_mm: float
    rms_mm: float
    check_max_mm: float
    time_s: float
    evaluations: int
    ratio_max: float = float("nan")
    ratio_mean: float = float("nan")
    ratio_rms: float = float("nan")
    bound_multiple: float = float("nan")
    check_bound_multiple: float = float("nan")


MEASURES = tuple(f.name for f in fields(Run) if f.type is float)


class Bound(NamedTuple):
    """Local bounds about the best substitute found at an N, mm: on the optimisation grid and on
    the check grid (see :func:`local_bound`)."""

    grid: float
    check: float


@dataclass(frozen=True)
class Aggregate:
    """The runs of one strategy at one N, summarised over their seeds.

    seeds: the seeds run; mean, std, low, high: {measure: value} over the runs for every name in
    MEASURES (std 0 for a single run).
    """

    strategy: str
    n: int
    seeds: tuple
    mean: dict
    std: dict
    low: dict
    high: dict


@dataclass
class Study:
    """What :func:`compare` measured.

    face: the face studied; ns: point counts; strategies: names, in run order; rows: list of Run
    (one per strategy, N and seed, in run order); bounds: {n: Bound (mm)}; bound_about: {n:
    (strategy, seed)} the run whose substitute each bound is about (the smallest check-grid
    maximum at that N); refused: {(strategy, n): message} the runs a strategy refused (e.g.
    uniform Cartesian on a face its footprint grid cannot cover); results: {strategy:
    SamplingResult} at ``figure_n`` (the first seed's) for the figures; figure_n: that N;
    settings: every parameter of the study; cancelled: stopped early (rows hold only the runs
    completed); elapsed_s: wall time (s).
    """

    face: object
    ns: tuple
    strategies: tuple
    rows: list = field(default_factory=list)
    bounds: dict = field(default_factory=dict)
    bound_about: dict = field(default_factory=dict)
    refused: dict = field(default_factory=dict)
    results: dict = field(default_factory=dict)
    figure_n: int | None = None
    settings: dict = field(default_factory=dict)
    cancelled: bool = False
    elapsed_s: float = 0.0

    def runs(self, strategy, n):
        """The Run records of one strategy at one N (one per seed)."""
        return [r for r in self.rows if r.strategy == strategy and r.n == n]

    def aggregate(self, strategy, n):
        """The Aggregate of one strategy at one N, or None where nothing was run."""
        runs = self.runs(strategy, n)
        if not runs:
            return None
        values = {m: np.array([getattr(r, m) for r in runs], dtype=float) for m in MEASURES}
        return Aggregate(strategy, n, tuple(r.seed for r in runs),
                         {m: float(v.mean()) for m, v in values.items()},
                         {m: float(v.std()) for m, v in values.items()},
                         {m: float(v.min()) for m, v in values.items()},
                         {m: float(v.max()) for m, v in values.items()})

    def summary(self):
        """Aggregates for every N (outer) and strategy (inner) that has runs."""
        found = (self.aggregate(s, n) for n in self.ns for s in self.strategies)
        return [a for a in found if a is not None]

    def matrix(self, measure="max_mm", statistic="mean"):
        """(strategies, ns) array of a measure's statistic ("mean", "std", "low", "high") over seeds;
        NaN where a strategy was not run at an N."""
        table = np.full((len(self.strategies), len(self.ns)), np.nan)
        for i, strategy in enumerate(self.strategies):
            for j, n in enumerate(self.ns):
                aggregate = self.aggregate(strategy, n)
                if aggregate is not None:
                    table[i, j] = getattr(aggregate, statistic)[measure]
        return table

    def table(self):
        """Fixed-width text table: one line per strategy and N, means over seeds (± std of the max
        where there are several), deviations in mm, ratios to uniform parametric, multiples of the
        local bound on the grid and the check grid, time in s."""
        header = (f"{'strategy':<20} {'N':>4} {'runs':>4} {'max mm':>9} {'± std':>7} {'mean mm':>8} "
                  f"{'RMS mm':>8} {'check max':>9} {'max/unif':>8} {'mean/unif':>9} {'RMS/unif':>8} "
                  f"{'x bound':>7} {'x check':>7} {'time s':>7}")
        lines = [header]
        for a in self.summary():
            m = a.mean
            spread = f"{a.std['max_mm']:>7.4f}" if len(a.seeds) > 1 else f"{'':>7}"
            lines.append(
                f"{a.strategy:<20} {a.n:>4} {len(a.seeds):>4} {m['max_mm']:>9.4f} {spread} "
                f"{m['mean_mm']:>8.4f} {m['rms_mm']:>8.4f} {m['check_max_mm']:>9.4f} "
                f"{m['ratio_max']:>8.3f} {m['ratio_mean']:>9.3f} {m['ratio_rms']:>8.3f} "
                f"{m['bound_multiple']:>7.3f} {m['check_bound_multiple']:>7.3f} {m['time_s']:>7.2f}")
        for n, bound in self.bounds.items():
            lines.append(f"{'local bound':<20} {n:>4} {'':>4} {bound.grid:>9.4f} {'':>7} {'':>8} "
                         f"{'':>8} {bound.check:>9.4f}")
        if self.cancelled:
            lines.append("(cancelled: only the runs completed are listed)")
        return "\n".join(lines)


@dataclass(frozen=True)
class Step:
    """One unit of work: one run of a strategy at N with a seed, or the bound at N (strategy None)."""

    n: int
    strategy: str | None = None
    seed: int | None = None

    def describe(self):
        """A short line for progress messages."""
        if self.strategy is None:
            return f"N = {self.n}: local bound about the best"
        return f"N = {self.n}: {STRATEGIES[self.strategy].label} (seed {self.seed})"


def study_steps(ns, strategies, seeds, seeded):
    """The study's steps in order: for each N every strategy (seeded ones once per seed, the
    others with the first seed), then the bound about the best of them."""
    steps = []
    for n in ns:
        for strategy in strategies:
            for seed in (seeds if strategy in seeded else seeds[:1]):
                steps.append(Step(n, strategy, seed))
        steps.append(Step(n))
    return steps


class Relay:
    """Relays the study's progress to callback(done_steps, total_steps, message) -> True to cancel."""

    def __init__(self, callback, total):
        self.callback, self.total, self.done = callback, total, 0
        self.cancelled = False

    def report(self, message):
        """Tell the callback; remember and return whether it asks to cancel."""
        if self.callback is not None and self.callback(self.done, self.total, message):
            self.cancelled = True
        return self.cancelled

    def optimiser(self, step):
        """A progress callable (iteration, best_max_mm) for sample(), relaying to the callback."""
        unit = STRATEGIES[step.strategy].progress_unit
        return lambda count, best: self.report(
            f"{step.describe()}: {unit} {count}, best max {best:.4f} mm")


def compare(face: Part.Face, ns: tuple = DEFAULT_NS, strategies: tuple | None = None, *, seeds: tuple = DEFAULT_SEEDS,
            seeded: tuple | None = None, options: dict | None = None, fit_degree: Pair = DEFAULT_DEGREE,
            fit_poles: Pair | None = None, smoothing: float = DEFAULT_SMOOTHING, grid: Pair = DEFAULT_GRID,
            edge_offset: float = 0.0, min_spacing: float | None = None, figure_n: int | None = None,
            progress: Callable | None = None, workers: int | None = None) -> Study:
    """Run every strategy over a list of N on one face and collect the trade-off.

    face: a Part.Face (e.g. ``cmmsampling.reference_face()``); ns: point counts (each >= 4);
    strategies: names from STRATEGIES (None: all, in their order); seeds: seeds of the
    seed-dependent strategies named in ``seeded`` (None: those whose record says ``seeded``, the
    random one; add "pso" for the swarm's spread, at 5x its time); the others run once with
    seeds[0]; options: {strategy name: {option: value}}, the strategies' own options (the others
    keep their defaults, e.g. the paper's PSO, 25 x 3000), e.g. ``{"pso": {"iterations": 500}}``;
    fit_degree, fit_poles, smoothing, grid, edge_offset (mm), min_spacing (mm): as in sample(),
    the same for every run (so a study's figures match Sample face's with the same values);
    figure_n: the N whose results are kept for the figures (default 81 if studied, else the middle
    N); progress: callable(done_steps, total_steps, message) called before every step (one run, or
    the bound at an N) and during the optimisers' iterations; returning True cancels: the study
    returns what was completed, with ``cancelled`` set (a run interrupted is dropped);
    workers: processes for the optimisers (as in sample()).
    Returns a Study.
    """
    ns = _check_ns(ns)
    strategies = _check_strategies(strategies, options)
    seeds = _check_seeds(seeds)
    seeded = _check_names("seeded strategy", [name for name in strategies if STRATEGIES[name].seeded]
                          if seeded is None else seeded)
    options = _check_options(options, strategies)
    figure_n = _check_figure_n(figure_n, ns)
    if progress is not None and not callable(progress):
        raise InputTypeError(f"progress must be callable(done, total, message) or None, got {progress!r}")
    fit = {"fit_degree": fit_degree, "fit_poles": fit_poles, "smoothing": smoothing, "grid": grid,
           "edge_offset": edge_offset, "min_spacing": min_spacing}
    with reused():
        return _study(face, ns, strategies, seeds, seeded, options, fit, figure_n, workers, progress)


def _study(face, ns, strategies, seeds, seeded, options, fit, figure_n, workers, progress):
    """compare() once its arguments are checked: the Study of its runs (inside a
    :func:`cmmsampling.strategies.face_setup.reused` block: the face is built once)."""
    make_problem(face, ns[0], **fit, workers=workers)
    study = Study(face, ns, strategies, figure_n=figure_n, settings={
        "ns": list(ns), "strategies": list(strategies), "seeds": list(seeds), "seeded": list(seeded),
        "options": {name: _described(given) for name, given in options.items()}, **fit, "figure_n": figure_n, "baseline": baseline_strategy(), "workers": workers})
    began = time.perf_counter()
    _execute(study, study_steps(ns, strategies, seeds, seeded), options, fit, progress, workers)
    study.rows = derive(study.rows, study.bounds)
    study.elapsed_s = time.perf_counter() - began
    return study


class StudyTime(NamedTuple):
    """What :func:`study_time` estimates: runs, the study's runs (the bounds left out); seconds,
    those whose length is known; open_ended, the strategies whose runs go on until they converge."""

    runs: int
    seconds: float
    open_ended: list


def study_time(face, ns=DEFAULT_NS, strategies=None, *, seeds=DEFAULT_SEEDS, options=None, **common):
    """Estimated duration of :func:`compare` with these arguments, the bounds left out: a
    StudyTime.

    Each optimiser is timed by :func:`cmmsampling.time_needed` once per N and counted for each of
    its seeds; a blind strategy's run is mostly building its problem, timed once per N and
    counted for each blind run. The optimal strategy without a limit has no known length: it is
    named in ``open_ended``. common: fit_degree, fit_poles, grid, edge_offset, min_spacing,
    workers (as in compare()).
    """
    ns = _check_ns(ns)
    strategies = _check_strategies(strategies, options)
    options = _check_options(options, strategies)
    seeded = [name for name in strategies if STRATEGIES[name].seeded]
    runs = Counter((step.n, step.strategy) for step in study_steps(ns, strategies, _check_seeds(seeds), seeded)
                   if step.strategy is not None)
    seconds, open_ended, blind = 0.0, [], {}
    for (n, name), count in runs.items():
        if not STRATEGIES[name].optimiser:
            if n not in blind:
                blind[n] = time_needed(face, n, name, **common)
            seconds += count * blind[n]
            continue
        each = time_needed(face, n, name, **common, **options.get(name, {}))
        if each is None:
            open_ended += [] if name in open_ended else [name]
        else:
            seconds += count * each
    return StudyTime(sum(runs.values()), seconds, open_ended)


def _check_options(options, strategies):
    """{name: validated options, defaults filled in} for the studied strategies that take options;
    ValueError for a name that is no strategy, TypeError for options one does not take."""
    if not isinstance(options or {}, dict):
        raise InputTypeError(f"options must be a dict {{strategy name: {{option: value}}}}, got {options!r}")
    given = {}
    for name, values in (options or {}).items():
        check_choice("strategy in options", name, list(STRATEGIES))
        if not isinstance(values, dict):
            raise InputTypeError(f"options[{name!r}] must be a dict {{option: value}}, got {values!r}")
        given[name] = strategy_options(name, values)
    return {name: given.get(name) or strategy_options(name, {})
            for name in strategies if STRATEGIES[name].options}


def _execute(study, steps, options, fit, callback, workers):
    """Run the steps into ``study`` (bounds, rows, results); stop when the callback cancels."""
    relay = Relay(callback, len(steps))
    best = {}
    for step in steps:
        if relay.report(step.describe()):
            break
        if step.strategy is None:
            about = best.pop(step.n)
            study.bounds[step.n] = local_bound(about)
            study.bound_about[step.n] = (about.strategy, about.settings["seed"])
        else:
            entry = STRATEGIES[step.strategy]
            try:
                result = sample(study.face, step.n, step.strategy, seed=step.seed, occ_check=False,
                                workers=workers,
                                progress=relay.optimiser(step) if entry.optimiser else None,
                                **fit, **options.get(step.strategy, {}))
            except InputError as refusal:
                study.refused[(step.strategy, step.n)] = str(refusal)
                relay.done += 1
                continue
            if result.cancelled:
                break
            study.rows.append(record(step, result))
            if step.n not in best or result.check.maximum < best[step.n].check.maximum:
                best[step.n] = result
            if step.n == study.figure_n and step.strategy not in study.results:
                study.results[step.strategy] = result
        relay.done += 1
    study.cancelled = relay.cancelled
    if not relay.cancelled:
        relay.report("study complete")


def local_bound(result):
    """The local bounds about a result's substitute on the grid and on the check grid: Bound (mm).

    The least maximum deviation that moving its poles along its normals could reach
    (:meth:`cmmsampling.strategies.result.SamplingResult.bounds`)."""
    with blas_threads(1):
        bounds = result.bounds()
    return Bound(bounds["grid"].lower, bounds["check"].lower)


def record(step, result):
    """The Run of one step from its SamplingResult (ratios and multiples left for :func:`derive`)."""
    d = result.deviation
    return Run(step.strategy, step.n, step.seed, d.maximum, d.mean, d.rms, result.check.maximum,
               result.timings["total_s"], result.evaluations)


def derive(rows, bounds, baseline=None):
    """Rows with ratios to the baseline's mean max/mean/RMS at their N and multiples of the bounds.

    Ratios stay NaN where the baseline was not run at that N, multiples where no bound was computed;
    a zero bound gives an infinite multiple. baseline: a strategy name (None: the records' baseline).
    """
    baseline = baseline or baseline_strategy()
    reference = {}
    for n in {r.n for r in rows}:
        base = [r for r in rows if r.n == n and r.strategy == baseline]
        if base:
            reference[n] = np.mean([[r.max_mm, r.mean_mm, r.rms_mm] for r in base], axis=0)
    derived = []
    for r in rows:
        ratios = reference[r.n] if r.n in reference else np.full(3, np.nan)
        bound = bounds.get(r.n, Bound(np.nan, np.nan))
        derived.append(replace(
            r, ratio_max=_ratio(r.max_mm, ratios[0]), ratio_mean=_ratio(r.mean_mm, ratios[1]),
            ratio_rms=_ratio(r.rms_mm, ratios[2]), bound_multiple=_ratio(r.max_mm, bound.grid),
            check_bound_multiple=_ratio(r.check_max_mm, bound.check)))
    return derived


def _ratio(value, reference):
    """value / reference; NaN for a NaN reference, inf for a zero one."""
    if np.isnan(reference):
        return float("nan")
    return float(value / reference) if reference > 0 else float("inf")


def _check_ns(ns):
    """Sorted distinct point counts, each at least MIN_POINTS; ValueError for none."""
    values = sorted({check_int("n", n, MIN_POINTS) for n in np.atleast_1d(ns).tolist()})
    if not values:
        raise InputError("ns must name at least one point count, e.g. (25, 49, 81)")
    return tuple(values)


def _check_strategies(strategies: tuple | list | str | None, options: dict | None = None) -> tuple[str, ...]:
    """Strategy names (None: all those whose required options, e.g. part_error's prior, are
    given in ``options``, in their order), at least one."""
    if strategies is None:
        given = options if isinstance(options, dict) else {}
        return tuple(name for name, entry in STRATEGIES.items()
                     if all(option in (given.get(name) or {}) for option in entry.requires))
    names = _check_names("strategy", strategies)
    if not names:
        raise InputError(f"strategies must name at least one of {', '.join(STRATEGIES)}")
    return names


def _described(options):
    """A strategy's options for the study's settings (JSON): objects such as a prior's
    inspections named by their count and kind."""
    def described(value):
        if isinstance(value, (bool, int, float, str)) or value is None:
            return value
        if isinstance(value, (list, tuple)) and all(isinstance(item, (bool, int, float, str)) for item in value):
            return list(value)
        if isinstance(value, (list, tuple)):
            return f"{len(value)} {type(value[0]).__name__} objects" if value else []
        return type(value).__name__

    return {option: described(value) for option, value in options.items()}


def _check_names(kind, names):
    """A strategy name or an iterable of them, each known, without repeats, in the order given."""
    if isinstance(names, str):
        names = [names]
    return tuple(dict.fromkeys(check_choice(kind, name, list(STRATEGIES)) for name in names))


def _check_seeds(seeds):
    """Distinct non-negative whole seeds, at least one."""
    values = tuple(dict.fromkeys(check_int("seed", s, 0) for s in np.atleast_1d(seeds).tolist()))
    if not values:
        raise InputError("seeds must hold at least one seed, e.g. (0, 1, 2, 3, 4)")
    return values


def _check_figure_n(figure_n, ns):
    """The N kept for the figures: the one given (must be studied), else 81 or the middle N."""
    if figure_n is None:
        return PREFERRED_FIGURE_N if PREFERRED_FIGURE_N in ns else ns[len(ns) // 2]
    return check_choice("figure_n", check_int("figure_n", figure_n, MIN_POINTS), list(ns))
