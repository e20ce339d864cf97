"""The worker process of :mod:`cmmsampling.runtime.parallel`.

Started as ``python -c BOOT PACKAGE_PARENT SOCKET_FD`` (see :data:`cmmsampling.runtime.parallel.BOOT`):
it first answers ("ready", its pid), then receives a batched objective once (pickled, pure numpy)
and evaluates the point sets it is sent, until the parent closes the channel or dies. Requests:
("load", token, objective), ("eval", token, uv (P, N, 2), above (P,) or None), ("ping",).
Replies: ("ok", values (P,)) or ("error", message).
"""
from __future__ import annotations

import os
import socket
import traceback
from typing import Any

from .channel import Channel


def main(fd: int) -> None:
    """Serve the parent on the socket ``fd`` until it goes away."""
    channel = Channel(socket.socket(fileno=fd))
    try:
        channel.send(("ready", os.getpid()))
    except OSError:
        return
    serve(channel)


def serve(channel: Channel) -> None:
    """Answer requests until the parent closes the channel or has gone."""
    objectives: dict[int, Any] = {}
    while True:
        try:
            request = channel.receive()
        except (EOFError, OSError):
            return
        try:
            reply = _answer(request, objectives)
        except Exception:  # every failure goes to the parent, which then goes on in one process
            reply = ("error", traceback.format_exc())
        try:
            channel.send(reply)
        except OSError:
            return


def _answer(request: tuple[Any, ...], objectives: dict[int, Any]) -> tuple[str, Any]:
    """The reply to one request; objectives: {token: objective} (only the last one loaded)."""
    if request[0] == "load":
        objectives.clear()
        objectives[request[1]] = request[2]
        return ("ok", None)
    if request[0] == "ping":
        return ("ok", None)
    objective, uv, above = objectives[request[1]], request[2], request[3]
    return ("ok", objective(uv) if above is None else objective(uv, above))
