"""Independent per-face runs, in parallel: in this process, on local processes or on a Dask cluster.

A job is plain data (the face as a BREP string, numbers, names) and its outcome is plain data,
so both cross process and machine boundaries. Local processes are started with this Python
(also from inside FreeCAD, whose ``sys.executable`` is the FreeCAD binary) by the ``spawn``
method; a Dask cluster is reached through ``distributed.Client`` (Debian's python3-distributed).

Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes glibc's
mmap threshold at 128 KiB: every temporary array of the fit and the deviation is then mapped and
unmapped anew, and a face took 1.65x as long (22.5 s against 13.6 s, measured). A job run on Dask
first sets glibc's thresholds back to sizes that keep those arrays in the heap.
"""
import concurrent.futures
import ctypes
import multiprocessing
import os

from ..geometry.validation import check_int
from ..strategies.parallel import python_executable


def run_all(function, jobs, processes=None, scheduler=None, progress=None, describe=None):
    """``function(job)`` for every job; returns the outcomes in the jobs' order.

    function: a module-level function (picklable); jobs: a list of picklable jobs;
    processes: local processes (None: all cores; 1 runs here, one job after another);
    scheduler: a Dask scheduler address ("tcp://host:8786") or a distributed.Client, which then
    runs the jobs instead of local processes; progress: callable(done, total, message) after
    each job ends, returning True to cancel: jobs not started are dropped, running ones are
    stopped, and their outcomes are None; describe: callable(job, outcome) -> the progress
    message of a finished job (default: "<job.name> done").
    """
    total = len(jobs)
    outcomes = [None] * total
    if scheduler is not None:
        runs = _dask_runs(function, jobs, scheduler)
    else:
        count = _process_count(processes, total)
        runs = _here(function, jobs) if count == 1 else _local_processes(function, jobs, count)
    describe = describe or _message
    try:
        for done, (index, outcome) in enumerate(runs, start=1):
            outcomes[index] = outcome
            if progress is not None and progress(done, total, describe(jobs[index], outcome)):
                break
    finally:
        runs.close()
    return outcomes


def _process_count(processes, jobs):
    """Processes to start: the given count (>= 1) or all cores, never more than jobs."""
    count = (os.cpu_count() or 1) if processes is None else check_int("processes", processes, 1)
    return max(1, min(count, jobs))


def _here(function, jobs):
    """Each job in this process, in order: (index, outcome)."""
    for index, job in enumerate(jobs):
        yield index, function(job)


def _local_processes(function, jobs, count):
    """The jobs on ``count`` local processes as they end: (index, outcome); closing the
    generator early stops the processes."""
    context = multiprocessing.get_context("spawn")
    executable = python_executable()
    if executable is not None:
        context.set_executable(executable)
    pool = concurrent.futures.ProcessPoolExecutor(count, mp_context=context)
    futures = {pool.submit(function, job): index for index, job in enumerate(jobs)}
    try:
        for future in concurrent.futures.as_completed(futures):
            yield futures[future], future.result()
    finally:
        _stop(pool)


def _stop(pool):
    """Shut a process pool down now: pending jobs cancelled, running processes terminated."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(5)


def _dask_runs(function, jobs, scheduler):
    """The jobs on a Dask cluster as they end: (index, outcome); closing the
    generator early cancels the jobs still queued or running."""
    from distributed import Client, as_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    futures = [client.submit(run_with_heap_thresholds, function, job, pure=False) for job in jobs]
    where = {future.key: index for index, future in enumerate(futures)}
    try:
        for future in as_completed(futures):
            yield where[future.key], future.result()
    finally:
        client.cancel([future for future in futures if not future.done()])
        if client is not scheduler:
            client.close()


# glibc's mallopt parameters and the sizes set for a Dask worker's jobs (bytes).
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
HEAP_THRESHOLDS = {M_TRIM_THRESHOLD: 128 * 2 ** 20, M_MMAP_THRESHOLD: 32 * 2 ** 20}


def run_with_heap_thresholds(function, job):
    """``function(job)`` after :func:`set_heap_thresholds` (a job on a Dask worker)."""
    set_heap_thresholds()
    return function(job)


def set_heap_thresholds():
    """Let glibc keep arrays up to 32 MiB in the heap and return freed memory to the system only
    above 128 MiB (HEAP_THRESHOLDS), for this process; True when set, False where the C library
    is not glibc."""
    mallopt = getattr(ctypes.CDLL(None), "mallopt", None)
    if mallopt is None:
        return False
    return all(mallopt(parameter, size) == 1 for parameter, size in HEAP_THRESHOLDS.items())


def _message(job, outcome):
    """What a finished job's progress line says by default: its name where it has one."""
    return f"{getattr(job, 'name', 'job')} done"
