"""The worker process of :mod:`cmmsampling.parallel`: ``python -m cmmsampling.worker READ_FD WRITE_FD``.

It receives a batched objective once (pickled, pure numpy) and then evaluates the point sets it
is sent, until the parent closes the pipe. Requests: ("load", token, objective),
("eval", token, uv (P, N, 2)). Replies: ("ok", values (P,)) or ("error", message).
"""
import sys
import traceback
from multiprocessing.connection import Connection


def serve(incoming, outgoing):
    """Answer requests until the parent goes away."""
    objectives = {}
    while True:
        try:
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
