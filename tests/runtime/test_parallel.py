"""Two-process swarm evaluation: identical results, and a fall-back when the worker fails."""
import time

import numpy as np
import pytest

import cmmsampling
from cmmsampling.runtime import parallel
from cmmsampling.runtime.parallel import TwoProcessObjective
from cmmsampling.runtime.threads import ThreadpoolController, blas_description, blas_threads


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
    assert parallel.shared_worker()[0].alive()


def test_small_swarms_stay_in_this_process(problem):
    objective = TwoProcessObjective(problem.objective)
    uv = np.random.default_rng(2).random((2, 25, 2))
    assert np.array_equal(objective(uv), problem.objective(uv))


def test_workers_option_is_checked(reference):
    with pytest.raises(ValueError, match="workers must be 1 or 2, got 3"):
        cmmsampling.sample(reference, 25, "pso", iterations=1, workers=3)
    with pytest.raises(ValueError, match="workers must be at least 1"):
        cmmsampling.sample(reference, 25, "pso", iterations=1, workers=0)


def test_the_channel_carries_messages_and_reports_a_closed_end_without_a_signal():
    """A send to a closed end raises BrokenPipeError (SIGPIPE left at its default would end the
    process, as it would end FreeCAD 1.0); a receive from it raises ChannelClosed."""
    import signal
    import socket

    from cmmsampling.runtime.channel import Channel, ChannelClosed

    here, there = (Channel(s) for s in socket.socketpair())
    assert not here.ready(0.05)
    there.send(("reply", np.arange(3.0)))
    start = time.perf_counter()
    assert here.receive(5)[0] == "reply"
    assert time.perf_counter() - start < 5
    with pytest.raises(TimeoutError):
        here.receive(0.01)
    there.close()
    with pytest.raises(ChannelClosed):
        here.receive(5)
    default = signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    try:
        with pytest.raises(BrokenPipeError):
            here.send(np.zeros(100_000))
    finally:
        signal.signal(signal.SIGPIPE, default)


def test_the_worker_starts_from_any_folder(problem, tmp_path, monkeypatch):
    """The worker finds the package through its folder, not the current one."""
    monkeypatch.chdir(tmp_path)
    parallel.shared_worker()[0].close()
    objective = TwoProcessObjective(problem.objective)
    assert objective.parallel and objective.fallback is None
    uv = np.random.default_rng(3).random((8, 25, 2))
    with blas_threads(1):
        assert np.array_equal(objective(uv), problem.objective(uv))
    assert objective.remote == 4


@pytest.fixture
def one_process_run(reference):
    return cmmsampling.sample(reference, 25, "pso", iterations=30, grid=30, workers=1, occ_check=False)


def test_a_worker_that_cannot_import_the_package_leaves_the_run_to_this_process(reference, one_process_run,
                                                                                 tmp_path, monkeypatch):
    parallel.shared_worker()[0].close()
    monkeypatch.setattr(parallel, "package_parent", lambda: str(tmp_path))
    run = cmmsampling.sample(reference, 25, "pso", iterations=30, grid=30, workers=2, occ_check=False)
    assert np.array_equal(run.uv, one_process_run.uv)
    assert run.settings["processes"] == 1
    [note] = [note for note in run.notes if "this process alone" in note]
    assert "ModuleNotFoundError: No module named 'cmmsampling'" in note
    monkeypatch.undo()
    assert parallel.shared_worker()[0].alive(), "a later run starts a worker again"


def test_a_worker_killed_mid_run_leaves_its_share_to_this_process(reference, one_process_run):
    import os
    import signal

    def kill_at(iteration, best):
        if iteration == 10:
            os.kill(parallel.shared_worker()[0].pid, signal.SIGKILL)
        return False

    run = cmmsampling.sample(reference, 25, "pso", iterations=30, grid=30, workers=2, occ_check=False,
                             progress=kill_at)
    assert np.array_equal(run.uv, one_process_run.uv)
    assert np.array_equal(run.history, one_process_run.history)
    assert run.settings["processes"] == 2
    assert any("the second process was killed by signal 9" in note for note in run.notes)


def test_a_silent_worker_is_ended_after_its_start_time(monkeypatch):
    """A worker that never answers is not waited for beyond its start time."""
    monkeypatch.setattr(parallel, "BOOT", "import time; time.sleep(60)")
    start = time.perf_counter()
    with pytest.raises(parallel.WorkerUnavailable, match="did not answer within 0.5 s"):
        parallel.Worker(parallel.python_executable(), start_seconds=0.5)
    assert time.perf_counter() - start < 30



def test_a_measured_split_follows_the_faster_way():
    """SplitChoice times both ways at the start of each window and keeps the faster for the rest."""
    choice = parallel.SplitChoice()
    trials = 2 * choice.TRIALS
    for faster in (False, True, False):
        for k in range(trials):
            split = choice.next_split()
            assert split == (k % 2 == 0)
            choice.record(split, 0.5 if split == faster else 1.0)
        assert choice.split is faster
        for _ in range(choice.WINDOW - trials):
            assert choice.next_split() is faster
            choice.record(faster, 1.0)


def _window(choice, faster):
    """Run one window of ``choice`` whose trials find ``faster`` the faster way; returns its calls."""
    calls = 0
    while True:
        split = choice.next_split()
        choice.record(split, 0.5 if split == faster else 1.0)
        calls += 1
        if choice.phase == 0:
            return calls


def test_a_steady_choice_measures_ever_more_seldom_and_a_change_at_once():
    """Each window whose trials confirm the last choice is twice as long, up to MAX_WINDOW; a
    change of the faster way starts the next at WINDOW again."""
    choice = parallel.SplitChoice()
    lengths = [_window(choice, False) for _ in range(7)]
    assert lengths == [60, 120, 240, 480, 960, 960, 960]
    assert _window(choice, True) == choice.WINDOW and choice.split
    assert _window(choice, True) == 2 * choice.WINDOW


def test_the_default_processes_give_the_same_result_as_one():
    """workers left to the default: the swarm is split only where measured faster, and scored
    exactly as in one process either way."""
    from cmmsampling.strategies.sampling import make_problem

    problem = make_problem(cmmsampling.reference_face(), 25, grid=30)
    if problem.workers == 1:
        pytest.skip("one core: the default is one process")
    objective = problem.swarm_objective()
    assert problem.measured_split and objective.choice is not None
    swarms = np.random.default_rng(4).random((2 * parallel.SplitChoice.WINDOW, 8, problem.n, 2))
    with blas_threads(1):
        values = np.array([objective(s) for s in swarms])
        alone = np.array([problem.objective(s) for s in swarms])
    np.testing.assert_array_equal(values, alone)
    assert objective.remote >= 2 * parallel.SplitChoice.TRIALS * 4


def test_a_worker_killed_while_a_measured_run_scores_alone_is_noticed(reference, one_process_run):
    """With the default processes a run may score its swarms here alone when the worker dies:
    the run still says so, whichever way it was going."""
    import os
    import signal

    from cmmsampling.strategies.sampling import make_problem

    def kill_at(iteration, best):
        if iteration == 10:
            os.kill(parallel.shared_worker()[0].pid, signal.SIGKILL)
        return False

    run = cmmsampling.sample(reference, 25, "pso", iterations=30, grid=30, occ_check=False, progress=kill_at)
    assert np.array_equal(run.uv, one_process_run.uv)
    assert any("the second process was killed by signal 9" in note for note in run.notes)
    objective = TwoProcessObjective(make_problem(reference, 16, grid=20).objective, measured=True)
    objective.check_worker()
    assert objective.parallel, "a live worker answers the ping"
    os.kill(objective.worker.pid, signal.SIGKILL)
    objective.check_worker()
    assert not objective.parallel and "killed by signal 9" in objective.fallback


@pytest.mark.skipif(ThreadpoolController is None, reason="threadpoolctl is not installed")
def test_the_benchmarks_name_the_blas_and_its_kernels():
    from threadpoolctl import threadpool_info

    found = [info for info in threadpool_info() if info["user_api"] == "blas"]
    described = blas_description()
    if not found:  # a BLAS threadpoolctl does not know (Debian sid's numpy 2.4)
        assert described == "unknown"
        return
    assert described.startswith(found[0]["internal_api"])
    assert found[0].get("architecture") is None or f"{found[0]['architecture']} kernels" in described
