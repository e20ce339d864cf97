"""Per-face runs in parallel as a user meets them: processes that cannot import the package or die,
a parent killed while its processes work, more processes asked for than the machine has, and a Dask
cluster whose workers do not have the package, interrupted with Ctrl-C."""
import importlib
import os
import signal
import socket
import subprocess
import sys
import time

import pytest
from support.faces import Part
from support.paths import ROOT

import cmmsampling
from cmmsampling.runtime import jobs as face_runs

PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable


def test_processes_that_cannot_import_a_job_leave_the_jobs_to_this_process(tmp_path, monkeypatch):
    """The jobs' module exists only in this process (its file is gone): the spawned processes die
    on it, and the jobs left run here, with a note."""
    (tmp_path / "vanishing_jobs.py").write_text("def square(x):\n    return x * x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("vanishing_jobs")
    (tmp_path / "vanishing_jobs.py").unlink()
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p != str(tmp_path)])
    seen = []
    # a busy machine may beat (message None) while the processes start and die: not counted here
    outcomes, notes = face_runs.run_all(module.square, [1, 2, 3], processes=2,
                                        progress=lambda done, total, message: None if message is None else seen.append(done))
    assert outcomes == [1, 4, 9]
    assert seen == [1, 2, 3]
    [note] = notes
    assert note.startswith("a local process ended abruptly") and note.endswith("ran in this process")


UNGUARDED = """import sys
sys.path.insert(0, {root!r})
with open({marker!r}, "a") as marker:
    marker.write(__name__ + "\\n")
import cmmsampling
import Part
made = cmmsampling.plan(Part.makeBox(20, 30, 10), n_total=48, strategy="uniform_parametric", processes=2,
                        faces=[1, 2, 3])
print("notes", made.notes, "points", made.n_total)
"""


@pytest.mark.parametrize("given_as", ["file", "stdin"])
def test_a_script_without_a_main_guard_plans_on_two_processes_and_ends(tmp_path, given_as):
    """A plain script (no ``if __name__ == "__main__":``), as a file or on standard input: the
    local processes import the package alone and never run the script again (before, each ran it
    as __mp_main__, started processes of its own and died, and the faces fell back to one process
    with the note "a local process ended abruptly")."""
    marker = tmp_path / "runs.txt"
    script = UNGUARDED.format(root=ROOT, marker=str(marker))
    (tmp_path / "plan_box.py").write_text(script)
    command = [PYTHON, "plan_box.py"] if given_as == "file" else [PYTHON, "-"]
    started = time.perf_counter()
    done = subprocess.run(command, input=None if given_as == "file" else script, capture_output=True, text=True,
                          cwd=str(tmp_path), timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "notes [] points 48" in done.stdout, done.stdout + done.stderr[-2000:]
    assert marker.read_text().split() == ["__main__"]
    assert time.perf_counter() - started < 60


def test_starting_local_processes_turns_a_closed_pipe_into_an_error_not_an_exit(tmp_path):
    """SIGPIPE at its default, as FreeCAD 1.0 and 1.1 leave it (a Cancel that stopped a local
    process while the pool wrote to it ended FreeCAD with exit 141): once local processes can
    start, a write to a pipe with no reader raises BrokenPipeError and the process goes on."""
    script = ("import os, signal, sys\n"
              f"sys.path.insert(0, {ROOT!r})\n"
              "signal.signal(signal.SIGPIPE, signal.SIG_DFL)\n"
              "from cmmsampling.runtime import jobs as face_runs\n"
              "face_runs.package_context()\n"
              "reader, writer = os.pipe()\n"
              "os.close(reader)\n"
              "try:\n"
              "    os.write(writer, b'x')\n"
              "except BrokenPipeError:\n"
              "    print('still here')\n")
    done = subprocess.run([PYTHON, "-c", script], capture_output=True, text=True, timeout=60)
    assert (done.returncode, done.stdout.strip()) == (0, "still here"), (done.returncode, done.stderr[-2000:])


def test_more_processes_than_cores_are_capped_and_said():
    notes = []
    count = face_runs.process_count(1000, 500, notes)
    assert count == min(os.cpu_count(), 500)
    assert notes == [f"{count} local process(es) ran the jobs, not 1000: the machine has {os.cpu_count()} core(s)"]
    assert face_runs.process_count(1, 5, notes) == 1 and len(notes) == 1


def test_the_processes_are_capped_by_the_free_memory(monkeypatch):
    monkeypatch.setenv("CMMSAMPLING_MEMORY_BYTES", str(face_runs.PROCESS_BYTES))
    notes = []
    assert face_runs.process_count(8, 8, notes) == 1
    if os.cpu_count() > 1:
        assert "of free memory" in notes[0]


def children(pid):
    """The pids whose parent is ``pid``."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    if int(stat.read().rsplit(")", 1)[1].split()[1]) == pid:
                        found.append(int(entry))
            except (OSError, IndexError, ValueError):
                continue
    return found


def test_a_killed_parent_takes_its_processes_with_it(tmp_path):
    """SIGKILL to a plan's process: its local processes and multiprocessing's resource tracker
    end within a few seconds instead of living on under PID 1."""
    script = tmp_path / "long_jobs.py"
    script.write_text(f"import sys, time\nsys.path.insert(0, {ROOT!r})\n"
                      "from cmmsampling.runtime import jobs as face_runs\n"
                      "if __name__ == '__main__':\n"
                      "    print('started', flush=True)\n"
                      "    face_runs.run_all(time.sleep, [60, 60, 60], processes=2)\n")
    parent = subprocess.Popen([PYTHON, str(script)], stdout=subprocess.PIPE, text=True, cwd=str(tmp_path))
    assert parent.stdout.readline().strip() == "started"
    deadline = time.monotonic() + 60
    while len(children(parent.pid)) < 3 and time.monotonic() < deadline:
        time.sleep(0.2)
    spawned = children(parent.pid)
    assert len(spawned) >= 3, "two processes and the resource tracker"
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 15
    while any(os.path.exists(f"/proc/{pid}") and not _zombie(pid) for pid in spawned) and time.monotonic() < deadline:
        time.sleep(0.2)
    alive = [pid for pid in spawned if os.path.exists(f"/proc/{pid}") and not _zombie(pid)]
    assert not alive, f"still running after the parent was killed: {alive}"


def _zombie(pid):
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return False


def free_port():
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture(scope="module")
def bare_cluster(tmp_path_factory):
    """A Dask scheduler and one worker started from an empty folder with no cmmsampling on their
    path: its address."""
    pytest.importorskip("distributed")
    folder = tmp_path_factory.mktemp("dask")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    address = f"tcp://127.0.0.1:{free_port()}"
    scheduler = subprocess.Popen([PYTHON, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                                  address.rsplit(":", 1)[1], "--no-dashboard"], cwd=str(folder), env=env,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    worker = subprocess.Popen([PYTHON, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                               "--nworkers", "1", "--no-dashboard", "--local-directory", str(folder)],
                              cwd=str(folder), env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        from distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=60)
        yield address
    finally:
        for process in (worker, scheduler):
            process.terminate()
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                process.kill()


def test_dask_workers_without_the_package_get_it_uploaded(bare_cluster):
    from distributed import Client

    def finds_package():
        import importlib.util

        return importlib.util.find_spec("cmmsampling") is not None

    with Client(bare_cluster) as client:
        assert not any(client.run(finds_package).values()), "the worker must not have the package beforehand"
        box = Part.makeBox(50, 40, 30)
        plan = cmmsampling.plan(box, n_total=32, faces=[1, 2], strategy="halton", scheduler=client)
        assert [face.n for face in plan.faces] == [16, 16] and not plan.notes
        here = cmmsampling.plan(box, n_total=32, faces=[1, 2], strategy="halton", processes=1)
        assert [face.uv.tolist() for face in plan.faces] == [face.uv.tolist() for face in here.faces]


def test_ctrl_c_cancels_a_plan_on_dask(bare_cluster, tmp_path):
    """SIGINT to the command line while its face runs on the cluster: exit 130 at once, the
    cluster holds none of its jobs afterwards, and the worker's one thread is free within seconds
    (Dask cannot stop a running task: the face's run asks whether its task was cancelled and ends;
    before, it went on computing, for minutes with these iterations)."""
    from distributed import Client

    step = str(tmp_path / "reference.step")
    cmmsampling.reference_face().exportStep(step)
    command = [PYTHON, "-m", "cmmsampling", "plan", step, "--points", "50", "--strategy", "pso",
               "--iterations", "100000", "--scheduler", bare_cluster]
    run = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    with Client(bare_cluster) as client:
        deadline = time.monotonic() + 120
        while not any(client.processing().values()) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert any(client.processing().values()), "the face never started on the cluster"
        run.send_signal(signal.SIGINT)
        stopped = time.monotonic()
        out, err = run.communicate(timeout=60)
        assert run.returncode == 130, err
        assert time.monotonic() - stopped < 15
        assert "interrupted" in err
        deadline = time.monotonic() + 30
        while any(client.processing().values()) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not any(client.processing().values()), "the cancelled job is still on the cluster"
        freed = time.monotonic()
        assert client.submit(sum, [1, 2], pure=False).result(timeout=60) == 3
        assert time.monotonic() - freed < 10, "the worker went on computing the cancelled face"
