"""Evaluate a swarm's batched objective on two cores: this process and one worker process.

The swarm's many small numpy operations hold the GIL, so threads do not help; a second process
does. The worker is a plain ``python -m cmmsampling.strategies.worker`` started once (with Debian's Python,
also from inside FreeCAD, whose ``sys.executable`` is the FreeCAD binary) and kept for the
session. Each particle's fitness is computed exactly as in one process, so results are identical.
While a run goes on, both sides poll for the other's message instead of blocking (see
:func:`cmmsampling.strategies.worker.wait_for`). If the worker cannot be started or fails, evaluation
continues in this process alone.
"""
import atexit
import itertools
import os
import subprocess
import sys
from multiprocessing.connection import Connection

import numpy as np

from .worker import wait_for

MIN_PARTICLES = 4
_tokens = itertools.count()


def python_executable():
    """A Python interpreter of this process's version, also when running inside FreeCAD."""
    name = f"python{sys.version_info.major}.{sys.version_info.minor}"
    if os.path.basename(sys.executable).startswith("python"):
        return sys.executable
    candidate = os.path.join(sys.base_exec_prefix, "bin", name)
    return candidate if os.path.exists(candidate) else None


class Worker:
    """One worker process with a pipe in each direction."""

    def __init__(self, executable):
        to_child_r, to_child_w = os.pipe()
        from_child_r, from_child_w = os.pipe()
        package_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        env = dict(os.environ, PYTHONPATH=package_root, OPENBLAS_NUM_THREADS="1",
                   OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        self.process = subprocess.Popen(
            [executable, "-m", "cmmsampling.strategies.worker", str(to_child_r), str(from_child_w)],
            pass_fds=(to_child_r, from_child_w), env=env, stdin=subprocess.DEVNULL,
            close_fds=True,
        )
        os.close(to_child_r)
        os.close(from_child_w)
        self.send = Connection(to_child_w, readable=False).send
        self._incoming = Connection(from_child_r, writable=False)
        self.loaded = None

    def receive(self):
        """The worker's reply payload; RuntimeError when it reports a failure."""
        wait_for(self._incoming)
        status, payload = self._incoming.recv()
        if status != "ok":
            raise RuntimeError(f"worker process failed:\n{payload}")
        return payload

    def close(self):
        """End the worker (it exits when its pipe closes)."""
        self.process.kill()
        self.process.wait()


_worker = None


def shared_worker():
    """The session's worker process, started on first use; None where it cannot run."""
    global _worker
    if _worker is not None and _worker.process.poll() is None:
        return _worker
    executable = python_executable()
    if executable is None:
        return None
    try:
        _worker = Worker(executable)
    except OSError:
        return None
    return _worker


def _close_shared_worker():
    if _worker is not None:
        _worker.close()


atexit.register(_close_shared_worker)


class TwoProcessObjective:
    """Wraps a batched objective f(uv: (P, N, 2)) -> (P,) to split each swarm over two processes.

    The objective must pickle (the engine's DeviationObjective does). Swarms smaller than
    MIN_PARTICLES, and every call after a worker failure, are evaluated here alone.
    ``evaluations`` counts point sets scored; ``parallel`` says whether the worker is in use.
    """

    def __init__(self, objective):
        self.objective = objective
        self.token = next(_tokens)
        self.worker = shared_worker()
        self.evaluations = 0
        if self.worker is not None:
            self._guard(lambda: (self.worker.send(("load", self.token, objective)), self.worker.receive()))

    @property
    def parallel(self):
        """True while the worker process shares the work."""
        return self.worker is not None

    def _guard(self, action):
        """Run a worker action; on any failure drop the worker and return None."""
        try:
            return action()
        except (OSError, EOFError, RuntimeError):
            self.worker = None
            return None

    def __call__(self, uv):
        uv = np.asarray(uv, dtype=float)
        self.evaluations += uv.shape[0]
        if self.worker is None or uv.shape[0] < MIN_PARTICLES:
            return self.objective(uv)
        half = (uv.shape[0] + 1) // 2
        sent = self._guard(lambda: self.worker.send(("eval", self.token, uv[half:])) or True)
        local = self.objective(uv[:half] if sent else uv)
        if not sent:
            return local
        remote = self._guard(self.worker.receive)
        if remote is None:
            return np.concatenate([local, self.objective(uv[half:])])
        return np.concatenate([local, remote])
