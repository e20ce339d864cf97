"""SampleSettings: the settings every strategy shares, checked once per call and passed by name,
and the defaults they share (the strategy sample() runs by default, the best one, the spacing every
strategy keeps, the blind layouts a search starts from), so that no strategy reads another's."""
from __future__ import annotations

import os
from dataclasses import dataclass, replace

import numpy as np

from ..fitting.deviation import DEFAULT_GRID
from ..fitting.substitute import DEFAULT_DEGREE, DEFAULT_SMOOTHING, default_pole_count
from ..geometry.validation import InputError, check_int, check_pair, check_real

MIN_POINTS = 4
# sample()'s strategy when none is named: the paper's.
DEFAULT_STRATEGY = "pso"
# What the command line, the plans and Plan part start with: the strategy that goes furthest.
BEST_STRATEGY = "optimal"
# The blind layouts a descent's "best" start, and part_error's fallback, are chosen from.
BEST_STARTS = ("uniform_parametric", "uniform_cartesian", "halton", "hammersley")
# The uniform layouts a swarm's result is judged against (the first is always possible; the
# second is left out where the face refuses it).
UNIFORM_LAYOUTS = ("uniform_parametric", "uniform_cartesian")
SPACING_FRACTION = 0.1
# Points nearer than this measure one spot twice with a CMM's ball: the default spacing keeps it
# wherever the face has room, mm.
BALL_SEPARATION_MM = 0.1
PACKING = np.sqrt(3) / 2
# An int for both parameter directions or a (u, v) pair of them.
Pair = int | tuple[int, int]
# The keyword arguments of sample() that SampleSettings.checked takes, besides n.
KEYWORDS = ("fit_degree", "fit_poles", "smoothing", "grid", "seed", "workers", "edge_offset", "min_spacing")


@dataclass(frozen=True)
class SampleSettings:
    """sample()'s settings common to every strategy, checked: made once per call by
    :meth:`checked` and handed by name to the memory check, the SamplingProblem and the result.

    n: points wanted; fit_degree, fit_poles: (k_u, k_v), (n_u, n_v) of the substitute B-spline
    (poles_given False: fit_poles follows n, :func:`resolve_fit_poles`); smoothing: its
    second-difference weight; grid: the (g_u, g_v) evaluation raster; seed: for the strategies'
    random parts; workers: processes an optimiser's swarm is spread over, 1 or 2 (workers_given
    False: the default, and a swarm is split only where that is measured faster); edge_offset:
    mm every point keeps from the face's edges; min_spacing: mm between any two points, None for
    the default the face decides.
    """

    n: int
    fit_degree: tuple[int, int]
    fit_poles: tuple[int, int]
    poles_given: bool
    smoothing: float
    grid: tuple[int, int]
    seed: int
    workers: int
    workers_given: bool
    edge_offset: float
    min_spacing: float | None

    @classmethod
    def checked(cls, n: int, *, fit_degree: Pair = DEFAULT_DEGREE, fit_poles: Pair | None = None,
                smoothing: float = DEFAULT_SMOOTHING, grid: Pair = DEFAULT_GRID, seed: int = 0,
                workers: int | None = None, edge_offset: float = 0.0,
                min_spacing: float | None = None) -> SampleSettings:
        """The settings of sample() (see there) checked whatever the face; InputError or
        InputTypeError naming the first bad one."""
        n = check_int("n", n, MIN_POINTS)
        degree = check_pair("fit_degree", fit_degree, 1)
        given = None if fit_poles is None else check_pair("fit_poles", fit_poles, 2)
        poles = resolve_fit_poles(given, n, degree)
        for axis, (d, p) in enumerate(zip(degree, poles)):
            if p < d + 1:
                raise InputError(f"fit_poles along {'uv'[axis]} ({p}) must be at least fit_degree + 1 ({d + 1})")
        return cls(n=n, fit_degree=degree, fit_poles=poles, poles_given=given is not None,
                   smoothing=check_real("smoothing", smoothing, above=0.0), grid=check_pair("grid", grid, 2),
                   seed=check_int("seed", seed, 0), workers=check_workers(workers), workers_given=workers is not None,
                   edge_offset=check_real("edge_offset", edge_offset, 0.0),
                   min_spacing=None if min_spacing is None else check_real("min_spacing", min_spacing, 0.0))

    def with_n(self, n: int) -> SampleSettings:
        """The same settings for n points (>= MIN_POINTS): the poles follow n unless given."""
        poles = self.fit_poles if self.poles_given else resolve_fit_poles(None, n, self.fit_degree)
        return replace(self, n=n, fit_poles=poles)


def default_min_spacing(area: float, n: int, feasible_area: float | None = None) -> float:
    """The default distance every strategy keeps between points, mm.

    A tenth of the spacing of N points spread evenly over a face of ``area`` mm^2, at least
    BALL_SEPARATION_MM (0.1 mm: nearer points measure one spot twice with a ball); where the
    feasible part of the face (``feasible_area`` mm^2, after the edge offset) cannot hold N
    points that far apart, half the spacing that fits there.
    """
    spacing = max(SPACING_FRACTION * float(np.sqrt(area / n)), BALL_SEPARATION_MM)
    if feasible_area is not None:
        spacing = min(spacing, 0.5 * float(np.sqrt(feasible_area / (PACKING * n))))
    return spacing


def resolve_fit_poles(fit_poles: tuple[int, int] | None, n: int, fit_degree: tuple[int, int]) -> tuple[int, int]:
    """(n_u, n_v): the given pole counts, or :func:`default_pole_count` for N in each direction."""
    if fit_poles is None:
        return (default_pole_count(n, fit_degree[0]), default_pole_count(n, fit_degree[1]))
    return fit_poles


def check_workers(workers: int | None) -> int:
    """1 or 2 processes for the optimisers; None picks 2 where the machine has 2 or more cores."""
    if workers is None:
        return 2 if (os.cpu_count() or 1) >= 2 else 1
    count = check_int("workers", workers, 1)
    if count > 2:
        raise InputError(f"workers must be 1 or 2, got {count}")
    return count
