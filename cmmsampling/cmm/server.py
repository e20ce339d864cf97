"""A simulated I++ DME server: the virtual CMM of :func:`cmmsampling.simulate_measurement` behind
the protocol, on 127.0.0.1 only.

The part departs from the CAD model by the same smooth form error and lies misplaced on the table
in the same way; a ``PtMeas`` of a nominal point p with vector n touches the part at
``M (p + f(p) n)`` (M the misplacement, f the form error) and reports the ball centre there and
the surface's vector ``M n`` with the tool's effective radius, as ``OnPtMeasReport`` asks. The
commands it knows are those a client needs to measure points (session, homing, tools, report
format, moves, point measurements, errors, abort); any other is answered with I++ error 0501.
Moves take ``move_s`` seconds each (0 by default), during which an ``AbortE`` stops them.
"""
from __future__ import annotations

import queue
import re
import socket
import socketserver
import threading
import time
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..formats.exporting import as_point_set
from ..inspection.align import transform
from ..inspection.simulate import Misplacement, form_waves
from .answers import NIST_ERRORS as ERRORS
from .protocol import LINE_END, number, vector_text

LOCALHOST = "127.0.0.1"
# The errors this server sends (code -> (severity, text)) are NIST's table of the specification's
# section 8.2 (cmmsampling.cmm.answers.NIST_ERRORS), so that NIST's parser takes its answers.
_COMMAND = re.compile(r"^(\d{5}|E\d{4}) ([A-Za-z][A-Za-z0-9]*)\s*\((.*)\)\s*$")
_PROPERTY = re.compile(r"([A-Za-z]+)\(([^()]*)\)")
DEFAULT_REPORT = ("X", "Y", "Z")
# How far beyond the nominal point (mm) the probe searches for the surface.
SEARCH_MM = 10.0


class CommandFailed(Exception):
    """A command the server answers with an error: code (section 8.2)."""

    def __init__(self, code):
        super().__init__(code)
        self.code = code


@dataclass
class VirtualPart:
    """The manufactured part: its form error f (a function of points (M, 3) mm -> (M,) mm), its
    misplacement (4, 4) nominal -> table, and the probing error: noise mm (standard deviation,
    along the vector) drawn from rng for each touch."""

    form: object
    matrix: np.ndarray
    noise: float = 0.0
    rng: object = None

    @classmethod
    def of(cls, source, form_error=0.0, misplacement=None, seed=0, noise=0.0):
        """The part simulate_measurement measures for the planned points of source (the form
        error's waves sized by their extent, the misplacement about their centroid, the same
        seed); its noise drawn in the order the points are touched."""
        points = as_point_set(source).points
        placed = misplacement if isinstance(misplacement, Misplacement) else Misplacement(**(misplacement or {}))
        return cls(form_waves(points, float(form_error), seed), placed.matrix(points.mean(axis=0)), float(noise),
                   np.random.default_rng(seed + 1))

    def touch(self, point, vector):
        """(contact point (3,) mm, the surface's unit vector there (3,)) where a probe moving
        along -vector through the nominal point (3,) mm touches the part."""
        error = self.form(point[None])[0] + (self.rng.normal(0.0, self.noise) if self.noise else 0.0)
        touched = point + error * vector
        return transform(self.matrix, touched[None])[0], self.matrix[:3, :3] @ vector


@dataclass
class MachineState:
    """What one client's session has set: session, homed, tool, the report's properties, and the
    error that waits for ClearAllErrors (0: none)."""

    session: bool = False
    homed: bool = False
    tool: str = ""
    report: tuple = DEFAULT_REPORT
    error: int = 0
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))


class SimulatedCMM:
    """The server: ``with SimulatedCMM(part) as cmm: cmm.address`` ('127.0.0.1:port').

    part: the VirtualPart; tools: {name: ball radius mm}; homed: whether the machine starts homed;
    move_s: seconds each move and point measurement takes; port: 0 for a free one. ``commands``
    lists every command line received, ``connections`` counts the clients served."""

    def __init__(self, part: VirtualPart, tools: dict[str, float] | None = None, homed: bool = False, move_s: float = 0.0,
                 port: int = 0) -> None:
        self.part = part
        self.tools = dict(tools or {"Probe1": 1.0})
        self.homed, self.move_s = homed, float(move_s)
        self.commands: list[str] = []
        self.connections = 0
        owner = self

        class Handler(socketserver.StreamRequestHandler):
            def handle(self):
                self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                owner.serve(self.connection)

        self._server = socketserver.ThreadingTCPServer((LOCALHOST, port), Handler, bind_and_activate=False)
        self._server.allow_reuse_address = True
        self._server.daemon_threads = True
        self._thread = None

    @classmethod
    def measuring(cls, source: object, form_error: float = 0.0, misplacement: Misplacement | None = None, seed: int = 0,
                  noise: float = 0.0, **options: Any) -> SimulatedCMM:
        """The server of the part simulate_measurement measures for source's planned points (the
        same form error, misplacement and seed; VirtualPart.of); options: tools, homed, move_s,
        port."""
        return cls(VirtualPart.of(source, form_error, misplacement, seed, noise), **options)

    @property
    def address(self) -> str:
        """'127.0.0.1:port' of the listening socket."""
        host, port = cast(tuple, self._server.server_address)
        return f"{host}:{port}"

    def __enter__(self):
        self._server.server_bind()
        self._server.server_activate()
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.05},
                                        name="simulated I++ DME server", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(5)

    def serve(self, connection: socket.socket) -> None:
        """One client: lines read by a reader thread into a queue, executed in order (an AbortE
        reaches a running move through the queue)."""
        self.connections += 1
        lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=_read_lines, args=(connection, lines), daemon=True).start()
        state = MachineState(homed=self.homed)
        while True:
            line = lines.get()
            if line is None:
                return
            self.commands.append(line)
            for answer in self.execute(line, state, lines):
                try:
                    connection.sendall((answer + LINE_END).encode("ascii"))
                except OSError:
                    return

    def execute(self, line: str, state: MachineState, pending: queue.Queue) -> list[str]:
        """The answer lines to one command line."""
        found = _COMMAND.match(line)
        if found is None:
            return [f"E0000 ! Error(3, 0008, \"{line[:40].replace(chr(34), chr(39))}\", \"Protocol error\")"]
        tag, method, arguments = found.groups()
        answers = [f"{tag} &"]
        try:
            if state.error and method not in ("ClearAllErrors", "AbortE", "GetErrStatusE"):
                raise CommandFailed(514)
            answers += [data.replace("{tag}", tag) for data in self.run(method, arguments, state, pending)]
        except CommandFailed as failed:
            severity, text = ERRORS[failed.code]
            if severity >= 2:
                state.error = failed.code
            answers.append(f"{tag} ! Error({severity}, {failed.code:04d}, \"{method}\", \"{text}\")")
        answers.append(f"{tag} %")
        return answers

    def run(self, method: str, arguments: str, state: MachineState, pending: queue.Queue) -> list[str]:
        """The data lines of one method (CommandFailed for an error)."""
        needs_session = method not in ("StartSession", "AbortE", "ClearAllErrors")
        if needs_session and not state.session:
            raise CommandFailed(508)
        if method == "StartSession":
            state.session = True
        elif method == "EndSession":
            state.session = False
        elif method in ("ClearAllErrors", "AbortE"):
            state.error = 0
        elif method == "IsHomed":
            return [f"{{tag}} # IsHomed({int(state.homed)})"]
        elif method == "Home":
            self._wait(pending)
            state.homed = True
        elif method == "EnumTools":
            return [f'{{tag}} # "{name}"' for name in self.tools]
        elif method == "ChangeTool":
            name = arguments.strip().strip('"')
            if name not in self.tools:
                raise CommandFailed(1502)
            state.tool = name
        elif method == "OnPtMeasReport":
            names = tuple(name for name, _ in _PROPERTY.findall(arguments))
            if not names or set(names) - {"X", "Y", "Z", "IJK", "ER"}:
                raise CommandFailed(510)
            state.report = names
        elif method == "GoTo":
            state.position = self._target(arguments, state, pending)[0]
        elif method == "PtMeas":
            return [f"{{tag}} # {self._measure(arguments, state, pending)}"]
        else:
            raise CommandFailed(501)
        return []

    def _target(self, arguments, state, pending):
        """(point (3,) mm, vector (3,) or None) of a move's arguments, once the move is done."""
        if not state.homed or not state.tool:
            raise CommandFailed(508)
        given = {name: [float(v) for v in values.split(",")] for name, values in _PROPERTY.findall(arguments)}
        try:
            point = np.array([given.get(axis, [state.position[k]])[0] for k, axis in enumerate("XYZ")])
        except (ValueError, IndexError):
            raise CommandFailed(502) from None
        vector = np.array(given["IJK"]) if "IJK" in given else None
        self._wait(pending)
        return point, vector

    def _measure(self, arguments, state, pending):
        """The report of a point measurement: the ball centre where it touches, its vector and
        radius, as OnPtMeasReport asks."""
        point, vector = self._target(arguments, state, pending)
        if vector is None or len(vector) != 3 or np.linalg.norm(vector) < 1e-12:
            raise CommandFailed(1010)
        vector = vector / np.linalg.norm(vector)
        contact, normal = self.part.touch(point, vector)
        if abs(np.dot(contact - point, vector)) > SEARCH_MM:
            raise CommandFailed(1006)
        radius = self.tools[state.tool]
        centre = contact + radius * normal
        state.position = centre + radius * normal
        values = {"X": number(centre[0]), "Y": number(centre[1]), "Z": number(centre[2]),
                  "IJK": vector_text(normal), "ER": number(radius)}
        return ", ".join(f"{name}({values[name]})" for name in state.report)

    def _wait(self, pending):
        """A move's time; an AbortE arriving meanwhile aborts it (error 0006)."""
        end = time.monotonic() + self.move_s
        while time.monotonic() < end:
            time.sleep(min(0.01, max(0.0, end - time.monotonic())))
            if any("AbortE" in line for line in list(pending.queue)):
                raise CommandFailed(6)


def _read_lines(connection, lines):
    """Put each CR LF line the client sends into lines; None when it closes."""
    buffer = b""
    try:
        while True:
            chunk = connection.recv(4096)
            if not chunk:
                break
            buffer += chunk
            while b"\n" in buffer:
                line, buffer = buffer.split(b"\n", 1)
                lines.put(line.rstrip(b"\r").decode("ascii", "replace"))
    except OSError:
        pass
    lines.put(None)
