"""How many points does a face need? The fewest N whose strategy result meets a tolerance.

The substitute's space follows N through the pole rule (``default_pole_count``: round(2 sqrt(N) /
3) poles per direction, at least degree + 1), so the best deviation any N points can reach moves
in steps: inside one step the space is the same and more points cannot lower its bound, they only
help the strategy come closer to it. The search therefore runs over the steps, each tried at its
fewest points (:func:`step_counts`: the rule's first N with that pole count, and never fewer
points than poles), with a galloping search for the first step that meets the tolerance and a
bisection back down between the last step that failed and that one. A step whose result misses
the tolerance while its local bound (the least maximum deviation reshaping that substitute could
reach, :meth:`SamplingResult.bounds`) is within it is tried once more at the most points of the
step before the search moves on; the bound is worked out only there, and only as far as telling
it from the tolerance needs (:meth:`SamplingResult.bound_exceeds`). The result of each N tried
is kept in ``tried``. The galloping search gives up when two runs in a row each gave a maximum
above RISE_FACTOR times the best before them (the answer says so). A strategy that can stop once
its result is good enough (optimal's ``stop_at``) is told the tolerance: a run that meets it
needs to go no further to answer, and one that does not runs its whole course, so the search
takes the same steps.
"""
from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..access.reach import Reachability
from ..fitting.substitute import DEFAULT_DEGREE, default_pole_count
from ..geometry.validation import InputError, check_int, check_pair, check_real
from ..strategies.face_setup import reused
from ..strategies.sampling import (BEST_STRATEGY, MIN_POINTS, STRATEGIES, Part, check_arguments, measure_reach,
                                   probe_edge_offset, sample)

DEFAULT_MAX_POINTS = 400
# A search stops climbing when two runs in a row each gave a maximum this many times larger than
# the best before them: more points do not help there (a reached region too thin to hold them,
# a surface the substitute cannot follow), and each larger N costs more.
RISE_FACTOR = 1.2


def step_counts(n_max, degree=DEFAULT_DEGREE):
    """The pole-rule steps up to n_max points: [(poles per direction, fewest N, most N)], in
    increasing order; the fewest N of a step is at least its number of poles (p * p).
    degree: the substitute's degree, an int or a (u, v) pair (the higher one sets the steps).
    O(sqrt(n_max) log(n_max)): each step's end is found by bisection."""
    degree = _highest(degree)
    steps, n = [], MIN_POINTS
    while n <= n_max:
        poles = default_pole_count(n, degree)
        last = _last_with_poles(poles, n, n_max, degree)
        first = max(n, poles * poles)
        if first <= last:
            steps.append((poles, first, last))
        n = last + 1
    return steps


def fewest_points(degree=DEFAULT_DEGREE):
    """The fewest points a search or a plan runs: the first step's fewest N, (degree + 1)^2 (16
    for the bicubic substitute). degree: an int or a (u, v) pair."""
    return max(MIN_POINTS, (_highest(degree) + 1) ** 2)


def _highest(degree):
    """The higher degree of an int or a (u, v) pair."""
    return degree if np.ndim(degree) == 0 else max(degree)


def _last_with_poles(poles, n, n_max, degree):
    """The largest N in [n, n_max] that the pole rule gives ``poles`` (it does at n)."""
    low, high = n, n_max
    while low < high:
        middle = (low + high + 1) // 2
        if default_pole_count(middle, degree) == poles:
            low = middle
        else:
            high = middle - 1
    return low


@dataclass
class Tried:
    """One N tried: points, the maximum deviation its result reached (mm), the local bound about
    its substitute (mm; NaN where the search needed no more than to know it is above the
    tolerance), seconds; or the reason the strategy refused that N."""

    n: int
    maximum: float = float("nan")
    bound: float = float("nan")
    seconds: float = 0.0
    refused: str = ""


@dataclass
class PointsNeeded:
    """The answer of :func:`points_needed`.

    n: the fewest points found that meet the tolerance (mm), or the N of the best result reached
    when none does; result: that SamplingResult (None when every N was refused); met: whether it
    meets the tolerance; tolerance: mm; tried: a Tried per N run, in the order run; reason: why no
    N met it (empty when one did).
    """

    n: int
    result: object
    met: bool
    tolerance: float
    tried: list = field(default_factory=list)
    reason: str = ""

    @property
    def maximum(self):
        """Maximum deviation of the result, mm (NaN without one)."""
        return self.result.deviation.maximum if self.result is not None else float("nan")

    @property
    def bound(self):
        """Local bound about the result's substitute, mm: the best its space lets any N reach."""
        return self.result.bounds()["grid"].lower if self.result is not None else float("nan")


def points_needed(face: Part.Face, tolerance: float, strategy: str = BEST_STRATEGY, *, n_max: int = DEFAULT_MAX_POINTS,
                  edge_offset: float | None = None, fit_degree: int | tuple[int, int] = DEFAULT_DEGREE,
                  progress: Callable | None = None, **arguments) -> PointsNeeded:
    """The fewest probe points whose ``strategy`` result deviates at most ``tolerance`` mm.

    face: a Part.Face; tolerance: mm (> 0); n_max: the most points to try; edge_offset: mm, None
    for the face's probe edge offset (:func:`cmmsampling.probe_edge_offset`); fit_degree and
    ``arguments``: as in :func:`cmmsampling.sample` (e.g. grid, seed, workers, time_limit; part
    and probe: the probe's reach, judged once for all the N tried, and measured with OCC at the
    points of the result returned only);
    progress: callable(n, message) before each run (message "N = 16", after the first run with
    the best so far: "N = 36 (best so far 0.1046 mm with 16 points)") and after each iteration of
    an optimiser's run (message None), returning True to stop the search (the best found so far
    is returned). An optimiser that takes ``stop_at`` (optimal) stops each run once its maximum
    meets the tolerance, unless the arguments give stop_at (None: each run to its end). Returns a
    PointsNeeded; when no N up to n_max meets the tolerance, ``met`` is False and ``reason``
    names the best figure reached.
    """
    tolerance = check_real("tolerance", tolerance, above=0.0)
    n_max = check_max_points(n_max, fit_degree)
    check_arguments(strategy, {**arguments, "fit_degree": fit_degree}, fewest_points(fit_degree))
    if "stop_at" in STRATEGIES[strategy].options and "stop_at" not in arguments:
        arguments["stop_at"] = tolerance
    if arguments.get("part") is not None and not isinstance(arguments["part"], Reachability):
        arguments["part"] = Reachability(arguments["part"], arguments.pop("probe", None))
    with reused():
        if edge_offset is None:
            edge_offset = probe_edge_offset(face)
        search = _Search(face, strategy, tolerance, progress,
                         dict(arguments, edge_offset=edge_offset, fit_degree=fit_degree))
        reachability = arguments.get("part")
        with reachability.unmeasured() if reachability is not None else contextlib.nullcontext():
            search.run_steps(step_counts(n_max, fit_degree))
        answer = search.answer(n_max)
        if reachability is not None and answer.result is not None:
            measure_reach(answer.result)
        return answer


def why_not_met(result, tolerance):
    """Why a SamplingResult misses ``tolerance`` (mm), as the rest of a sentence: whether its
    substitute's space can hold it at all (the local bound about it, mm) and, where the probe
    cannot reach all of the face, over how much of the face it was judged."""
    bound = result.bounds()["grid"].lower
    if bound > tolerance:
        why = f": not even reshaping its substitute gets below {bound:.4g} mm (the local bound)"
    else:
        why = f": its substitute could reach {bound:.4g} mm (the local bound), no point set found does"
    domain = result.problem.domain if result.problem is not None else None
    if domain is not None and domain.unreached_area > 0:
        why += (f"; judged over the {result.problem.model.area - domain.unreached_area:.4g} mm^2 the probe reaches, "
                f"{domain.unreached_area:.4g} mm^2 out of its reach")
    return why


def check_max_points(n_max, fit_degree=DEFAULT_DEGREE):
    """n_max as int; InputError when it is below the fewest points a search runs (16 for the
    bicubic substitute: its 4 x 4 poles)."""
    fewest = fewest_points(check_pair("fit_degree", fit_degree, 1))
    n_max = check_int("n_max", n_max, MIN_POINTS)
    if n_max < fewest:
        raise InputError(f"n_max ({n_max}) is below the fewest points a degree-{_highest(fit_degree)} substitute "
                         f"is searched from ({fewest}); give n_max of at least {fewest}")
    return n_max


class _Search:
    """The runs of one points_needed() search: each N run once, its result kept."""

    def __init__(self, face, strategy, tolerance, progress, arguments):
        self.face, self.strategy, self.tolerance = face, strategy, tolerance
        self.progress, self.arguments = progress, arguments
        self.results, self.tried, self.stopped, self.gave_up = {}, [], False, False

    def meets(self, n):
        """True when the result at n meets the tolerance (runs it once)."""
        result = self.run(n)
        return result is not None and result.deviation.maximum <= self.tolerance

    def run(self, n):
        """The strategy's result at n (None when refused or stopped)."""
        if n in self.results:
            return self.results[n]
        if self.stopped or (self.progress is not None and self.progress(n, self._trying(n))):
            self.stopped = True
            return None
        start = time.perf_counter()
        try:
            result = sample(self.face, n, self.strategy, progress=self._during(n), **self.arguments)
        except InputError as exc:
            self.tried.append(Tried(n, seconds=time.perf_counter() - start, refused=str(exc)))
            self.results[n] = None
            return None
        self.tried.append(Tried(n, result.deviation.maximum, seconds=time.perf_counter() - start))
        self.results[n] = result
        return result

    def _trying(self, n):
        """The progress message before the run at n: "N = 36" and, after a run, the best maximum
        so far, e.g. "N = 36 (best so far 0.1046 mm with 16 points)"."""
        made = [t for t in self.tried if not t.refused]
        if not made:
            return f"N = {n}"
        best = min(made, key=lambda t: t.maximum)
        return f"N = {n} (best so far {best.maximum:.4g} mm with {best.n} points)"

    def _during(self, n):
        """sample()'s progress for the run at n: it asks the search's progress (message None)
        whether to stop, after each of an optimiser's iterations; None without a progress."""
        if self.progress is None:
            return None

        def asked(*_):
            self.stopped = self.stopped or bool(self.progress(n, None))
            return self.stopped

        return asked

    def step_meets(self, step):
        """True when the step meets the tolerance at its fewest points, or at its most points
        where its bound says the space can."""
        _, first, last = step
        if self.meets(first):
            return True
        result = self.results[first]
        if result is None or last == first:
            return False
        exceeds, bound = result.bound_exceeds(self.tolerance)
        next(tried for tried in self.tried if tried.n == first).bound = bound
        return not exceeds and self.meets(last)

    def run_steps(self, steps):
        """Run the steps the search needs to find the first that meets the tolerance: galloping
        up, then bisecting down (steps: non-empty, as :func:`step_counts`). A face that refuses
        the fewest points (too narrow for the edge offset, no usable area) refuses more too: the
        search ends there; so it does where more points kept giving larger maxima (:meth:`rising`)."""
        low, index, stride = -1, 0, 1
        while not self.stopped:
            if self.step_meets(steps[index]):
                break
            if index == len(steps) - 1 or self.tried[0].refused:
                return
            if self.rising():
                self.gave_up = True
                return
            low, index, stride = index, min(index + stride, len(steps) - 1), stride * 2
        while index - low > 1 and not self.stopped:
            middle = (low + index) // 2
            if self.step_meets(steps[middle]):
                index = middle
            else:
                low = middle

    def rising(self):
        """True when each of the last two runs made gave a maximum above RISE_FACTOR times the
        best of the runs before it."""
        made = [t.maximum for t in self.tried if not t.refused]
        return len(made) >= 3 and all(made[k] > RISE_FACTOR * min(made[:k]) for k in (-2, -1))

    def answer(self, n_max):
        """The PointsNeeded of the runs made."""
        meeting = [n for n, r in self.results.items() if r is not None and r.deviation.maximum <= self.tolerance]
        if meeting:
            n = min(meeting)
            return PointsNeeded(n, self.results[n], True, self.tolerance, self.tried)
        made = {n: r for n, r in self.results.items() if r is not None}
        if not made:
            why = self.tried[-1].refused if self.tried else "the search was stopped before any run"
            return PointsNeeded(0, None, False, self.tolerance, self.tried, f"no N could be placed: {why}")
        n = min(made, key=lambda k: made[k].deviation.maximum)
        best = made[n]
        tried = (f"no N meets {self.tolerance:g} mm (the search stopped at N = {max(made)}: two larger N in a row "
                 "gave larger maxima)" if self.gave_up else f"no N up to {n_max} meets {self.tolerance:g} mm")
        reason = (f"{tried}: the best reached is {best.deviation.maximum:.4g} mm with {n} points"
                  f"{why_not_met(best, self.tolerance)}")
        if self.stopped:
            reason = f"stopped before a result met {self.tolerance:g} mm; the best so far is " \
                     f"{best.deviation.maximum:.4g} mm with {n} points"
        return PointsNeeded(n, best, False, self.tolerance, self.tried, reason)
