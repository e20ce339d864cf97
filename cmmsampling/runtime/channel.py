"""Messages between this process and a worker process over a socket pair, never a signal.

Each message is a pickled Python object behind its length (8 bytes, big-endian). Sending uses
``MSG_NOSIGNAL``: when the other side is gone, ``send`` raises ``BrokenPipeError`` instead of
raising SIGPIPE, which would end FreeCAD 1.0 and 1.1 (their embedded Python does not ignore that
signal, as a plain Python does). Waiting blocks in ``poll`` after a short spin, so a waiting side
leaves its core to the computing one.
"""
from __future__ import annotations

import pickle
import select
import socket
import struct
import time
from typing import Any

HEADER = struct.Struct("!Q")
SPIN_SECONDS = 2e-4
NO_SIGNAL = getattr(socket, "MSG_NOSIGNAL", 0)


class ChannelClosed(EOFError):
    """The other side closed the channel (it exited or was killed)."""


class Channel:
    """One end of a socket pair carrying pickled messages."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self._poller = select.poll()
        self._poller.register(sock, select.POLLIN | select.POLLHUP | select.POLLERR)

    def fileno(self) -> int:
        """The socket's file descriptor."""
        return self.sock.fileno()

    def send(self, message: Any) -> None:
        """Send one picklable object; BrokenPipeError (or another OSError) when the other side is gone."""
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        self.sock.sendall(HEADER.pack(len(data)) + data, NO_SIGNAL)

    def ready(self, timeout: float | None) -> bool:
        """True when a message (or the other side's end) can be read within ``timeout`` seconds
        (None: wait as long as it takes). Spins for SPIN_SECONDS first, then blocks."""
        end = time.perf_counter() + SPIN_SECONDS
        while time.perf_counter() < end:
            if self._poller.poll(0):
                return True
        return bool(self._poller.poll(None if timeout is None else 1000.0 * timeout))

    def receive(self, timeout: float | None = None) -> Any:
        """The next message; TimeoutError when none comes within ``timeout`` seconds (None: no
        limit); ChannelClosed when the other side has gone."""
        if not self.ready(timeout):
            raise TimeoutError(f"no answer within {timeout:g} s")
        size = HEADER.unpack(self._read(HEADER.size))[0]
        return pickle.loads(self._read(size))

    def _read(self, size: int) -> bytes:
        """Exactly ``size`` bytes; ChannelClosed at the end of the stream."""
        chunks, left = [], size
        while left:
            chunk = self.sock.recv(min(left, 1 << 20))
            if not chunk:
                raise ChannelClosed("the other process closed the channel")
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)

    def close(self) -> None:
        """Close this end."""
        self.sock.close()

