"""How much memory a sampling run takes, estimated before it starts, and the refusal of a run
that would not fit in the memory this machine has free.

The estimate follows the arrays that grow with the problem (measured with tracemalloc and peak
RSS on the reference face, N = 100 to 4000; the project's memory benchmark prints estimate
against measurement):

* every run: the substitute's normal equations and regulariser, about 6 (K, K) float64 arrays
  (K = n_u n_v poles, about 4N/9 by default), a fixed part (the domain raster, the default
  grid), and about 8.5 KiB per node of a grid finer than the default;
* each strategy adds its own (``Strategy.memory``): PSO fits its whole swarm at once, about
  1.25 (P/W, K, K) float64 arrays and its fits' lattice tables (at most 16 MiB) in each of
  its W processes, plus a process; the optimal strategy's linearisation, (N, K) and (G, K)
  arrays.

Pairs of points are found by neighbour searches, so nothing of size N^2 is left.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence

from ..geometry.validation import InputError, check_int

FIXED_BYTES = 80 * 2**20
# Every grid node's share of a run (its points, normals and basis values on the evaluation grid
# and the denser check grid), bytes: measured 7.5-9.0 KiB per node on grids of 200 x 200 to 800 x 800,
# whatever N. The default 60 x 60 grid's share is in FIXED_BYTES.
GRID_NODE_BYTES = 8704
DEFAULT_GRID_NODES = 60 * 60
FIT_ARRAYS = 6
FLOAT = 8
# Refuse a run whose estimate exceeds this share of the memory the machine has free.
SAFE_SHARE = 0.8


def base_bytes(poles: Sequence[int], nodes: int = DEFAULT_GRID_NODES) -> int:
    """Memory (bytes) every run needs for a substitute with ``poles`` (n_u, n_v), judged on a
    grid of ``nodes`` nodes."""
    count = poles[0] * poles[1]
    return FIXED_BYTES + GRID_NODE_BYTES * max(nodes - DEFAULT_GRID_NODES, 0) + FIT_ARRAYS * FLOAT * count ** 2


def available_bytes() -> int | None:
    """Memory this machine has free for a new allocation (Linux MemAvailable), bytes, or None
    where the system does not say."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def free_bytes() -> int | None:
    """The free memory runs are checked against, bytes (None: unknown): the environment variable
    CMMSAMPLING_MEMORY_BYTES where set (tests, a batch job's limit), else :func:`available_bytes`."""
    limit = os.environ.get("CMMSAMPLING_MEMORY_BYTES")
    return check_int("CMMSAMPLING_MEMORY_BYTES", int(limit), 1) if limit else available_bytes()


def fits(needed: float, free: float | None) -> bool:
    """True when ``needed`` bytes are within SAFE_SHARE of ``free`` (or free is unknown)."""
    return free is None or needed <= SAFE_SHARE * free


def gib(size: float) -> str:
    """Bytes as a short TiB, GiB or MiB figure for messages."""
    if size >= 2**40:
        return f"{size / 2**40:.1f} TiB"
    return f"{size / 2**30:.1f} GiB" if size >= 2**30 else f"{size / 2**20:.0f} MiB"


def check_fits(needed: float, n: int, largest_n: Callable[[float], int | None], what: str) -> None:
    """ValueError when ``needed`` bytes exceed SAFE_SHARE of the free memory.

    n: the points asked for; largest_n: callable (free bytes) -> the largest N that fits, for the
    message; what: the run in words (strategy and its sizes). The free memory: :func:`free_bytes`.
    """
    free = free_bytes()
    if fits(needed, free):
        return
    assert free is not None   # fits() holds where the free memory is unknown
    largest = largest_n(SAFE_SHARE * free)
    advice = f"at most about n = {largest} fits" if largest else "no run fits"
    raise InputError(
        f"n = {n} needs about {gib(needed)} of memory ({what}), more than the {gib(free)} this "
        f"machine has free; {advice}")
