"""Measure probe points on a live CMM over I++ DME: :func:`measure`.

The commands, in order (docs/live-cmm.md): ``StartSession()``; ``IsHomed()`` and ``Home()`` where
the machine is not homed; ``EnumTools()`` and ``ChangeTool("...")`` (the first tool listed unless
one is named); ``OnPtMeasReport(X(),Y(),Z(),IJK(),ER())``; per point the moves before it
(``GoTo``: the plan's collision-free path where it has one, else its approach point along the
normal) and ``PtMeas(X(),Y(),Z(),IJK())``; ``EndSession()``. Each report is the ball centre, the
surface's vector and the tool's effective radius: the contact point is the centre less the radius
along the vector. A Cancel during a move sends ``AbortE()`` and ``ClearAllErrors()``; every run
that reaches the server ends its session, and the points measured so far are written.
"""
from __future__ import annotations

import os
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..formats.exporting import along_moves, as_point_set, export
from ..formats.files import check_writable
from ..formats.pointfiles import resolve_format
from ..formats.pointset import PointSet
from ..geometry.validation import InputError, check_real
from .answers import ResponseError, parse_response
from .protocol import LINE_END, point_arguments, tag_text

DEFAULT_PORT = 1294
# The formats the measured points are written in: those read back as measured points.
MEASURED_FORMATS = ("csv", "xyz")
# mm before each point along its normal, where the plan has no probe of its own.
APPROACH_MM = 5.0
POLL_S = 0.1
# The longest wait (s) for each answer while a stopped session is ended.
CLEANUP_S = 5.0
REPORT = "OnPtMeasReport(X(),Y(),Z(),IJK(),ER())"


class MeasurementStopped(RuntimeError):
    """The run stopped before its last point: an I++ error, a lost connection or a time-out
    (the message says which). ``run``: the MeasuredRun of the points measured before, written;
    ``connection_lost``: the connection is gone (nothing more can be sent on it)."""

    def __init__(self, message: str, run: MeasuredRun | None = None, connection_lost: bool = False) -> None:
        super().__init__(message)
        self.run = run
        self.connection_lost = connection_lost


class _Cancelled(Exception):
    """The progress callback asked to stop."""


@dataclass
class MeasuredRun(os.PathLike):
    """What :func:`measure` measured: path (the file written; the run is a path-like, so
    ``cmmsampling.inspect(result, run)`` reads it), labels measured, missing (planned labels not
    measured), tool and its ball radius (mm), cancelled, commands (every line sent, in order),
    server ('host:port')."""

    path: str
    labels: list
    missing: list
    tool: str
    radius: float
    server: str
    cancelled: bool = False
    commands: list = field(default_factory=list)

    def __fspath__(self):
        return self.path

    def __str__(self):
        written = f"wrote {self.path}" if self.labels else "nothing written"
        line = (f"Measured {len(self.labels)} of {len(self.labels) + len(self.missing)} points over I++ DME at "
                f"{self.server} (tool {self.tool or 'none'}, ball radius {self.radius:g} mm); {written}.")
        if self.missing:
            line += (f" Not measured{' (cancelled)' if self.cancelled else ''}: {', '.join(self.missing[:8])}"
                     f"{' ...' if len(self.missing) > 8 else ''}.")
        return line


def server_address(server):
    """(host, port) of 'host:port' or 'host' (port DEFAULT_PORT); InputError for another form."""
    host, _, port = str(server).rpartition(":") if ":" in str(server) else (str(server), "", str(DEFAULT_PORT))
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise InputError(f"server {server!r}: give the I++ DME server as 'host:port', e.g. '127.0.0.1:1294'")
    return host, int(port)


class Connection:
    """One I++ DME session's socket: send a command, collect its answers."""

    def __init__(self, sock, timeout_s, progress, log):
        self.sock, self.timeout_s, self.progress, self.log = sock, timeout_s, progress, log
        self.buffer, self.count, self.commands, self.running = b"", 0, [], None

    def call(self, method):
        """Send method with the next tag; the data answers (list of Answer). MeasurementStopped
        for an error answer, a time-out or a lost connection; _Cancelled on Cancel (``running``
        keeps the command that has not finished, for :meth:`abort`)."""
        self.count += 1
        tag = tag_text(self.count)
        self.send(f"{tag} {method}")
        self.running = (tag, method)
        data = self.answers(tag, method)
        self.running = None
        return data

    def send(self, line):
        """Write one command line."""
        self.commands.append(line)
        self.log.append(f"> {line}")
        try:
            self.sock.sendall((line + LINE_END).encode("ascii"))
        except OSError as exc:
            raise MeasurementStopped(f"the connection to the CMM was lost sending {line!r} ({exc})",
                                     connection_lost=True) from None

    def answers(self, tag, method, cancellable=True):
        """Read lines until tag's '%'; its '#' answers."""
        data, error, deadline = [], None, time.monotonic() + self.timeout_s
        while True:
            line = self.line(deadline, f"{tag} {method}", cancellable)
            try:
                answer = parse_response(line)
            except ResponseError as exc:
                raise MeasurementStopped(f"the CMM answered {tag} {method} with {line!r}, which is not I++ DME "
                                         f"({exc})") from None
            if answer.tag != tag:
                continue
            if answer.kind == "#":
                data.append(answer)
            elif answer.kind == "!":
                error = answer
            elif answer.kind == "%":
                if error is not None:
                    self.running = None
                    raise MeasurementStopped(f"the CMM answered {tag} {method} with I++ error {error.code:04d} "
                                             f"(severity {error.severity}): {error.text}")
                return data

    def line(self, deadline, what, cancellable):
        """The next line from the server; asks progress(None) between reads whether to cancel."""
        while b"\n" not in self.buffer:
            if cancellable and self.progress is not None and self.progress(None):
                raise _Cancelled
            if time.monotonic() > deadline:
                raise MeasurementStopped(f"no answer from the CMM to {what} within {self.timeout_s:g} s")
            try:
                chunk = self.sock.recv(4096)
            except socket.timeout:
                continue
            except OSError as exc:
                raise MeasurementStopped(f"the connection to the CMM was lost during {what} ({exc})",
                                         connection_lost=True) from None
            if not chunk:
                raise MeasurementStopped(f"the CMM closed the connection during {what}", connection_lost=True)
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\n", 1)
        text = line.rstrip(b"\r").decode("ascii", "replace")
        self.log.append(f"< {text}")
        return text

    def abort(self):
        """Stop the running command (AbortE on the fast queue: a move stops), wait for its end and
        clear the error it leaves; each wait at most CLEANUP_S, a failure ignored (the session
        is ending)."""
        if self.running is not None:
            tag = self.running[0]
            try:
                self.send(f"{tag_text(self.count, fast=True)} AbortE()")
                deadline = time.monotonic() + min(self.timeout_s, CLEANUP_S)
                while self.line(deadline, "AbortE()", False) != f"{tag} %":
                    pass
            except (MeasurementStopped, ResponseError):
                pass
            self.running = None
        self.quietly("ClearAllErrors()")

    def quietly(self, method):
        """A command whose error or time-out (after CLEANUP_S) does not matter any more (ending
        a session)."""
        timeout, self.timeout_s = self.timeout_s, min(self.timeout_s, CLEANUP_S)
        try:
            self.count += 1
            tag = tag_text(self.count)
            self.send(f"{tag} {method}")
            self.answers(tag, method, cancellable=False)
        except (MeasurementStopped, ResponseError):
            pass
        finally:
            self.timeout_s = timeout


def measure(source: object, server: str, out: str | os.PathLike = "measured.csv", tool: str | None = None,
            progress: Callable[[str | None], bool | None] | None = None, timeout_s: float = 60.0,
            log: str | os.PathLike | None = None) -> MeasuredRun:
    """Measure the planned points of source (a SamplingResult, PartPlan, PointSet or the
    workbench's probe points) on the CMM behind an I++ DME server and write the contact points.

    server: 'host:port'; out: the file, CSV (.csv) or XYZIJK (.xyz, .txt), read back by
    :func:`cmmsampling.inspect`; tool: the tool's name (default: the first the server lists);
    progress: callable(message) before each point (message 'point k of N') and while waiting
    (None), returning True to cancel; timeout_s: the longest wait for one command's answers;
    log: a file for the session's transcript ('> ' sent, '< ' received).
    Returns a MeasuredRun (a path-like of out). A Cancel returns the points measured so far
    (``cancelled``); an I++ error, a lost connection or a time-out raises MeasurementStopped
    after writing them (its ``run``). InputError before connecting for bad arguments.
    """
    host, port = server_address(server)
    fmt = resolve_format(out)
    if fmt not in MEASURED_FORMATS:
        raise InputError(f"{os.fspath(out)}: measured points are written as CSV (.csv) or XYZIJK (.xyz, .txt), the "
                         "files cmmsampling.inspect reads back")
    check_writable(out)
    timeout_s = check_real("timeout_s", timeout_s, above=0.0)
    planned, moves = _planned_path(source)
    try:
        sock = socket.create_connection((host, port), timeout=min(timeout_s, 10.0))
    except OSError as exc:
        raise MeasurementStopped(f"cannot reach the I++ DME server at {host}:{port} ({exc}); is it running and "
                                 "is the address right?") from None
    sock.settimeout(POLL_S)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    transcript: list[str] = []
    connection = Connection(sock, timeout_s, progress, transcript)
    touched: dict[str, tuple] = {}
    state = {"tool": "", "radius": 0.0, "cancelled": False}
    stopped = None
    try:
        _session(connection, planned, moves, tool, progress, touched, state)
    except _Cancelled:
        state["cancelled"] = True
        connection.abort()
    except MeasurementStopped as exc:
        stopped = exc
        if not exc.connection_lost:
            connection.abort()
    finally:
        if stopped is None or not stopped.connection_lost:
            connection.quietly("EndSession()")
        sock.close()
        if log is not None:
            with open(log, "w", encoding="ascii", errors="replace") as stream:
                stream.write("\n".join(transcript) + "\n")
    run = _written(planned, touched, out, state, f"{host}:{port}", connection.commands)
    if stopped is not None:
        raise MeasurementStopped(f"{stopped}; {run}", run) from None
    return run


def _planned_path(source):
    """(the planned PointSet in measuring order, the travel before each point or None): a
    PointSet with its travel (already in the path's order) as it is, a plan or result made with
    a probe along its collision-free path."""
    from ..access.probe_moves import probe_moves

    if isinstance(source, PointSet) and source.travel is not None:
        return source, source.travel
    planned = as_point_set(source)
    try:
        moves = probe_moves(source)
    except (InputError, TypeError, AttributeError):
        return planned, None
    ordered = along_moves(planned, moves)
    return ordered, ordered.travel


def _session(connection, planned, moves, tool, progress, touched, state):
    """The session's commands up to the last point (touched: {label: (contact, vector)})."""
    connection.call("StartSession()")
    if connection.call("IsHomed()")[0].args != (1.0,):
        connection.call("Home()")
    tools = [answer.args[0] for answer in connection.call("EnumTools()") if answer.form == "String"]
    if not tools or (tool is not None and tool not in tools):
        raise MeasurementStopped(f"the CMM has no tool {tool!r}; it lists {', '.join(tools) or 'none'}"
                                 if tool is not None else "the CMM lists no tool")
    state["tool"] = tool or tools[0]
    connection.call(f'ChangeTool("{state["tool"]}")')
    connection.call(REPORT)
    count = len(planned)
    for index in range(count):
        if progress is not None and progress(f"point {index + 1} of {count}"):
            raise _Cancelled
        point, vector = planned.points[index], planned.normals[index]
        if moves is not None:
            for position in np.concatenate([part for part in moves[index] if len(part)] or [np.empty((0, 3))]):
                connection.call(f"GoTo({point_arguments(position)})")
        else:
            connection.call(f"GoTo({point_arguments(point + (APPROACH_MM + state['radius']) * vector)})")
        report = connection.call(f"PtMeas({point_arguments(point, vector)})")[0].props
        normal = np.array(report["IJK"], dtype=float)
        state["radius"] = report["ER"][0]
        centre = np.array([report[axis][0] for axis in "XYZ"])
        touched[planned.labels[index]] = (centre - state["radius"] * normal / np.linalg.norm(normal), normal)


def _written(planned, touched, out, state, server, commands):
    """Write the contact points measured (in the planned order) and return the MeasuredRun."""
    labels = [label for label in planned.labels if label in touched]
    missing = [label for label in planned.labels if label not in touched]
    if labels:
        points = np.array([touched[label][0] for label in labels])
        vectors = np.array([touched[label][1] for label in labels])
        metadata = {"source": f"measured over I++ DME at {server}", "tool": state["tool"],
                    "tool_radius_mm": state["radius"]}
        if missing:
            metadata["not_measured"] = " ".join(missing)
        export(PointSet(labels, points, vectors, metadata=metadata), out)
    return MeasuredRun(os.path.abspath(os.fspath(out)), labels, missing, state["tool"], state["radius"], server,
                       state["cancelled"], list(commands))
