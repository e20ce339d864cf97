"""The generic swarm optimiser on simple objectives: convergence, schedule, cancel, determinism."""
import numpy as np
import pytest

from cmmsampling.strategies.pso import SwarmSettings, inertia, particle_swarm

LOWER, UPPER = np.zeros(2), np.ones(2)
TARGET = np.array([[0.3, 0.7], [0.8, 0.1], [0.5, 0.5]])


def distance_to_target(x):
    """(P, 3, 2) -> (P,): largest distance of a point to its target."""
    return np.linalg.norm(x - TARGET, axis=2).max(axis=1)


def test_swarm_finds_the_minimum():
    result = particle_swarm(distance_to_target, LOWER, UPPER, 3, SwarmSettings(20, 300, 0.9, 0.4))
    assert result.best_value < 1e-3
    assert np.allclose(result.best, TARGET, atol=1e-3)
    assert result.evaluations == 20 * 301
    assert np.all(np.diff(result.history) <= 0)


def test_inertia_decreases_linearly_from_w1_to_w2():
    settings = SwarmSettings(iterations=11, w1=0.9, w2=0.4)
    values = [inertia(k, settings) for k in range(1, 12)]
    assert values[0] == pytest.approx(0.9) and values[-1] == pytest.approx(0.4)
    assert np.allclose(np.diff(values), -0.05)


def test_same_seed_same_result_other_seed_other_path():
    settings = SwarmSettings(10, 50, seed=7)
    a = particle_swarm(distance_to_target, LOWER, UPPER, 3, settings)
    b = particle_swarm(distance_to_target, LOWER, UPPER, 3, settings)
    c = particle_swarm(distance_to_target, LOWER, UPPER, 3, SwarmSettings(10, 50, seed=8))
    assert np.array_equal(a.history, b.history) and np.array_equal(a.best, b.best)
    assert not np.array_equal(a.history, c.history)


def test_positions_stay_in_the_box():
    seen = []

    def objective(x):
        seen.append(x.copy())
        return -x.sum(axis=(1, 2))

    particle_swarm(objective, LOWER, UPPER, 3, SwarmSettings(8, 40, c1=4, c2=4, velocity_limit=1.0))
    allx = np.concatenate(seen)
    assert allx.min() >= 0.0 and allx.max() <= 1.0


def test_progress_can_cancel_and_the_best_so_far_is_kept():
    calls = []

    def progress(iteration, best, best_set):
        calls.append((iteration, best))
        assert distance_to_target(best_set[None])[0] == pytest.approx(best)
        return iteration == 5

    result = particle_swarm(distance_to_target, LOWER, UPPER, 3, SwarmSettings(10, 100), progress=progress)
    assert result.cancelled and len(result.history) == 5 and len(calls) == 5
    assert result.best_value == pytest.approx(calls[-1][1])
    assert distance_to_target(result.best[None])[0] == pytest.approx(result.best_value)


def test_a_seed_layout_is_never_lost():
    seed_layout = TARGET + 0.01
    result = particle_swarm(distance_to_target, LOWER, UPPER, 3, SwarmSettings(5, 3, seed=1),
                            seeds=[seed_layout])
    assert result.best_value <= distance_to_target(seed_layout[None])[0]
