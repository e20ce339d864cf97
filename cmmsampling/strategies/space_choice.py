"""The substitute's pole counts where the caller left them to the default.

The default space (:func:`cmmsampling.fitting.substitute.default_pole_count`: about 2.25 points
per pole) suits points spread over the whole face. Where they cannot be (a narrow strip whose
edge offset leaves a thin band, a face the probe reaches in part), a pole whose support holds few
points is set by the smoothing alone and the substitute swings there, by more the more poles it
has: on the Ventilator's Face58 with the probe, the default gave 0.156 mm at N = 16, 0.65 mm at
46 and 2.4 mm at 96. So the space is chosen by the figure the strategies minimise: every
coarser pole count per direction, from degree + 1 up to the default's, is fitted to the same
points and screened by the optimisers' fast figure on the grid; the best one is judged exactly
and kept where its maximum beats the current space's by SPACE_GAIN (a clear gain, never a
rounding tie). Each candidate costs one fit and one fast figure on the grid's nodes.
"""
from __future__ import annotations

import itertools

import numpy as np

from .problem import SamplingProblem

# A coarser space replaces the default only where its maximum deviation is below this share of
# the default's.
SPACE_GAIN = 0.8


def candidate_poles(default: SamplingProblem) -> list[tuple[int, int]]:
    """(n_u, n_v) pairs from degree + 1 up to the default problem's poles in each direction."""
    ranges = [range(degree + 1, count + 1) for degree, count in zip(default.space.degrees, default.space.poles)]
    return [(u, v) for u, v in itertools.product(*ranges)]


def chosen_space(default: SamplingProblem, current: SamplingProblem, uv: np.ndarray) -> tuple[SamplingProblem, str]:
    """The problem whose space fits the points at ``uv`` (N, 2) best, and a note saying why (''
    where ``current`` is kept). default: the problem with the default poles (the caller left them
    to it); current: the one the points were placed for (``default`` or one this function chose).
    Every candidate is screened by the optimisers' fast figure on the grid; the best one replaces
    ``current`` where its exact maximum is below SPACE_GAIN times current's."""
    uv = np.asarray(uv, dtype=float)
    problems = {tuple(current.space.poles): current, tuple(default.space.poles): default}
    screened = []
    for poles in candidate_poles(default):
        problem = problems.get(poles) or default.with_poles(poles)
        screened.append((float(problem.objective(uv[None])[0]), poles, problem))
    _, poles, best = min(screened, key=lambda item: item[:2])
    kept = current.exact_maximum(uv)
    if best is current or not best.exact_maximum(uv) < SPACE_GAIN * kept:
        return current, ""
    u, v = poles
    du, dv = default.space.poles
    return best, (f"the substitute has {u} x {v} poles, not the default {du} x {dv}: these points hold no more "
                  f"(on the evaluation grid the default's maximum deviation is {default.exact_maximum(uv):.4g} mm "
                  f"here, this one's {best.exact_maximum(uv):.4g} mm)")
