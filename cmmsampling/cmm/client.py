"""Measure probe points on a live CMM over I++ DME: :func:`measure`.

The commands, in order (docs/live-cmm.md): ``StartSession()``; ``IsHomed()`` and ``Home()`` where
the machine is not homed; ``EnumTools()`` and ``ChangeTool("...")`` (the first tool listed unless
one is named); ``OnPtMeasReport(X(),Y(),Z(),IJK(),ER())``; per point the moves before it
(``GoTo``: the plan's collision-free path where it has one, else its approach point along the
normal) and ``PtMeas(X(),Y(),Z(),IJK())``; ``EndSession()``. Each report is the ball centre, the
surface's vector and the tool's effective radius: the contact point is the centre less the radius
along the vector.

Nothing measured is lost: the output file is rewritten whole after each point (a temporary file,
fsync, rename: it always reads back) and the transcript is written line by line as it goes, so
whatever ends the run (an I++ error, a lost link, Cancel, Ctrl-C, an exception, kill -9) the
points measured before it are on disk. A run that stops ends its session as far as the link
allows (``AbortE()`` for a running command, ``ClearAllErrors()``, ``EndSession()``).
Answers are read as the specification 1.4.3 says: errors of severity 0 and 1 are warnings
(section 8.1: the run goes on, the warning kept); an error of severity 2 or more, the command's
own or unsolicited (tag ``E0000``), stops the run at once with the CMM's text; a point report
that is incomplete, not finite, outside the machine volume, or off in scale (a ball radius or
distances between points far from the tool's and the plan's: a server speaking inches) stops it
naming the value.
"""
from __future__ import annotations

import os
import re
import socket
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..formats.exporting import along_moves, as_point_set, export
from ..formats.files import check_writable
from ..formats.pointfiles import resolve_format
from ..formats.pointset import PointSet
from ..formats.registry import FORMATS, live_records
from ..geometry.validation import InputError, check_real
from .answers import IPPSIZE, ResponseError, parse_response
from .protocol import LINE_END, point_arguments, tag_text

DEFAULT_PORT = 1294
# mm before each point along its normal, where the plan has no probe of its own.
APPROACH_MM = 5.0
POLL_S = 0.1
# The longest wait (s) for each answer while a stopped session is ended.
CLEANUP_S = 5.0
REPORT = "OnPtMeasReport(X(),Y(),Z(),IJK(),ER())"
REPORTED = ("X", "Y", "Z", "IJK", "ER")
# The machine volume where none is stated: each axis within +-10 m of the machine's zero (mm).
DEFAULT_REACH_MM = 10_000.0
# A reported ball radius, or a distance between two measured points, more than this factor from
# the tool's radius or the planned distance is refused (an inch is 25.4 mm).
SCALE_FACTOR = 2.0
# Planned distances shorter than this (mm) do not test the scale (form error and misplacement).
SCALE_MIN_MM = 5.0
# The most characters of a CMM's line quoted in a message.
QUOTE_CHARS = 200
# Severity classes (section 8.1): below this an error is a warning and the command goes on.
STOPPING_SEVERITY = 2
UNSOLICITED = "E0000"


class MeasurementStopped(RuntimeError):
    """The run stopped before its last point: an I++ error, a lost connection, a time-out, an
    implausible answer or an exception (the message says which). ``run``: the MeasuredRun of the
    points measured before, written; ``connection_lost``: the connection is gone (nothing more
    can be sent on it)."""

    def __init__(self, message: str, run: MeasuredRun | None = None, connection_lost: bool = False) -> None:
        super().__init__(message)
        self.run = run
        self.connection_lost = connection_lost


class _Cancelled(Exception):
    """The progress callback asked to stop."""


class _CallbackFailed(Exception):
    """The progress callback raised (the exception is the cause)."""


@dataclass
class MeasuredRun(os.PathLike):
    """What :func:`measure` measured: path (the file written; the run is a path-like, so
    ``cmmsampling.inspect(result, run)`` reads it), labels measured, missing (planned labels not
    measured), tool and its ball radius (mm), cancelled, commands (every line sent, in order),
    server ('host:port'), warnings (the CMM's errors of severity 0 and 1, as text)."""

    path: str
    labels: list
    missing: list
    tool: str
    radius: float
    server: str
    cancelled: bool = False
    commands: list = field(default_factory=list)
    warnings: list = field(default_factory=list)

    def __fspath__(self):
        return self.path

    def __str__(self):
        written = f"wrote {self.path}" if self.labels else "nothing written"
        line = (f"Measured {len(self.labels)} of {len(self.labels) + len(self.missing)} points over I++ DME at "
                f"{self.server} (tool {self.tool or 'none'}, ball radius {self.radius:g} mm); {written}.")
        if self.missing:
            line += (f" Not measured{' (cancelled)' if self.cancelled else ''}: {', '.join(self.missing[:8])}"
                     f"{' ...' if len(self.missing) > 8 else ''}.")
        if self.warnings:
            line += f" Warnings ({len(self.warnings)}): {self.warnings[0]}{' ...' if len(self.warnings) > 1 else ''}."
        return line


def cut(text: str, limit: int = QUOTE_CHARS) -> str:
    """text cut to limit characters (its length stated) for a message."""
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def quoted(text: str, limit: int = QUOTE_CHARS) -> str:
    """text in quotes, cut to limit characters (its length stated) for a message."""
    return repr(text) if len(text) <= limit else f"{text[:limit]!r}... ({len(text)} characters)"


def server_address(server: object) -> tuple[str, int]:
    """(host, port) of 'host:port', 'host' (port DEFAULT_PORT), '[IPv6]:port' or '[IPv6]';
    InputError for another form or no server."""
    if not isinstance(server, str) or not server.strip():
        raise InputError(f"no I++ DME server given ({server!r}); give it as 'host:port', e.g. '127.0.0.1:1294'")
    text = server.strip()
    bracketed = re.fullmatch(r"\[([^\[\]]+)\](?::(.*))?", text)
    if bracketed:
        host, port = bracketed[1], bracketed[2] if bracketed[2] is not None else str(DEFAULT_PORT)
    elif text.count(":") > 1:
        raise InputError(f"server {server!r}: write an IPv6 address in brackets, e.g. '[::1]:1294'")
    else:
        host, _, port = text.partition(":") if ":" in text else (text, "", str(DEFAULT_PORT))
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise InputError(f"server {server!r}: give the I++ DME server as 'host:port', e.g. '127.0.0.1:1294'")
    return host, int(port)


def address_text(host: str, port: int) -> str:
    """'host:port', the host in brackets where it is an IPv6 address."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def machine_volume(volume: object) -> np.ndarray:
    """(2, 3) mm: the lowest and highest x, y, z a CMM may report, of ((x0, y0, z0), (x1, y1, z1))
    or None (+-DEFAULT_REACH_MM); InputError for another form."""
    if volume is None:
        return np.array([[-DEFAULT_REACH_MM] * 3, [DEFAULT_REACH_MM] * 3])
    try:
        box = np.array(volume, dtype=float)
    except (TypeError, ValueError):
        box = np.empty(0)
    if box.shape != (2, 3) or not np.isfinite(box).all() or (box[1] <= box[0]).any():
        raise InputError(f"volume {volume!r}: give the machine volume as ((x_min, y_min, z_min), (x_max, y_max, "
                         "z_max)) in mm, each max above its min")
    return box


class Journal:
    """The run's files as it goes: the transcript line by line (flushed at once, synced with each
    point) and the measured points, the file rewritten whole after each point (a temporary file,
    fsync, rename), with a ``run_end`` line that says how the run ended ('in progress' while it
    runs, so a file left by a killed run says so)."""

    def __init__(self, planned: PointSet, out: str, log: str | None, server: str, chosen: bool = False) -> None:
        self.planned, self.out, self.server = planned, out, server
        self.touched: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        # A run that chooses its points as it goes (chosen) owes only those it chose.
        self.wanted: list[str] | None = [] if chosen else None
        self.tool, self.radius = "", 0.0
        self.stream = None if log is None else open(log, "w", encoding="ascii", errors="replace")

    def line(self, text: str) -> None:
        """Append one transcript line (cut to the longest line I++ allows)."""
        if self.stream is not None:
            self.stream.write(text[:IPPSIZE] + "\n")
            self.stream.flush()

    def point(self, label: str, contact: np.ndarray, vector: np.ndarray) -> None:
        """Keep one measured point (contact (3,) mm, unit vector (3,)) and rewrite the file."""
        self.touched[label] = (contact, vector)
        self.write("in progress")

    def labels(self) -> tuple[list, list]:
        """(labels measured, labels not measured), in the planned order (in the order chosen, of
        the points chosen, for a run that chooses them)."""
        wanted = self.planned.labels if self.wanted is None else self.wanted
        return [label for label in wanted if label in self.touched], [label for label in wanted if label not in self.touched]

    def measured(self, metadata: dict | None = None) -> PointSet:
        """The contact points kept so far (in the order :meth:`labels` gives), with metadata."""
        labels = self.labels()[0]
        return PointSet(labels, np.array([self.touched[label][0] for label in labels]).reshape(-1, 3),
                        np.array([self.touched[label][1] for label in labels]).reshape(-1, 3), metadata=metadata or {})

    def write(self, end: str) -> None:
        """Write the points measured (in the planned order), if any, and sync the transcript."""
        labels, missing = self.labels()
        if labels:
            metadata = {"source": f"measured over I++ DME at {self.server}", "tool": self.tool,
                        "tool_radius_mm": self.radius, "run_end": end}
            if missing:
                metadata["not_measured"] = " ".join(missing)
            export(self.measured(metadata), self.out)
        if self.stream is not None:
            os.fsync(self.stream.fileno())

    def close(self) -> None:
        """Close the transcript."""
        if self.stream is not None:
            self.stream.close()


class Connection:
    """One I++ DME session's socket: send a command, collect its answers."""

    def __init__(self, sock: socket.socket, timeout_s: float, progress: Callable[[str | None], bool | None] | None,
                 journal: Journal) -> None:
        self.sock, self.timeout_s, self.progress, self.journal = sock, timeout_s, progress, journal
        self.buffer, self.count, self.running = b"", 0, None
        self.commands: list[str] = []
        self.warnings: list[str] = []

    def call(self, method):
        """Send method with the next tag; the data answers (list of Response). MeasurementStopped
        for an error answer (severity 2 or more), a time-out or a lost connection; _Cancelled on
        Cancel (``running`` keeps the command that has not finished, for :meth:`abort`)."""
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
        self.journal.line(f"> {line}")
        try:
            self.sock.sendall((line + LINE_END).encode("ascii"))
        except OSError as exc:
            raise MeasurementStopped(f"the connection to the CMM was lost sending {line!r} ({exc})",
                                     connection_lost=True) from None

    def answers(self, tag, method, cancellable=True):
        """Read lines until tag's '%'; its '#' answers. An error of severity 0 or 1 is a warning
        (kept, shown through progress); one of severity 2 or more, the command's own or
        unsolicited, stops at once."""
        data, deadline = [], time.monotonic() + self.timeout_s
        while True:
            line = self.line(deadline, f"{tag} {method}", cancellable)
            try:
                answer = parse_response(line)
            except ResponseError as exc:
                raise MeasurementStopped(f"the CMM answered {tag} {method} with {quoted(line)}, which is not I++ DME "
                                         f"({exc})") from None
            if answer.kind == "!" and answer.tag in (tag, UNSOLICITED):
                self.error(answer, tag, method, cancellable)
            elif answer.tag != tag:
                continue
            elif answer.kind == "#":
                data.append(answer)
            elif answer.kind == "%":
                return data

    def error(self, answer, tag, method, cancellable):
        """A warning kept for severity 0 and 1; MeasurementStopped naming the CMM's error else."""
        code = f"I++ error {answer.code:04d} (severity {answer.severity})"
        said = (f"the CMM reported an unsolicited {code} during {tag} {method}: {cut(answer.text)}"
                if answer.tag == UNSOLICITED else f"the CMM answered {tag} {method} with {code}: {cut(answer.text)}")
        if answer.severity < STOPPING_SEVERITY:
            self.warnings.append(said)
            self.journal.line(f"! warning: {said}")
            if cancellable and self.progress is not None and _asked(self.progress, f"warning: {said}"):
                raise _Cancelled
            return
        if answer.tag == tag:
            self.running = None
        raise MeasurementStopped(said)

    def line(self, deadline, what, cancellable):
        """The next line from the server; asks progress(None) between reads whether to cancel."""
        while b"\n" not in self.buffer:
            if len(self.buffer) > IPPSIZE:
                raise MeasurementStopped(f"the CMM sent a line of more than {IPPSIZE} characters during {what}, longer "
                                         "than I++ DME allows (section 6.2); it begins "
                                         f"{quoted(self.buffer[:QUOTE_CHARS].decode('ascii', 'replace'))}")
            if cancellable and self.progress is not None and _asked(self.progress, None):
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
        self.journal.line(f"< {text}")
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


def _asked(progress, message):
    """progress(message), an exception it raises wrapped in _CallbackFailed."""
    try:
        return progress(message)
    except Exception as exc:
        raise _CallbackFailed from exc


def measure(source: object, server: str, out: str | os.PathLike = "measured.csv", tool: str | None = None,
            progress: Callable[[str | None], bool | None] | None = None, timeout_s: float = 60.0,
            log: str | os.PathLike | None = None,
            volume: Sequence[Sequence[float]] | None = None) -> MeasuredRun:
    """Measure the planned points of source (a SamplingResult, PartPlan, PointSet or the
    workbench's probe points) on the CMM behind an I++ DME server and write the contact points.

    server: 'host:port' ('[IPv6]:port'); out: the file, CSV (.csv) or XYZIJK (.xyz, .txt), read
    back by :func:`cmmsampling.inspect`, rewritten after each point; tool: the tool's name
    (default: the first the server lists); progress: callable(message) before each point
    (message 'point k of N'), with each warning of the CMM and while waiting (None), returning
    True to cancel; timeout_s: the longest wait for one command's answers; log: a file for the
    session's transcript ('> ' sent, '< ' received, '! warning: ' the CMM's warnings), written
    line by line; volume: the machine volume ((x_min, y_min, z_min), (x_max, y_max, z_max)) mm
    in the CMM's coordinates, a reported point outside it refused (default +-10 m).
    Returns a MeasuredRun (a path-like of out). A Cancel returns the points measured so far
    (``cancelled``); an I++ error, a lost connection, a time-out, an implausible answer or an
    exception (a progress callback's included) raises MeasurementStopped after writing them (its
    ``run``); Ctrl-C (KeyboardInterrupt) is raised again after writing them, the run in its
    note. InputError (or ExportError for a path that cannot be written) before connecting.
    """
    link = link_settings(server, out, log, timeout_s, volume)
    planned, moves, probe_radius = _planned_path(source)
    return run_session(link, planned, moves, probe_radius, tool, progress, fixed_order(planned))


@dataclass(frozen=True)
class Link:
    """Where a session measures and writes: host, port, the measured file (target) and the
    transcript (record, or None), the longest wait for a command (s), the machine volume box."""

    host: str
    port: int
    target: str
    record: str | None
    timeout_s: float
    box: np.ndarray


def link_settings(server: str, out: str | os.PathLike, log: str | os.PathLike | None, timeout_s: float,
                  volume: Sequence[Sequence[float]] | None) -> Link:
    """The Link of measure()'s arguments, checked before connecting (InputError, or ExportError
    for a path that cannot be written)."""
    host, port = server_address(server)
    fmt = resolve_format(out)
    live = live_records()
    if FORMATS[fmt] not in live:
        kinds = " or ".join(f"{record.title} ({', '.join(record.extensions)})" for record in live)
        raise InputError(f"{os.fspath(out)}: measured points are written as {kinds}, the files cmmsampling.inspect "
                         "reads back")
    target = check_writable(out)
    record = None if log is None else check_writable(log)
    return Link(host, port, target, record, check_real("timeout_s", timeout_s, above=0.0), machine_volume(volume))


def fixed_order(planned: PointSet) -> Callable[[Journal], Iterator[tuple[int, str]]]:
    """The order of a fixed plan: each planned point in turn, 'point k of N'."""
    def order(journal: Journal) -> Iterator[tuple[int, str]]:
        count = len(planned)
        for index in range(count):
            yield index, f"point {index + 1} of {count}"
    return order


def run_session(link: Link, planned: PointSet, moves: list | Callable[[int | None, int], np.ndarray] | None,
                probe_radius: float, tool: str | None,
                progress: Callable[[str | None], bool | None] | None,
                order: Callable[[Journal], Iterator[tuple[int, str]]], chosen: bool = False) -> MeasuredRun:
    """Measure the points of planned (a PointSet; moves: the travel before each (a list by point, or
    moves(previous point or None, point) -> (K, 3) mm), or None: straight) that
    order(journal) yields ((row, progress message), one after the other; it may look at the
    points the journal kept so far), each written as it comes; the MeasuredRun (see
    :func:`measure`: what ends the run, and what it raises). chosen: the points are chosen as
    the run goes (only those yielded count as planned)."""
    journal = Journal(planned, link.target, link.record, address_text(link.host, link.port), chosen)
    try:
        sock = _connect(link.host, link.port, link.timeout_s)
        connection = Connection(sock, link.timeout_s, progress, journal)
        state = {"cancelled": False, "radius": probe_radius}
        failure = _measured(connection, planned, moves, tool, link.box, state, order)
        run = MeasuredRun(link.target, *journal.labels(), journal.tool, journal.radius, journal.server,
                          bool(state["cancelled"]), list(connection.commands), list(connection.warnings))
        journal.write(_ending(failure, state["cancelled"]))
    finally:
        journal.close()
    _raise(failure, run)
    return run


def _connect(host, port, timeout_s):
    """The socket to the server (polled every POLL_S); MeasurementStopped naming the address."""
    try:
        sock = socket.create_connection((host, port), timeout=min(timeout_s, 10.0))
    except OSError as exc:
        raise MeasurementStopped(f"cannot reach the I++ DME server at {address_text(host, port)} ({exc}); is it "
                                 "running and is the address right?") from None
    sock.settimeout(POLL_S)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


def _measured(connection, planned, moves, tool, box, state, order):
    """Run the session and end it as far as the link allows whatever stops it; the exception
    that stopped it (None: every point, or Cancel)."""
    failure = None
    try:
        _session(connection, planned, moves, tool, box, state, order)
    except _Cancelled:
        state["cancelled"] = True
        connection.abort()
    except BaseException as exc:  # an I++ error, an exception, Ctrl-C: the points are kept either way
        failure = exc
        if not getattr(exc, "connection_lost", False):
            connection.abort()
    finally:
        if not getattr(failure, "connection_lost", False):
            connection.quietly("EndSession()")
        connection.sock.close()
    return failure


def _ending(failure, cancelled):
    """How the run ended, for the file's ``run_end`` line (one line, quoted text cut)."""
    if failure is None:
        return "cancelled" if cancelled else "all points measured"
    return f"stopped: {' '.join(_said(failure).split())[:QUOTE_CHARS]}"


def _said(failure):
    """What stopped the run, in words."""
    if isinstance(failure, MeasurementStopped):
        return str(failure)
    if isinstance(failure, _CallbackFailed):
        cause = failure.__cause__
        return f"the progress callback raised {type(cause).__name__}: {quoted(str(cause))}"
    if isinstance(failure, KeyboardInterrupt):
        return "interrupted (Ctrl-C)"
    return f"an unexpected {type(failure).__name__}: {quoted(str(failure))}"


def _raise(failure, run):
    """Raise what stopped the run, its MeasuredRun attached: MeasurementStopped for an error,
    KeyboardInterrupt (or another BaseException) again with the run in its note."""
    if failure is None:
        return
    if not isinstance(failure, Exception):
        failure.add_note(f"cmmsampling: {run}")
        raise failure
    cause = failure.__cause__ if isinstance(failure, _CallbackFailed) else failure
    raise MeasurementStopped(f"{_said(failure)}; {run}", run,
                             getattr(failure, "connection_lost", False)) from (
        None if isinstance(failure, MeasurementStopped) else cause)


def _planned_path(source):
    """(the planned PointSet in measuring order, the travel before each point or None, the ball
    radius of the plan's probe in mm or 0 where it has none): a PointSet with its travel (already
    in the path's order) as it is, a plan or result made with a probe along its collision-free
    path."""
    from ..access.probe_moves import probe_moves

    if isinstance(source, PointSet) and source.travel is not None:
        return source, source.travel, 0.0
    planned = as_point_set(source)
    try:
        moves = probe_moves(source)
    except (InputError, TypeError, AttributeError):
        return planned, None, 0.0
    ordered = along_moves(planned, moves)
    return ordered, ordered.travel, _probe_radius(source)


def _probe_radius(source):
    """The ball radius (mm) of the probe a plan (``probe``) or a run (its settings' ``probe``)
    was made with; 0 where none is known."""
    probe = getattr(source, "probe", None)
    if probe is not None:
        return float(probe.radius)
    settings = getattr(source, "settings", None)
    stated = settings.get("probe") if isinstance(settings, dict) else None
    return 0.5 * float(stated["ball_diameter"]) if isinstance(stated, dict) and "ball_diameter" in stated else 0.0


def _session(connection, planned, moves, tool, box, state, order):
    """The session's commands up to the last point order yields, each point kept by the journal
    as it comes."""
    journal = connection.journal
    connection.call("StartSession()")
    if connection.call("IsHomed()")[0].args != (1.0,):
        connection.call("Home()")
    tools = [answer.args[0] for answer in connection.call("EnumTools()") if answer.form == "String"]
    if not tools or (tool is not None and tool not in tools):
        raise MeasurementStopped(f"the CMM has no tool {tool!r}; it lists {', '.join(tools) or 'none'}"
                                 if tool is not None else "the CMM lists no tool")
    journal.tool = tool or tools[0]
    connection.call(f'ChangeTool("{journal.tool}")')
    connection.call(REPORT)
    previous = None
    for index, message in order(journal):
        if journal.wanted is not None:
            journal.wanted.append(planned.labels[index])
        if connection.progress is not None and _asked(connection.progress, message):
            raise _Cancelled
        point, vector = planned.points[index], planned.normals[index]
        for position in _travel(moves, previous, index, point + (APPROACH_MM + journal.radius) * vector):
            connection.call(f"GoTo({point_arguments(position)})")
        previous = index
        what = f"PtMeas({point_arguments(point, vector)})"
        centre, normal, radius = _report(connection.call(what), f"{tag_text(connection.count)} {what}", box)
        state["radius"] = _checked_radius(radius, state["radius"], planned.labels[index])
        journal.radius = radius
        contact = centre - radius * normal
        _check_scale(planned, journal, index, contact)
        journal.point(planned.labels[index], contact, normal)


def _travel(moves, previous, index, straight):
    """(K, 3) mm: the positions the probe goes to before touching point index: moves[index]'s
    (the travel pairs of a planned path), moves(previous, index)'s (a callable: the moves of a
    run choosing its points as it goes; previous: the point touched before, None at the first),
    or straight to ``straight`` (3,) where moves is None."""
    if moves is None:
        return straight[None]
    if callable(moves):
        return np.asarray(moves(previous, index), dtype=float).reshape(-1, 3)
    return np.concatenate([part for part in moves[index] if len(part)] or [np.empty((0, 3))])


def _report(data, what, box):
    """(ball centre (3,) mm, unit vector (3,), effective radius mm) of a PtMeas's answers;
    MeasurementStopped naming what is missing, not finite or outside the machine volume box."""
    reports = [answer.props for answer in data if set(REPORTED) <= set(answer.props)]
    if len(reports) != 1:
        got = "; ".join(f"{answer.props}" for answer in data) or "no data"
        raise MeasurementStopped(f"the CMM answered {what} with {len(reports)} point reports where one with "
                                 f"{', '.join(REPORTED)} was asked for (OnPtMeasReport); got {quoted(got)}")
    report = reports[0]
    shapes = {"X": 1, "Y": 1, "Z": 1, "IJK": 3, "ER": 1}
    wrong = [name for name, size in shapes.items() if len(report[name]) != size
             or not all(isinstance(value, float) for value in report[name])]
    if wrong:
        raise MeasurementStopped(f"the CMM answered {what} with {', '.join(f'{name}{report[name]}' for name in wrong)},"
                                 " not the numbers a point report has")
    centre = np.array([report[axis][0] for axis in "XYZ"])
    vector, radius = np.array(report["IJK"]), report["ER"][0]
    values = f"X({centre[0]:g}), Y({centre[1]:g}), Z({centre[2]:g}), IJK({', '.join(f'{v:g}' for v in vector)}), ER({radius:g})"
    if not (np.isfinite(centre).all() and np.isfinite(vector).all() and np.isfinite(radius)):
        raise MeasurementStopped(f"the CMM reported {values} for {what}: a number that is not finite")
    if ((centre < box[0]) | (centre > box[1])).any():
        raise MeasurementStopped(f"the CMM reported {values} for {what}, outside the machine volume "
                                 f"{box[0].tolist()} .. {box[1].tolist()} mm; give measure(volume=) if the "
                                 "machine is larger")
    length = float(np.linalg.norm(vector))
    if not 0.5 < length < 2.0:
        raise MeasurementStopped(f"the CMM reported {values} for {what}: IJK is no unit vector (length {length:g})")
    if not radius > 0.0:
        raise MeasurementStopped(f"the CMM reported {values} for {what}: a ball radius ER that is not positive")
    return centre, vector / length, float(radius)


def _checked_radius(radius, expected, label):
    """The tool's radius from here on (mm): expected (the plan's probe's, else the first point's
    ER) where known; MeasurementStopped when radius is more than SCALE_FACTOR from it."""
    if expected and not expected / SCALE_FACTOR <= radius <= expected * SCALE_FACTOR:
        raise MeasurementStopped(
            f"the CMM reported a ball radius ER({radius:g}) for point {label} where the tool's is {expected:g} mm; "
            "I++ DME speaks millimetres: is the CMM set to inches (1 mm = 0.03937 in), or is another tool in?")
    return expected or radius


def _check_scale(planned, journal, index, contact):
    """MeasurementStopped when the distance of contact (3,) mm from the first point measured is
    more than SCALE_FACTOR from the planned distance (planned ones over SCALE_MIN_MM): the
    part's motion on the table keeps distances, inches do not."""
    if not journal.touched:
        return
    first = next(iter(journal.touched))
    planned_distance = float(np.linalg.norm(planned.points[index] - planned.points[planned.labels.index(first)]))
    measured = float(np.linalg.norm(contact - journal.touched[first][0]))
    if planned_distance > SCALE_MIN_MM and not planned_distance / SCALE_FACTOR <= measured <= planned_distance * SCALE_FACTOR:
        raise MeasurementStopped(
            f"the CMM's point {planned.labels[index]} lies {measured:.4g} mm from point {first} where the plan has "
            f"{planned_distance:.4g} mm; I++ DME speaks millimetres: is the CMM set to inches, or measuring another part?")
