"""Particle swarm optimisation (Kennedy & Eberhart 1995) over sets of points in a box.

Generic: it knows nothing of surfaces. A particle is a set of N points ``(N, 2)``; the whole swarm
``(P, N, 2)`` is scored by one call of a batched objective ``f(X) -> (P,)``. The update is the
paper's eq. 7-9, per particle i and coordinate j:

    v[k+1] = w v[k] + c1 r1 (pbest - x[k]) + c2 r2 (gbest - x[k]),    x[k+1] = x[k] + v[k+1],

with r1, r2 uniform in [0, 1] drawn per coordinate, and an inertia decreasing linearly from w1 at
the first iteration to w2 at the last. Velocities are limited to ``velocity_limit`` times the box
size; a coordinate pushed out of the feasible set is projected back and its velocity zeroed.
"""
from dataclasses import dataclass

import numpy as np


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


def inertia(iteration, settings):
    """Inertia weight at iteration 1..iterations, linear from w1 to w2."""
    if settings.iterations == 1:
        return settings.w1
    fraction = (iteration - 1) / (settings.iterations - 1)
    return settings.w1 - fraction * (settings.w1 - settings.w2)


def _initial_swarm(rng, lower, upper, n_points, settings, seeds):
    """Random positions in the box, the first particles replaced by the given seed layouts."""
    shape = (settings.population, n_points, 2)
    positions = lower + rng.random(shape) * (upper - lower)
    for index, layout in enumerate(seeds[: settings.population]):
        positions[index] = layout
    limit = settings.velocity_limit * (upper - lower)
    velocities = (2 * rng.random(shape) - 1) * limit
    return positions, velocities, limit


def _attraction(positions, personal, best, r1, r2, settings):
    """c1 r1 (pbest - x) + c2 r2 (gbest - x) for the whole swarm, computed in r1 and r2 in place.

    positions, personal, r1, r2: (P, N, 2); best: (N, 2). Returns r1.
    """
    r1 *= settings.c1
    r1 *= personal - positions
    r2 *= settings.c2
    r2 *= best - positions
    r1 += r2
    return r1


def _screened(values, positions, personal_values, admissible):
    """values (P,) with inf where a position that would improve its personal best is inadmissible."""
    if admissible is None:
        return values
    candidates = np.flatnonzero(values < personal_values)
    if len(candidates):
        values[candidates[~admissible(positions, candidates)]] = np.inf
    return values


def particle_swarm(objective, lower, upper, n_points, settings, seeds=(), project=None, progress=None,
                   admissible=None):
    """Minimise objective over sets of n_points points in the box [lower, upper].

    objective: callable (P, N, 2) -> (P,); lower, upper: (2,) box corners; settings: SwarmSettings;
    seeds: layouts (N, 2) that start as particles 0, 1, ...; project: callable (P, N, 2) -> (P, N, 2)
    mapping positions onto the feasible set (default: clip to the box); progress: callable
    (iteration, best_value), called after every iteration, returning True to stop;
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
        values = _screened(objective(positions), positions, personal_values, admissible)
        improved = values < personal_values
        personal[improved] = positions[improved]
        personal_values[improved] = values[improved]
        leader = int(np.argmin(personal_values))
        if personal_values[leader] < best_value:
            best, best_value = personal[leader].copy(), float(personal_values[leader])
        history[iteration - 1] = best_value
        done = iteration
        if progress is not None and progress(iteration, best_value):
            cancelled = iteration < settings.iterations
            break
    evaluations = settings.population * (done + 1)
    return SwarmResult(best, best_value, history[:done], evaluations, cancelled)
