"""Evaluate a swarm's batched objective on two cores: this process and one worker process.

The swarm's many small numpy operations hold the GIL, so threads do not help; a second process
does. The worker is a plain Python of this process's version (Debian's, also from inside FreeCAD,
whose ``sys.executable`` is the FreeCAD binary), started once and kept for the session.

How it finds the package: the worker is started as ``python -c BOOT FOLDER FD`` in the temporary
folder, where FOLDER is the folder that holds this very ``cmmsampling`` package (a checkout, the
add-on's folder in FreeCAD's Mod folder, an Addon Manager copy, site-packages), put first on the
worker's ``sys.path``. So it imports the same code from any current folder and any install.

When it cannot: the worker answers ("ready", pid) before anything is sent to it; a worker that
exits first (it cannot import the package, no Python of this version) or does not answer within
START_SECONDS is ended, and the swarm runs in this process alone. A worker that dies during a run
is noticed on its closed channel (never a signal: see :mod:`cmmsampling.runtime.channel`), and
its share is computed here. Each particle's fitness is computed exactly as in one process, so the
result is the same either way; :attr:`TwoProcessObjective.fallback` says why one process was used.
"""
from __future__ import annotations

import atexit
import itertools
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .channel import Channel

MIN_PARTICLES = 4
START_SECONDS = 60.0
BOOT = ("import sys; sys.path.insert(0, sys.argv[1]); "
        "from cmmsampling.runtime.worker import main; main(int(sys.argv[2]))")
_tokens = itertools.count()


def python_executable() -> str | None:
    """A Python interpreter of this process's version, also when running inside FreeCAD; None
    where there is none."""
    name = f"python{sys.version_info.major}.{sys.version_info.minor}"
    if os.path.basename(sys.executable).startswith("python"):
        return sys.executable
    candidate = os.path.join(sys.base_exec_prefix, "bin", name)
    return candidate if os.path.exists(candidate) else None


def ignore_broken_pipes() -> None:
    """Let a write to a pipe whose reader has died raise BrokenPipeError instead of ending this
    process. Python's own start-up sets that; FreeCAD 1.0 and 1.1 leave SIGPIPE at its default,
    and a local process ended on Cancel while a pool's thread wrote to it then ended FreeCAD
    (exit 141). Only the main thread may set a handler: called where the workbench starts and
    where local processes or the swarm's worker start; a handler of the host's own is kept."""
    if hasattr(signal, "SIGPIPE") and threading.current_thread() is threading.main_thread() \
            and signal.getsignal(signal.SIGPIPE) == signal.SIG_DFL:
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)


def package_parent() -> str:
    """The folder (or zip file) that holds the imported ``cmmsampling`` package: what a worker
    process puts first on its sys.path."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return os.path.dirname(package)


def single_threaded_environment() -> dict[str, str]:
    """This process's environment with the numeric libraries limited to one thread each (a
    worker process shares the machine's cores with this one)."""
    return dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")


class WorkerUnavailable(RuntimeError):
    """The worker process could not be started or did not answer; the message says why."""


class Worker:
    """One worker process and the channel to it; WorkerUnavailable when it does not start."""

    def __init__(self, executable: str, start_seconds: float = START_SECONDS) -> None:
        ignore_broken_pipes()
        ours, theirs = socket.socketpair()
        self.errors = tempfile.TemporaryFile()
        try:
            self.process = subprocess.Popen(
                [executable, "-c", BOOT, package_parent(), str(theirs.fileno())],
                pass_fds=(theirs.fileno(),), cwd=tempfile.gettempdir(), env=single_threaded_environment(),
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=self.errors)
        except OSError as exc:
            ours.close()
            raise WorkerUnavailable(f"{executable} could not be started ({exc})") from exc
        finally:
            theirs.close()
        self.channel = Channel(ours)
        self.pid = self._handshake(start_seconds)

    def _handshake(self, seconds: float) -> int:
        """The worker's pid from its first message; WorkerUnavailable (the worker ended) when it
        exits or stays silent for ``seconds``."""
        try:
            status, pid = self.channel.receive(seconds)
        except (EOFError, OSError) as exc:
            self.settle()
            reason = self.why(f"did not answer within {seconds:g} s")
            self.close()
            raise WorkerUnavailable(reason) from exc
        return pid

    def settle(self, seconds: float = 5.0) -> None:
        """Give a worker whose channel closed ``seconds`` to exit, so that its exit code is known."""
        try:
            self.process.wait(seconds)
        except subprocess.TimeoutExpired:
            pass

    def why(self, silent: str | None = None) -> str:
        """Why the worker is gone, in words: its exit code and the last line it wrote on stderr
        (e.g. a ModuleNotFoundError, unless it was closed already); ``silent`` when it is still
        running."""
        code = self.process.poll()
        if code is None:
            return f"the second process {silent or 'stopped answering'}"
        lines = []
        if not self.errors.closed:
            self.errors.seek(0)
            lines = self.errors.read().decode(errors="replace").strip().splitlines()
        ending = f"was killed by signal {-code}" if code < 0 else f"exited with code {code}"
        return f"the second process {ending}" + (f": {lines[-1].strip()}" if lines else "")

    def alive(self) -> bool:
        """True while the worker process runs."""
        return self.process.poll() is None

    def send(self, message: Any) -> None:
        """Send a request; OSError when the worker has gone."""
        self.channel.send(message)

    def receive(self) -> Any:
        """The worker's reply payload; EOFError when it has gone, RuntimeError when it reports a failure."""
        status, payload = self.channel.receive()
        if status != "ok":
            raise RuntimeError(f"the second process failed:\n{payload}")
        return payload

    def close(self) -> None:
        """End the worker and close the channel."""
        if self.alive():
            self.process.kill()
        self.process.wait()
        self.channel.close()
        self.errors.close()


_worker: Worker | None = None


def shared_worker() -> tuple[Worker | None, str | None]:
    """The session's worker process, started on first use (or again after it died). Returns
    (worker, None), or (None, the reason in words) where it cannot run."""
    global _worker
    if _worker is not None and _worker.alive():
        return _worker, None
    if _worker is not None:
        _worker.close()
        _worker = None
    executable = python_executable()
    if executable is None:
        return None, f"no python{sys.version_info.major}.{sys.version_info.minor} was found to start it with"
    try:
        _worker = Worker(executable)
    except WorkerUnavailable as exc:
        return None, str(exc)
    return _worker, None


def _close_shared_worker() -> None:
    if _worker is not None:
        _worker.close()


atexit.register(_close_shared_worker)


class SplitChoice:
    """Whether the next swarm is split over the two processes, as measured on this very run.

    At the start of every window, TRIALS calls run each way in turn (split, here alone), timed
    per point set; the rest of the window runs the way whose median was faster. A second process
    beside a CPU-bound one costs more in waiting than it gains (the paper's run took 1.5x as long
    split as here alone, measured), on a quiet machine it can gain: the choice follows the load
    as it changes. A window is WINDOW calls long at first; each time its trials pick the way the
    last ones picked it doubles, up to MAX_WINDOW, and a change of way starts it at WINDOW again.
    So a steady load pays for few trials (beside a busy process a split trial can wait
    milliseconds for a core), and a change of load is followed within MAX_WINDOW calls.
    """

    WINDOW = 60
    MAX_WINDOW = 960
    TRIALS = 3

    def __init__(self) -> None:
        self.window = self.WINDOW
        self.phase = 0
        self.split = True
        self._seconds: dict[bool, list[float]] = {True: [], False: []}

    def next_split(self) -> bool:
        """True when the next call is to be split."""
        return self.phase % 2 == 0 if self.phase < 2 * self.TRIALS else self.split

    def record(self, split: bool, seconds: float) -> None:
        """Count a call that ran ``split`` and took ``seconds`` per point set."""
        phase = self.phase
        self.phase = (phase + 1) % self.window
        if phase >= 2 * self.TRIALS:
            return
        self._seconds[split].append(seconds)
        if phase == 2 * self.TRIALS - 1:
            faster = bool(np.median(self._seconds[True]) < np.median(self._seconds[False]))
            self.window = min(2 * self.window, self.MAX_WINDOW) if faster == self.split else self.WINDOW
            self.split = faster
            self._seconds = {True: [], False: []}


class TwoProcessObjective:
    """Wraps a batched objective f(uv: (P, N, 2)) -> (P,) to split each swarm over two processes.

    The objective must pickle (the engine's DeviationObjective does). Swarms smaller than
    MIN_PARTICLES, and every call after a worker failure, are evaluated here alone; measured:
    split only where that is faster on this run (:class:`SplitChoice`), else every swarm.
    ``evaluations`` counts point sets scored, ``remote`` those the worker scored; ``fallback``
    is None while the worker shares the work, else why it does not (a sentence).
    """

    # A Worker, None after a failure; Any because the lambdas given to _guard use it while it is set,
    # which the type checker cannot follow into a lambda.
    worker: Any

    def __init__(self, objective: Callable[..., np.ndarray], measured: bool = False) -> None:
        self.objective = objective
        self.token = next(_tokens)
        self.worker, self.fallback = shared_worker()
        self.evaluations = 0
        self.remote = 0
        self.choice = SplitChoice() if measured else None
        if self.worker is not None:
            self._guard(lambda: (self.worker.send(("load", self.token, objective)), self.worker.receive()))

    @property
    def parallel(self) -> bool:
        """True while the worker process shares the work."""
        return self.worker is not None

    def check_worker(self) -> None:
        """Notice a worker that has gone while it was not asked (a measured run that scored its
        swarms here alone): it is pinged, and ``fallback`` says why when it does not answer (its
        channel closes when it dies, so a worker just killed is found gone, never taken as alive)."""
        if self.worker is not None:
            self._guard(lambda: (self.worker.send(("ping",)), self.worker.receive()))

    def _guard(self, action: Callable[[], Any]) -> Any:
        """Run a worker action; on any failure drop the worker, say why, and return None."""
        try:
            return action()
        except (OSError, EOFError, RuntimeError) as exc:
            worker, self.worker = self.worker, None
            if isinstance(exc, RuntimeError):
                self.fallback = str(exc).splitlines()[0].rstrip(":") + f": {str(exc).strip().splitlines()[-1]}"
            else:
                worker.settle()
                self.fallback = worker.why()
            return None

    @property
    def beats(self) -> bool:
        """True when the objective takes the values to beat (see DeviationObjective)."""
        return getattr(self.objective, "beats", False)

    def __call__(self, uv: np.ndarray, above: np.ndarray | None = None) -> np.ndarray:
        """The objective's values of uv (P, N, 2), as the objective called alone (above: (P,) or
        None, passed on with the share of each process)."""
        uv = np.asarray(uv, dtype=float)
        self.evaluations += uv.shape[0]
        if self.worker is None or uv.shape[0] < MIN_PARTICLES:
            return self._here(uv, above)
        if self.choice is None:
            return self._split(uv, above)
        split = self.choice.next_split()
        start = time.perf_counter()
        values = self._split(uv, above) if split else self._here(uv, above)
        self.choice.record(split, (time.perf_counter() - start) / uv.shape[0])
        return values

    def _here(self, uv: np.ndarray, above: np.ndarray | None, rows: slice = slice(None)) -> np.ndarray:
        """The objective's values of uv[rows] in this process."""
        return self.objective(uv[rows]) if above is None else self.objective(uv[rows], above[rows])

    def _split(self, uv: np.ndarray, above: np.ndarray | None) -> np.ndarray:
        """The values of uv (P, N, 2), half of them scored by the worker."""
        half = (uv.shape[0] + 1) // 2
        theirs = None if above is None else above[half:]
        sent = self._guard(lambda: self.worker.send(("eval", self.token, uv[half:], theirs)) or True)
        local = self._here(uv, above, slice(None, half) if sent else slice(None))
        if not sent:
            return local
        remote = self._guard(self.worker.receive)
        if remote is None:
            return np.concatenate([local, self._here(uv, above, slice(half, None))])
        self.remote += uv.shape[0] - half
        return np.concatenate([local, remote])
