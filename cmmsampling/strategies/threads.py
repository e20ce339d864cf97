"""BLAS thread control for the many small solves of a swarm.

Debian's numpy links a multithreaded OpenBLAS; for batches of small systems two threads on two
cores were measured about 3x slower than one, so the engine runs its hot loops with one BLAS
thread. threadpoolctl (Debian's python3-threadpoolctl) does the switching; without it the BLAS
keeps its own setting.
"""
import contextlib

try:
    from threadpoolctl import threadpool_limits
except ImportError:
    threadpool_limits = None


def blas_threads(count=1):
    """Context manager limiting BLAS to ``count`` threads (a no-op without threadpoolctl)."""
    if threadpool_limits is None:
        return contextlib.nullcontext()
    return threadpool_limits(limits=count, user_api="blas")
