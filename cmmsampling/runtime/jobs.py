"""Independent jobs, in parallel: in this process, on local processes or on a Dask cluster
(:func:`run_all`; a part plan's faces, cmmsampling.planning.part_plan, are such jobs).

A job is plain data (for a face: the face as a BREP string, numbers, names) and its outcome is
plain data, so both cross process and machine boundaries. Local processes are started with this Python
(also from inside FreeCAD, whose ``sys.executable`` is the FreeCAD binary) by the ``spawn``
method; a Dask cluster is reached through ``distributed.Client`` (Debian's python3-distributed).

Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes glibc's
mmap threshold at 128 KiB: every temporary array of the fit and the deviation is then mapped and
unmapped anew, and a face took 1.65x as long (22.5 s against 13.6 s, measured). A job run on Dask
first sets glibc's thresholds back to sizes that keep those arrays in the heap.
"""
from __future__ import annotations

import concurrent.futures
import contextvars
import ctypes
import multiprocessing
import multiprocessing.context
import multiprocessing.spawn
import os
import queue
import tempfile
import threading
import time
import zipfile
from collections.abc import Callable, Generator, Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from ..geometry.validation import check_int
from .memory import free_bytes, gib
from .parallel import ignore_broken_pipes, package_parent, python_executable

# Memory one local process takes for a face (FreeCAD, numpy, scipy and a face's arrays), bytes:
# a Ventilator face's process peaked at about 180 MB; this leaves room for larger grids.
PROCESS_BYTES = 400 * 2**20
PARENT_CHECK_SECONDS = 1.0
# How often a run reports that jobs are still under way (and can be cancelled), s.
BEAT_SECONDS = 0.5
# What the job runners yield: (index, outcome) for each job that ends, (None, None) for a beat.
Runs = Generator[tuple[int | None, Any], None, None]


# Local processes that import the package alone: spawn's children normally run the parent's
# __main__ again (as __mp_main__), which re-runs a script without an ``if __name__ ==
# "__main__":`` guard (its plan() call then starts processes inside the child, which dies) and
# fails for stdin or a FreeCAD macro. The processes of this module are named with PROCESS_PREFIX
# and their preparation data lose the main module's path and name; the jobs' functions and data
# come from the package, found on the sys.path the data keep.
PROCESS_PREFIX = "cmmsampling-"
_MAIN_KEYS = ("init_main_from_path", "init_main_from_name")


def _package_only(prepare: Callable[[str], dict[str, Any]]) -> Callable[[str], dict[str, Any]]:
    """multiprocessing.spawn.get_preparation_data, without the main module for this module's
    processes (named PROCESS_PREFIX...), as it was for any other."""

    def prepared(name: str) -> dict[str, Any]:
        data = prepare(name)
        if name.startswith(PROCESS_PREFIX):
            for key in _MAIN_KEYS:
                data.pop(key, None)
        return data

    setattr(prepared, "package_only", True)
    return prepared


class _PackageProcess(multiprocessing.context.SpawnProcess):
    """A spawned process that runs none of the parent's __main__ (see PROCESS_PREFIX)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.name = PROCESS_PREFIX + self.name


class _PackageContext(multiprocessing.context.SpawnContext):
    """The spawn start method with :class:`_PackageProcess` processes."""

    Process = _PackageProcess


def package_context() -> multiprocessing.context.SpawnContext:
    """A spawn context whose processes import the package alone, never the parent's __main__,
    started with this Python (python_executable: also from inside FreeCAD)."""
    ignore_broken_pipes()
    if not getattr(multiprocessing.spawn.get_preparation_data, "package_only", False):
        prepare = _package_only(multiprocessing.spawn.get_preparation_data)
        setattr(multiprocessing.spawn, "get_preparation_data", prepare)
    context = _PackageContext()
    executable = python_executable()
    if executable is not None:
        context.set_executable(executable)
    return context


class WorkersFailed(RuntimeError):
    """The processes or Dask workers could not run the jobs (they died, or cannot import the
    package); the message says why."""


def run_all(function: Callable[[Any], Any], jobs: Sequence[Any], processes: int | None = None, scheduler: Any = None,
            progress: Callable[[int, int, str | None], bool | None] | None = None,
            describe: Callable[[Any, Any], str] | None = None,
            during: Callable[[int, str], None] | None = None) -> tuple[list[Any], list[str]]:
    """``function(job)`` for every job; returns (outcomes in the jobs' order, notes).

    function: a module-level function (picklable); jobs: a list of picklable jobs;
    processes: local processes (None: all cores; never more than the cores, the jobs and the
    memory free for them allow; 1 runs here, one job after another);
    scheduler: a Dask scheduler address ("tcp://host:8786") or a distributed.Client, which then
    runs the jobs instead of local processes (the package is uploaded to its workers); progress:
    callable(done, total, message) after each job ends, and with message None every BEAT_SECONDS
    while a job runs, returning True to cancel: jobs not started are dropped, running ones are
    stopped at once (local processes ended; a job in this process or on Dask runs on in its
    thread, told to stop (:func:`stop_asked`, Dask's job cancelled), and its outcome is dropped), and their
    outcomes are None; describe:
    callable(job, outcome) -> the progress message of a finished job (default: "<job.name> done");
    during: callable(index, text) with what a job under way last said of itself (:func:`report`:
    in this process and on local processes, not on Dask), before each beat's progress.
    notes: sentences on how the jobs ran where that differs from what was asked (fewer processes,
    processes that failed, after which the jobs left ran here).
    """
    total = len(jobs)
    outcomes: list[Any] = [None] * total
    notes: list[str] = []
    reports = _Reports()
    if scheduler is not None:
        runs = _dask_runs(function, jobs, scheduler)
    else:
        count = process_count(processes, total, notes)
        runs = _here(function, jobs, reports) if count == 1 else _local_processes(function, jobs, count, reports)
    message = describe or _message
    done = 0

    def record(index: int | None, outcome: Any) -> bool:
        """Keep an outcome and report it (a beat where index is None); True when the caller cancels."""
        nonlocal done
        if index is None:
            for job, text in reports.drain():
                if during is not None and outcomes[job] is None:
                    during(job, text)
            return progress is not None and bool(progress(done, total, None))
        done += 1
        outcomes[index] = outcome
        return progress is not None and bool(progress(done, total, message(jobs[index], outcome)))

    try:
        any(record(index, outcome) for index, outcome in runs)
    except WorkersFailed as exc:
        left = [k for k in range(total) if outcomes[k] is None]
        notes.append(f"{exc}; the {len(left)} job(s) left ran in this process")
        any(record(index, function(jobs[index])) for index in left)
    finally:
        runs.close()
        reports.close()
    return outcomes, notes


def process_count(processes: int | None, jobs: int, notes: list[str] | None = None) -> int:
    """Local processes to start: the given count (>= 1) or all cores, never more than the
    cores, the jobs, or the processes the free memory holds (PROCESS_BYTES each); a note in
    ``notes`` when fewer than asked are started for the cores or the memory."""
    cores = os.cpu_count() or 1
    asked = cores if processes is None else check_int("processes", processes, 1)
    free = free_bytes()
    room = cores if free is None else max(1, int(free // PROCESS_BYTES))
    count = max(1, min(asked, cores, room, jobs))
    if notes is not None and count < min(asked, jobs):
        why = (f"{cores} core(s)" if free is None or cores <= room else
               f"{gib(free)} of free memory, about {gib(PROCESS_BYTES)} each")
        notes.append(f"{count} local process(es) ran the jobs, not {asked}: the machine has {why}")
    return count


def _here(function: Callable[[Any], Any], jobs: Sequence[Any], reports: _Reports) -> Runs:
    """Each job in this process, in order, in a thread of its own: (index, outcome), and
    (None, None) every BEAT_SECONDS while it runs; what a job says of itself (:func:`report`) goes
    to ``reports`` (a _Reports). Closing the generator early asks the job under way to stop
    (:func:`stop_asked`) and leaves it to end in its thread."""
    stop = threading.Event()
    try:
        for index, job in enumerate(jobs):
            ended: dict[str, Any] = {}
            thread = threading.Thread(target=_run_job, args=(function, job, stop, ended, reports.teller(index)),
                                      daemon=True, name="cmmsampling-job")
            thread.start()
            thread.join(BEAT_SECONDS)
            while thread.is_alive():
                yield None, None
                thread.join(BEAT_SECONDS)
            if "error" in ended:
                raise ended["error"]
            yield index, ended["outcome"]
    finally:
        stop.set()


_STOP: contextvars.ContextVar[threading.Event | _TaskCancelled | None] = contextvars.ContextVar(
    "cmmsampling_job_stop", default=None)


def _run_job(function: Callable[[Any], Any], job: Any, stop: threading.Event, ended: dict[str, Any],
             teller: Callable[[str], None]) -> None:
    """function(job) into ended["outcome"] (or its exception into ended["error"]), with
    :func:`stop_asked` answering from ``stop`` (a threading.Event) and :func:`report` telling
    ``teller`` (callable(text))."""
    _STOP.set(stop)
    _TELL.set(teller)
    try:
        ended["outcome"] = function(job)
    except BaseException as exc:  # handed to the generator, which raises it in the caller's thread
        ended["error"] = exc


_TELL: contextvars.ContextVar[Callable[[str], None] | None] = contextvars.ContextVar(
    "cmmsampling_job_report", default=None)
# In a local process: the queue its jobs' reports go to (set by _start_process).
_PROCESS_QUEUE: Any = None


def report(text: str) -> None:
    """Say how the job under way in this thread is getting on (e.g. "N = 36 (best so far ...)"):
    run_all hands the latest text of each job to its ``during`` at the next beat. Does nothing
    outside a job of run_all or on Dask."""
    tell = _TELL.get()
    if tell is not None:
        tell(text)


class _Reports:
    """The latest text each job under way said of itself (:func:`report`): jobs in this process
    write them here directly, jobs in local processes through a queue (:meth:`queue`)."""

    def __init__(self) -> None:
        self._latest: dict[int, str] = {}
        self._lock = threading.Lock()
        self._queue: Any = None

    def teller(self, index: int) -> Callable[[str], None]:
        """callable(text) that keeps ``text`` as job ``index``'s latest."""

        def tell(text: str) -> None:
            with self._lock:
                self._latest[index] = text

        return tell

    def queue(self, context: multiprocessing.context.SpawnContext) -> Any:
        """A queue of the multiprocessing ``context`` for local processes' reports (index, text)."""
        self._queue = context.Queue()
        return self._queue

    def drain(self) -> list[tuple[int, str]]:
        """[(index, latest text)] said since the last drain, each job once."""
        while self._queue is not None:
            try:
                index, text = self._queue.get_nowait()
            except (queue.Empty, OSError, ValueError):
                break
            self.teller(index)(text)
        with self._lock:
            latest, self._latest = self._latest, {}
        return sorted(latest.items())

    def close(self) -> None:
        """Let go of the queue (its feeder thread ends)."""
        if self._queue is not None:
            self._queue.close()
            self._queue.cancel_join_thread()
            self._queue = None


def _start_process(parent: int, reports: Any) -> None:
    """A local process's initializer: follow the parent (:func:`follow_parent`) and send its
    jobs' reports to the queue ``reports``."""
    global _PROCESS_QUEUE
    _PROCESS_QUEUE = reports
    follow_parent(parent)


def _in_process(function: Callable[[Any], Any], index: int, job: Any) -> Any:
    """function(job) in a local process, its :func:`report` texts sent as (index, text)."""
    queue_ = _PROCESS_QUEUE
    token = _TELL.set(None if queue_ is None else (lambda text: queue_.put((index, text))))
    try:
        return function(job)
    finally:
        _TELL.reset(token)


def stop_asked() -> bool:
    """True when the run of the job under way in this thread was cancelled (a job run in this
    process by :func:`run_all`, or on a Dask worker; a job in a local process is stopped from
    outside: the process ends)."""
    stop = _STOP.get()
    return stop is not None and stop.is_set()


def _local_processes(function: Callable[[Any], Any], jobs: Sequence[Any], count: int, reports: _Reports) -> Runs:
    """The jobs on ``count`` local processes as they end: (index, outcome); closing the
    generator early stops the processes. WorkersFailed when a process dies (or cannot import
    the package). Each process ends itself when this one dies (:func:`follow_parent`) and sends
    what its jobs say of themselves to ``reports`` (a _Reports)."""
    context = package_context()
    pool = concurrent.futures.ProcessPoolExecutor(count, mp_context=context, initializer=_start_process,
                                                  initargs=(os.getpid(), reports.queue(context)))
    futures = {pool.submit(_in_process, function, index, job): index for index, job in enumerate(jobs)}
    pending = set(futures)
    try:
        while pending:
            finished, pending = concurrent.futures.wait(pending, BEAT_SECONDS, concurrent.futures.FIRST_COMPLETED)
            if not finished:
                yield None, None
            for future in finished:
                try:
                    outcome = future.result()
                except BrokenProcessPool as exc:
                    raise WorkersFailed(f"a local process ended abruptly ({exc})") from exc
                yield futures[future], outcome
    finally:
        _stop(pool)


def follow_parent(parent: int) -> None:
    """In a local process: end this process as soon as ``parent`` (pid) is no longer its parent
    (it was killed), checked every PARENT_CHECK_SECONDS by a daemon thread."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK_SECONDS)
        os._exit(1)

    threading.Thread(target=watch, name="follow-parent", daemon=True).start()


def _stop(pool: concurrent.futures.ProcessPoolExecutor) -> None:
    """Shut a process pool down now: pending jobs cancelled, running processes terminated."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(5)


def _dask_runs(function: Callable[[Any], Any], jobs: Sequence[Any], scheduler: Any) -> Runs:
    """The jobs on a Dask cluster as they end: (index, outcome), and (None, None) every
    BEAT_SECONDS while none ends; closing the generator early (or Ctrl-C) cancels the jobs still
    queued or running. The package is uploaded to the workers first (:func:`upload_package`);
    WorkersFailed when they still cannot import it."""
    from distributed import Client, wait

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    futures = []
    try:
        upload_package(client)
        futures = [client.submit(run_on_worker, function, job, pure=False) for job in jobs]
        where = {future.key: index for index, future in enumerate(futures)}
        pending = futures
        while pending:
            try:
                finished, pending = wait(pending, timeout=BEAT_SECONDS, return_when="FIRST_COMPLETED")
            except TimeoutError:
                yield None, None
                continue
            for future in finished:
                try:
                    outcome = future.result()
                except ImportError as exc:
                    raise WorkersFailed(f"the Dask workers cannot import what the jobs need ({exc})") from exc
                yield where[future.key], outcome
    finally:
        client.cancel([future for future in futures if not future.done()])
        if client is not scheduler:
            client.close()


def upload_package(client: Any) -> None:
    """Send this cmmsampling package to every worker of a Dask client as a zip, which the
    workers put first on their sys.path: they run the same code as this process, and need only
    FreeCAD, numpy and scipy installed."""
    root = package_parent()
    if os.path.isfile(root):   # imported from a zip already (e.g. on a Dask worker)
        client.upload_file(root)
        return
    with tempfile.TemporaryDirectory() as folder:
        archive = os.path.join(folder, "cmmsampling.zip")
        with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as package:
            for directory, _, names in os.walk(os.path.join(root, "cmmsampling")):
                for name in sorted(names):
                    if name.endswith(".py"):
                        path = os.path.join(directory, name)
                        package.write(path, os.path.relpath(path, root))
        client.upload_file(archive)


# glibc's mallopt parameters and the sizes set for a Dask worker's jobs (bytes).
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
HEAP_THRESHOLDS = {M_TRIM_THRESHOLD: 128 * 2 ** 20, M_MMAP_THRESHOLD: 32 * 2 ** 20}


def run_on_worker(function: Callable[[Any], Any], job: Any) -> Any:
    """``function(job)`` on a Dask worker, after :func:`set_heap_thresholds`, with
    :func:`stop_asked` answering whether the client cancelled this task: Dask cannot stop a
    running task, so a job that asks ends early instead of holding the worker's thread."""
    from distributed import get_worker

    set_heap_thresholds()
    worker = get_worker()
    token = _STOP.set(_TaskCancelled(worker, worker.get_current_task()))
    try:
        return function(job)
    finally:
        _STOP.reset(token)


class _TaskCancelled:
    """Whether a Dask worker's task was cancelled, with the ``is_set()`` of a threading.Event:
    the worker's own state of the task (no call to the scheduler), gone or no longer to be
    computed once the client cancels it."""

    def __init__(self, worker: Any, key: str) -> None:
        self.worker, self.key = worker, key

    def is_set(self) -> bool:
        task = self.worker.state.tasks.get(self.key)
        return task is None or task.state in ("cancelled", "released", "forgotten")


def set_heap_thresholds() -> bool:
    """Let glibc keep arrays up to 32 MiB in the heap and return freed memory to the system only
    above 128 MiB (HEAP_THRESHOLDS), for this process; True when set, False where the C library
    is not glibc."""
    mallopt = getattr(ctypes.CDLL(None), "mallopt", None)
    if mallopt is None:
        return False
    return all(mallopt(parameter, size) == 1 for parameter, size in HEAP_THRESHOLDS.items())


def _message(job: Any, outcome: Any) -> str:
    """What a finished job's progress line says by default: its name where it has one."""
    return f"{getattr(job, 'name', 'job')} done"
