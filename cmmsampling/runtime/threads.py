"""BLAS thread control for the many small solves of a swarm.

Debian's numpy links a multithreaded OpenBLAS; for batches of small systems two threads on two
cores were measured about 3x slower than one, so the engine runs its hot loops with one BLAS
thread. threadpoolctl (Debian's python3-threadpoolctl) does the switching; without it the BLAS
keeps its own setting. Its controller, which finds the loaded libraries (20 ms each time), is
made once per process.
"""
from __future__ import annotations

import contextlib
import functools
from typing import Any

import numpy  # noqa: F401 (loads the BLAS before the controller looks for it)

try:
    from threadpoolctl import ThreadpoolController
except ImportError:
    ThreadpoolController = None


@functools.lru_cache(maxsize=1)
def _controller() -> Any:
    """The process's ThreadpoolController (the BLAS numpy and scipy loaded at the first call)."""
    return ThreadpoolController()


def blas_threads(count: int = 1) -> contextlib.AbstractContextManager[Any]:
    """Context manager limiting BLAS to ``count`` threads (a no-op without threadpoolctl)."""
    if ThreadpoolController is None:
        return contextlib.nullcontext()
    return _controller().limit(limits=count, user_api="blas")


def blas_description() -> str:
    """The BLAS numpy calls, in words: library, version and the kernels it chose for this
    processor (e.g. "openblas 0.3.21, Haswell kernels"); "unknown" without threadpoolctl."""
    if ThreadpoolController is None:
        return "unknown"
    found = [info for info in _controller().info() if info.get("user_api") == "blas"]
    if not found:
        return "unknown"
    info = found[0]
    kernels = f", {info['architecture']} kernels" if info.get("architecture") else ""
    return f"{info.get('internal_api', '?')} {info.get('version') or ''}".strip() + kernels
