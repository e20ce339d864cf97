"""Two-process swarm evaluation: identical results, and a fall-back when the worker fails."""
import time

import numpy as np
import pytest

import cmmsampling
from cmmsampling.strategies import parallel
from cmmsampling.strategies.parallel import TwoProcessObjective
from cmmsampling.strategies.threads import blas_threads


@pytest.fixture(scope="module")
def problem():
    from cmmsampling.strategies.sampling import make_problem

    return make_problem(cmmsampling.reference_face(), 25, grid=30, workers=2)


def test_worker_scores_exactly_like_this_process(problem):
    """Bit for bit, with one BLAS thread in both processes (as the engine always runs)."""
    objective = TwoProcessObjective(problem.objective)
    assert objective.parallel
    uv = np.random.default_rng(0).random((9, 25, 2))
    with blas_threads(1):
        assert np.array_equal(objective(uv), problem.objective(uv))
    assert objective.evaluations == 9


def test_pso_gives_the_same_result_with_one_or_two_processes(reference):
    runs = [cmmsampling.sample(reference, 25, "pso", iterations=40, grid=30, workers=w, occ_check=False)
            for w in (1, 2)]
    assert runs[0].deviation.maximum == runs[1].deviation.maximum
    assert np.array_equal(runs[0].uv, runs[1].uv) and np.array_equal(runs[0].history, runs[1].history)
    assert runs[1].settings["workers"] == 2


def test_a_dead_worker_falls_back_to_one_process(problem):
    objective = TwoProcessObjective(problem.objective)
    uv = np.random.default_rng(1).random((8, 25, 2))
    expected = problem.objective(uv)
    assert objective.parallel
    objective.worker.process.kill()
    objective.worker.process.wait()
    assert np.array_equal(objective(uv), expected)
    assert not objective.parallel
    assert np.array_equal(objective(uv), expected)
    assert parallel.shared_worker().process.poll() is None


def test_small_swarms_stay_in_this_process(problem):
    objective = TwoProcessObjective(problem.objective)
    uv = np.random.default_rng(2).random((2, 25, 2))
    assert np.array_equal(objective(uv), problem.objective(uv))


def test_workers_option_is_checked(reference):
    with pytest.raises(ValueError, match="workers must be 1 or 2, got 3"):
        cmmsampling.sample(reference, 25, "pso", iterations=1, workers=3)
    with pytest.raises(ValueError, match="workers must be at least 1"):
        cmmsampling.sample(reference, 25, "pso", iterations=1, workers=0)


def test_waiting_polls_then_gives_way_to_a_blocking_receive():
    """wait_for returns once data is there, and after its polling time when none comes."""
    from multiprocessing import Pipe

    from cmmsampling.strategies.worker import wait_for

    here, there = Pipe()
    wait_for(here, seconds=0.01)
    assert not here.poll(0)
    there.send("reply")
    start = time.perf_counter()
    wait_for(here, seconds=60)
    assert time.perf_counter() - start < 30, "it polled on although the reply was there"
    assert here.recv() == "reply"
