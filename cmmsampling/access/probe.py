"""The contact probe: a tip ball on a stylus under a cylindrical probe body, and the CMM's speeds.

A probe stands on an axis ``a`` (unit, from the ball towards the head). Touching a point ``p``
whose surface normal (out of the material) is ``n``, its ball centre is ``c = p + r n`` whatever
the axis; the stylus is the cylinder from ``c`` along ``a`` over ``stylus_length``, the body the
cylinder beyond it over ``body_length``. The ball approaches ``p`` along ``-n`` from
``approach`` mm away and retracts the same way; every move keeps ``clearance`` mm from the part.
All lengths in mm, angles in degrees.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..geometry.freecad_env import import_part
from ..geometry.validation import InputError, InputTypeError, check_real

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)


# The largest dimensions a Probe takes, mm: beyond any CMM stylus, and what keeps the pieces a
# reach test sweeps (and their memory) bounded.
LARGEST = {"ball_diameter": 100.0, "stylus_diameter": 100.0, "stylus_length": 1000.0, "body_diameter": 500.0,
           "body_length": 2000.0, "approach": 100.0, "clearance": 200.0}
# The finest step of an indexing head, degrees (its orientations grow with the inverse square of it).
FINEST_INDEX_STEP = 2.5


@dataclass(frozen=True)
class Probe:
    """A stylus and probe body, and how the head may tilt them (mm, degrees).

    ball_diameter, stylus_length (ball centre to the body), stylus_diameter, body_diameter,
    body_length; approach: the touch move's length along the normal, also the retract;
    clearance: what every move keeps from the part; max_tilt: the largest angle between the
    axis and a point's normal the head may take when the normal is blocked; index_step: the
    head's index step (a PH10-like head: its A and B angles are multiples of it), None for a
    continuous head; max_head_angle: the largest A angle (from the vertical +Z) the head reaches.
    """

    ball_diameter: float = 2.0
    stylus_length: float = 20.0
    stylus_diameter: float = 1.5
    body_diameter: float = 13.2
    body_length: float = 40.0
    approach: float = 3.0
    clearance: float = 2.0
    max_tilt: float = 30.0
    index_step: float | None = 7.5
    max_head_angle: float = 105.0

    def __post_init__(self) -> None:
        for name in ("ball_diameter", "stylus_length", "stylus_diameter", "body_diameter", "body_length"):
            check_real(name, getattr(self, name), above=0.0)
        for name in ("approach", "clearance"):
            check_real(name, getattr(self, name), 0.0)
        for name, largest in LARGEST.items():
            if getattr(self, name) > largest:
                raise InputError(f"{name} {getattr(self, name):g} mm is larger than a CMM probe's (at most {largest:g} "
                                 "mm here, which bounds the reach's memory and time); give a smaller value")
        check_real("max_tilt", self.max_tilt, 0.0, 90.0)
        check_real("max_head_angle", self.max_head_angle, 0.0, 180.0)
        if self.index_step is not None and check_real("index_step", self.index_step, above=0.0) < FINEST_INDEX_STEP:
            raise InputError(f"index_step {self.index_step:g} degrees is finer than an indexing head's ({FINEST_INDEX_STEP:g} "
                             "degrees or more: a PH10 steps 7.5, a Zeiss RDS 2.5); give index_step=None for a continuous head")
        if self.stylus_diameter > self.ball_diameter:
            raise InputError(f"a stylus of {self.stylus_diameter} mm is thicker than its {self.ball_diameter} mm "
                             "ball: the stylus would touch first; give stylus_diameter below ball_diameter")
        if self.stylus_length <= self.radius:
            raise InputError(f"a stylus of {self.stylus_length} mm (ball centre to the body) ends inside its "
                             f"{self.ball_diameter} mm ball; give stylus_length above the ball's radius, "
                             f"{self.radius:g} mm")
        if self.body_diameter < self.stylus_diameter:
            raise InputError(f"a probe body of {self.body_diameter} mm is thinner than its {self.stylus_diameter} mm "
                             "stylus; give body_diameter of at least stylus_diameter")

    @property
    def radius(self) -> float:
        """The tip ball's radius, mm."""
        return 0.5 * self.ball_diameter

    @property
    def reach(self) -> float:
        """From the ball centre to the end of the body, mm."""
        return self.stylus_length + self.body_length

    @property
    def stylus_start(self) -> float:
        """Where the stylus leaves the ball, mm along the axis from the ball centre."""
        return float(np.sqrt(max(self.radius ** 2 - (0.5 * self.stylus_diameter) ** 2, 0.0)))

    def stations(self, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(centres, ready) (N, 3) mm: the ball centres touching points (N, 3) with normals (N, 3)
        unit, c = p + r n, and the ready positions ``approach`` mm out along the normals."""
        centres = points + self.radius * normals
        return centres, centres + self.approach * normals

    def with_values(self, **values: Any) -> Probe:
        """A copy with some values changed (checked again)."""
        return replace(self, **values)

    def cylinders(self) -> list[tuple[float, float, float]]:
        """[(start, end, radius)] of the stylus and the body along the axis, mm from the ball
        centre."""
        return [(0.0, self.stylus_length, 0.5 * self.stylus_diameter),
                (self.stylus_length, self.reach, 0.5 * self.body_diameter)]

    def solid(self, centre: np.ndarray, axis: Any, with_ball: bool = True) -> Part.Shape:
        """The probe as an OCC solid with its ball centre at ``centre`` (3,) mm and its axis
        ``axis`` (3,) unit: ball, stylus and body fused (the ball left out with_ball=False)."""
        centre = Vector(centre)
        axis = Vector(axis)
        axis.normalize()
        parts = [Part.makeCylinder(radius, end - start, centre + axis * start, axis)
                 for start, end, radius in self.cylinders()]
        if with_ball:
            parts.append(Part.makeSphere(self.radius, centre))
        return parts[0].fuse(parts[1:]).removeSplitter()


def check_probe(probe: Any) -> None:
    """InputTypeError unless probe is a Probe (None is no probe, and passes)."""
    if probe is not None and not isinstance(probe, Probe):
        raise InputTypeError(f"probe must be a cmmsampling.Probe (e.g. cmmsampling.PROBES['2 mm ball, 20 mm "
                             f"stylus']), got {probe!r}")


def Vector(values: Sequence[float] | np.ndarray) -> FreeCAD.Vector:
    """A FreeCAD vector of three numbers."""
    return FreeCAD.Vector(*(float(v) for v in values))


@dataclass(frozen=True)
class Motion:
    """How the CMM moves: move_speed between points (mm/s), touch_speed over the approach
    (mm/s), point_time: what each touch adds (settling, the trigger), s; index_time: what each
    change of an indexing head's orientation adds (the head unlocks, turns and locks again), s:
    about 3 s on a PH10-class head, 0 for a head that turns while the CMM moves."""

    move_speed: float = 200.0
    touch_speed: float = 4.0
    point_time: float = 0.3
    index_time: float = 3.0

    def __post_init__(self) -> None:
        check_real("move_speed", self.move_speed, above=0.0)
        check_real("touch_speed", self.touch_speed, above=0.0)
        check_real("point_time", self.point_time, 0.0)
        check_real("index_time", self.index_time, 0.0)

    def seconds(self, travel: float, points: int, approach: float, index_moves: int = 0) -> float:
        """Estimated measuring time, s: ``travel`` mm of moves at move_speed, per point the
        approach (mm) at touch_speed, the retract at move_speed and point_time, and index_time
        per index move of the head (``index_moves``, the changes of orientation along the path)."""
        per_point = approach / self.touch_speed + approach / self.move_speed + self.point_time
        return travel / self.move_speed + points * per_point + index_moves * self.index_time


# Common styli on a TP20-like body (13.2 mm, 40 mm to the head), mm.
PROBES = {
    "2 mm ball, 20 mm stylus": Probe(),
    "1 mm ball, 10 mm stylus": Probe(ball_diameter=1.0, stylus_length=10.0, stylus_diameter=0.7),
    "3 mm ball, 30 mm stylus": Probe(ball_diameter=3.0, stylus_length=30.0, stylus_diameter=2.0),
    "4 mm ball, 50 mm stylus": Probe(ball_diameter=4.0, stylus_length=50.0, stylus_diameter=3.0),
}


def head_angles(axes: np.ndarray) -> np.ndarray:
    """(A, B) in degrees of probe axes (N, 3) unit: A from the vertical +Z (0: stylus pointing
    down), B the azimuth of the axis from +X about +Z (-180, 180]; (N, 2)."""
    axes = np.asarray(axes, dtype=float)
    a = np.degrees(np.arccos(np.clip(axes[:, 2], -1.0, 1.0)))
    b = np.degrees(np.arctan2(axes[:, 1], axes[:, 0]))
    b = np.where(a < 1e-9, 0.0, b)
    return np.stack([a, np.where(b <= -180.0, 180.0, b)], axis=1)


def axes_of(angles: np.ndarray) -> np.ndarray:
    """Probe axes (N, 3) unit for head angles (N, 2) degrees (see :func:`head_angles`)."""
    a, b = np.radians(np.asarray(angles, dtype=float)).T
    return np.stack([np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a)], axis=1)


# The tilt step of a continuous head's candidate rings, degrees.
CONTINUOUS_STEP = 7.5


def candidate_axes(normals: np.ndarray, probe: Probe) -> tuple[np.ndarray, np.ndarray]:
    """The axes the head may take at points of unit normals (N, 3), nearest each normal first:
    (axes (N, K, 3) unit, usable (N, K) bool; the unusable ones sort last).

    A continuous head (index_step None) starts with the normal itself, then rings of tilt in
    steps of CONTINUOUS_STEP degrees up to max_tilt; an indexing head takes the orientations on
    its A/B grid within max_tilt of the normal. Orientations beyond max_head_angle are unusable.
    """
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    if probe.index_step is None:
        axes = _rings(normals, probe.max_tilt)
    else:
        axes = np.repeat(index_axes(probe)[None], len(normals), axis=0)
    tilt = np.degrees(np.arccos(np.clip(np.einsum("nkc,nc->nk", axes, normals), -1.0, 1.0)))
    usable = (tilt <= probe.max_tilt + 1e-9) & (np.degrees(np.arccos(np.clip(axes[..., 2], -1.0, 1.0)))
                                                <= probe.max_head_angle + 1e-9)
    order = np.argsort(np.where(usable, tilt, np.inf), axis=1, kind="stable")
    return np.take_along_axis(axes, order[..., None], axis=1), np.take_along_axis(usable, order, axis=1)


def index_axes(probe: Probe) -> np.ndarray:
    """(K, 3) unit: the axes of an indexing head's orientations (Probe.index_step, up to
    max_head_angle from the vertical), the vertical first; ValueError for a continuous head."""
    if probe.index_step is None:
        raise InputError("a continuous head (index_step None) has no index orientations")
    return axes_of(_index_grid(probe.index_step, probe.max_head_angle))


def _index_grid(step: float, max_head_angle: float) -> np.ndarray:
    """(A, B) degrees of an indexing head's orientations, about ``step`` degrees apart on the
    sphere: A in steps up to max_head_angle degrees, B in multiples of the step that keep
    neighbours about a step apart (near the vertical, neighbouring B differ by far less than a step
    in direction)."""
    grid = [(0.0, 0.0)]
    for a in np.arange(step, max_head_angle + 1e-9, step):
        stride = step * max(1, int(round(1.0 / np.sin(np.radians(a)))))
        grid += [(a, b) for b in np.arange(-180.0 + stride, 180.0 + 1e-9, stride)]
    return np.array(grid)


def _rings(normals: np.ndarray, max_tilt: float) -> np.ndarray:
    """(N, K, 3): each normal, then rings of tilt CONTINUOUS_STEP, 2 CONTINUOUS_STEP, ... up to
    max_tilt around it, about CONTINUOUS_STEP degrees apart along each ring."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(normals, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(normals, e1)
    tilts, phis = [0.0], [0.0]
    for tilt in np.arange(CONTINUOUS_STEP, max_tilt + 1e-9, CONTINUOUS_STEP):
        count = max(3, int(np.ceil(360.0 * np.sin(np.radians(tilt)) / CONTINUOUS_STEP)))
        tilts += [tilt] * count
        phis += list(np.linspace(0.0, 2 * np.pi, count, endpoint=False))
    t, phi = np.radians(tilts), np.array(phis)
    return (np.cos(t)[None, :, None] * normals[:, None, :]
            + np.sin(t)[None, :, None] * (np.cos(phi)[None, :, None] * e1[:, None, :]
                                          + np.sin(phi)[None, :, None] * e2[:, None, :]))
