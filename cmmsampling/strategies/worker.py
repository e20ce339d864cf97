"""The worker process of :mod:`cmmsampling.strategies.parallel`: ``python -m cmmsampling.strategies.worker READ_FD WRITE_FD``.

It receives a batched objective once (pickled, pure numpy) and then evaluates the point sets it
is sent, until the parent closes the pipe. Requests: ("load", token, objective),
("eval", token, uv (P, N, 2)). Replies: ("ok", values (P,)) or ("error", message).
"""
import sys
import time
import traceback
from multiprocessing.connection import Connection

SPIN_SECONDS = 0.05


def wait_for(connection, seconds=SPIN_SECONDS):
    """Wait until ``connection`` has data, polling without sleeping for up to ``seconds`` first.

    A swarm's requests and replies follow each other about every millisecond. A process that
    blocks on a pipe is woken slowly on a virtual machine, and runs slower for a while after it,
    so both sides poll while a run is going on; after ``seconds`` of silence they block (recv).
    """
    end = time.perf_counter() + seconds
    while not connection.poll(0) and time.perf_counter() < end:
        pass


def serve(incoming, outgoing):
    """Answer requests until the parent goes away."""
    objectives = {}
    while True:
        try:
            wait_for(incoming)
            request = incoming.recv()
        except (EOFError, OSError):
            return
        try:
            if request[0] == "load":
                objectives.clear()
                objectives[request[1]] = request[2]
                outgoing.send(("ok", None))
            else:
                outgoing.send(("ok", objectives[request[1]](request[2])))
        except Exception:  # report every failure to the parent, which falls back to one process
            outgoing.send(("error", traceback.format_exc()))


if __name__ == "__main__":
    serve(Connection(int(sys.argv[1]), writable=False), Connection(int(sys.argv[2]), readable=False))
