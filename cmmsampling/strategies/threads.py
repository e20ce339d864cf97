"""BLAS thread control for the many small solves of a swarm.

Debian's numpy links a multithreaded OpenBLAS; for batches of small systems two threads on two
cores were measured about 3x slower than one, so the engine runs its hot loops with one BLAS
thread. threadpoolctl (Debian's python3-threadpoolctl) does the switching; without it the BLAS
keeps its own setting. Its controller, which finds the loaded libraries (20 ms each time), is
made once per process.
"""
import contextlib
import functools

try:
    from threadpoolctl import ThreadpoolController
except ImportError:
    ThreadpoolController = None


@functools.lru_cache(maxsize=1)
def _controller():
    """The process's ThreadpoolController (the BLAS numpy and scipy loaded at the first call)."""
    return ThreadpoolController()


def blas_threads(count=1):
    """Context manager limiting BLAS to ``count`` threads (a no-op without threadpoolctl)."""
    if ThreadpoolController is None:
        return contextlib.nullcontext()
    return _controller().limit(limits=count, user_api="blas")
