"""Which points a probe can reach on a part, and with which axis.

The part is stood in for by :class:`cmmsampling.access.obstacles.Obstacles` (points on its faces,
erring on the side of blocking): the fast test, made for a raster of a face or the pairs of a
path. :class:`ExactPoses` measures single probe poses with OCC's distances, the truth a final
point is held to.

A point ``p`` with normal ``n`` (out of the material) is reachable along an axis ``a`` when
(see :class:`cmmsampling.access.probe.Probe` for the pose):

- the ball at ``c = p + r n`` touches only: no part point nearer ``c`` than ``r`` less the
  touch tolerance (the tessellation's deflection), and likewise along the approach to
  ``s = c + approach n``;
- the stylus and the body at ``c`` are clear of the part;
- from ``s`` the probe can leave along ``a`` out of the part's box (grown by the ball radius
  and the clearance): the ball's, stylus's and body's sweeps along ``a`` are clear of the part.
  Moves along the probe's own axis (the approach, this exit) need not keep the clearance, which
  a narrow slot may not leave; travel moves do (:mod:`cmmsampling.access.probe_moves`).

The head tries the axes nearest the normal first (:func:`cmmsampling.access.probe.candidate_axes`).
"""
from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..geometry.freecad_env import import_part
from ..geometry.surface import lies_on
from ..geometry.validation import InputError
from .obstacles import MAX_POINTS, Obstacles
from .probe import Probe, Vector, candidate_axes, head_angles

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()


@dataclass
class Access:
    """How each point is reached: reachable (N,) bool; axes (N, 3) unit, the probe's axis at
    each reachable point (NaN where none); tilts (N,) degrees between axis and normal; angles
    (N, 2) head angles A, B in degrees (see :func:`cmmsampling.access.probe.head_angles`); ranks
    (N,) int, which of the head's orientations nearest the normal reached it (0: the nearest,
    -1: none); unreached: (K, 4) parameter rectangles (u0, u1, v0, v1) of the face where the
    probe reaches no point, so none was placed there (cmmsampling.geometry.domain), None when
    not judged; unreached_area: their area, mm^2."""

    reachable: np.ndarray
    axes: np.ndarray
    tilts: np.ndarray
    angles: np.ndarray
    ranks: np.ndarray
    unreached: np.ndarray | None = None
    unreached_area: float = 0.0

    @property
    def tilted(self) -> np.ndarray:
        """(N,) bool: reached only with the stylus tilted away from the head's orientation nearest
        the normal (that one was blocked)."""
        return self.reachable & (self.ranks > 0)


def pose_pieces(probe: Probe, centres: np.ndarray, ready: np.ndarray, axes: np.ndarray, exits: np.ndarray
                ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                           tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """What a probe touching at ball centres (M, 3) from ready positions (M, 3) along axes (M, 3)
    must keep clear, leaving ``exits`` (M,) mm along the axis (Probe.stations,
    Obstacles.exits): (sweeps, cylinders), each (starts, ends, radii, owner) with owner the pose
    of each piece.

    sweeps: the ball's exit along the axis (its touch, which no axis changes, is
    :func:`touch_blocked`); cylinders: the stylus and the body at the contact, and their sweeps
    along the axis on the exit.
    """
    stylus_r, body_r = 0.5 * probe.stylus_diameter, 0.5 * probe.body_diameter
    start, length, reach_ = probe.stylus_start, probe.stylus_length, probe.reach
    exits = exits[:, None]
    sweeps = [(ready, ready + exits * axes, probe.radius)]
    cylinders = [(centres + start * axes, centres + length * axes, stylus_r),
                 (centres + length * axes, centres + reach_ * axes, body_r),
                 (ready + start * axes, ready + (length + exits) * axes, stylus_r),
                 (ready + length * axes, ready + (reach_ + exits) * axes, body_r)]
    return _stacked(sweeps, len(axes)), _stacked(cylinders, len(axes))


def _stacked(pieces: Sequence[tuple[np.ndarray, np.ndarray, float]],
             count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(starts, ends, radii, owner) of pieces [(starts (M, 3), ends (M, 3), radius)], M poses each."""
    return (np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces]),
            np.concatenate([np.full(count, p[2]) for p in pieces]), np.tile(np.arange(count), len(pieces)))


def touch_blocked(probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(M,) bool: points whose ball cannot touch them from ``approach`` mm out along the normal
    without cutting into the part elsewhere, whatever the axis (see :func:`pose_pieces`)."""
    centres, ready = probe.stations(points, normals)
    return obstacles.swept_blocked(centres, ready, probe.radius - obstacles.deflection - 1e-3, margin=False,
                                   overreach=0.5 * obstacles.deflection)


def poses_blocked(probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray,
                  axes: np.ndarray) -> np.ndarray:
    """(M,) bool: the probe poses (see :func:`pose_pieces`) that the part blocks on the way out,
    or whose way out leaves the part's box through its bottom (the clearance plane above could
    not be reached from there)."""
    centres, ready = probe.stations(points, normals)
    grow = probe.radius + probe.clearance
    lengths, exits = obstacles.exits(ready, axes, grow)
    (s_starts, s_ends, s_radii, s_owner), (c_starts, c_ends, c_radii, c_owner) = pose_pieces(
        probe, centres, ready, axes, lengths)
    blocked = exits[:, 2] <= obstacles.box[0, 2] - grow + 1e-9
    swept = obstacles.swept_blocked(s_starts, s_ends, s_radii)
    blocked |= np.bincount(s_owner, weights=swept, minlength=len(points)) > 0
    open_ = ~blocked[c_owner]
    cylinders = obstacles.cylinders_blocked(c_starts[open_], c_ends[open_], c_radii[open_])
    return blocked | (np.bincount(c_owner[open_], weights=cylinders, minlength=len(points)) > 0)


def reach(probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray) -> Access:
    """How the probe reaches each point: the first axis, nearest the normal, whose pose is clear
    (:func:`candidate_axes`, tried for all points still blocked at once). points, normals: (N, 3)
    mm and unit. Returns an Access."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    candidates, usable = candidate_axes(normals, probe)
    axes = np.full((len(points), 3), np.nan)
    searching = ~touch_blocked(probe, obstacles, points, normals)
    refused = ~searching
    ranks = np.full(len(points), -1)
    for rank in range(candidates.shape[1]):
        trying = np.flatnonzero(searching & usable[:, rank])
        if not trying.size:
            if not (searching & usable[:, rank:].any(axis=1)).any():
                break
            continue
        tried = candidates[trying, rank]
        clear = ~poses_blocked(probe, obstacles, points[trying], normals[trying], tried)
        axes[trying[clear]] = tried[clear]
        ranks[trying[clear]] = rank
        searching[trying[clear]] = False
    reachable = ~searching & ~refused
    tilts = np.full(len(points), np.nan)
    tilts[reachable] = np.degrees(np.arccos(np.clip(np.einsum("nc,nc->n", axes[reachable], normals[reachable]),
                                                    -1.0, 1.0)))
    angles = np.full((len(points), 2), np.nan)
    angles[reachable] = head_angles(axes[reachable])
    return Access(reachable, axes, tilts, angles, ranks)


class ExactPoses:
    """OCC's verdict on single probe poses, from the part's faces near each pose.

    A pose's ball and its stylus and body can touch only faces whose bounding boxes meet theirs,
    so OCC measures against a compound of those (a few faces of a large part: on the Ventilator
    the ball's distance took 1.5 ms instead of 50 ms, the stylus's and body's 56 ms instead of
    160 ms). part: the Part.Shape; probe: a Probe.
    """

    def __init__(self, part: Part.Shape, probe: Probe) -> None:
        self.part, self.probe = part, probe
        self.faces = part.Faces
        self.boxes = np.array([[f.BoundBox.XMin, f.BoundBox.YMin, f.BoundBox.ZMin,
                                f.BoundBox.XMax, f.BoundBox.YMax, f.BoundBox.ZMax] for f in self.faces]).reshape(-1, 6)

    def near(self, lower: Sequence[float] | np.ndarray, upper: Sequence[float] | np.ndarray) -> Part.Compound | None:
        """A compound of the faces whose boxes meet the box [lower, upper] (3,) mm grown by
        TOUCH_TOLERANCE, or None where there is none."""
        grown_lower, grown_upper = np.asarray(lower) - TOUCH_TOLERANCE, np.asarray(upper) + TOUCH_TOLERANCE
        chosen = np.flatnonzero(np.all(self.boxes[:, :3] <= grown_upper, axis=1)
                                & np.all(self.boxes[:, 3:] >= grown_lower, axis=1))
        return Part.Compound([self.faces[k] for k in chosen]) if chosen.size else None

    def ball_gap(self, centre: np.ndarray) -> float:
        """The ball centre's (3,) mm distance to the part less the ball's radius, mm (0 when it just
        touches, negative when the ball cuts into the part; the radius where no face is within
        it). Where the centre lies strictly inside the part is :meth:`inside`'s question."""
        radius = self.probe.radius
        nearby = self.near(np.asarray(centre) - radius, np.asarray(centre) + radius)
        if nearby is None:
            return radius
        return nearby.distToShape(Part.Vertex(Vector(centre)))[0] - radius

    def body_clear(self, centre: np.ndarray, axis: np.ndarray) -> bool:
        """True when the stylus and the body with the ball centre at ``centre`` (3,) mm along
        ``axis`` (3,) unit keep off the part (OCC's distance above 0). They start at the ball
        centre, outside the part, so they reach into it only through a face near them."""
        solid = self.probe.solid(centre, axis, with_ball=False)
        box = solid.BoundBox
        nearby = self.near((box.XMin, box.YMin, box.ZMin), (box.XMax, box.YMax, box.ZMax))
        return nearby is None or nearby.distToShape(solid)[0] > 0.0

    def inside(self, point: np.ndarray) -> bool:
        """True when a closed part holds point (3,) mm strictly inside."""
        return bool(self.part.Solids) and any(solid.isInside(Vector(point), 1e-7, False)
                                              for solid in self.part.Solids)


# How far OCC may find the touching ball inside the part (mm) and still call it a touch.
TOUCH_TOLERANCE = 1e-3
# The seconds OCC's stylus and body checks may take for the final points of one run.
EXACT_SECONDS = 20.0
# The coarsest the part's model may know its surface, as a share of the ball's radius: the touch
# test takes that much off the ball.
COARSEST_DEFLECTION = 0.5


class Reachability:
    """Where a probe reaches a part: called with points (M, 3) mm and normals (M, 3) unit, it
    answers (M,) bool (the fast test: a face's domain asks it on a raster).

    part: the Part.Shape the faces belong to; probe: a Probe (default Probe()); spacing: the
    obstacles' point spacing, mm (see :class:`cmmsampling.access.obstacles.Obstacles`). One
    Reachability serves many runs on the part's faces (``sample(face, part=reachability)``).
    """

    _answers: dict[int, np.ndarray]
    _holds: dict[int, bool]

    def __init__(self, part: Part.Shape, probe: Probe | None = None, spacing: float | None = None) -> None:
        self.part = part
        self.probe = probe if probe is not None else Probe()
        self.obstacles = Obstacles(part, spacing)
        if self.obstacles.deflection > COARSEST_DEFLECTION * self.probe.radius:
            raise InputError(
                f"the part is {part.BoundBox.DiagonalLength:.0f} mm across: modelled by at most "
                f"{MAX_POINTS:,} points its surface is known to {self.obstacles.deflection:.2g} mm, too coarse to judge "
                f"a {self.probe.ball_diameter:g} mm ball's touch; give as part= only the faces around this one, or "
                "leave part= out")
        self.exact = ExactPoses(part, self.probe)
        self.measures = True
        self._answers, self._holds = {}, {}

    def __call__(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(M,) bool; the same question (the same points and normals, as a face's raster asks it
        at every N of a search) is answered once."""
        points, normals = np.asarray(points, dtype=float), np.asarray(normals, dtype=float)
        key = hash((points.tobytes(), normals.tobytes()))
        if key not in self._answers:
            self._answers[key] = reach(self.probe, self.obstacles, points, normals).reachable
        return self._answers[key].copy()

    @contextlib.contextmanager
    def unmeasured(self) -> Iterator[Reachability]:
        """Within the block, runs leave their final points' poses unmeasured (their result's
        ``access`` stays None): a search measures only the result it keeps."""
        self.measures = False
        try:
            yield self
        finally:
            self.measures = True

    def holds(self, face: Part.Face) -> bool:
        """True when face (a Part.Face) lies on the part (:func:`cmmsampling.geometry.surface.lies_on`);
        asked once per face (a search asks it at every N)."""
        key = face.hashCode()
        if key not in self._holds:
            self._holds[key] = lies_on(face, self.part)
        return self._holds[key]

    def final(self, points: np.ndarray, normals: np.ndarray) -> tuple[Access, list[int], int]:
        """The Access of final points (M, 3) mm with normals (M, 3) unit, all on one face: each
        point's axis from the fast test, then its pose measured with OCC (:class:`ExactPoses`):
        the ball's touch at every point, the stylus and the body where the fast test is unsure
        (:meth:`unsure`), for at most EXACT_SECONDS in all. A pose OCC finds touching the part
        anywhere but at the ball's contact is unreachable. Returns (Access, [index of each point
        OCC refused], the number of unsure poses the time left to the fast test, which errs on
        the side of blocking)."""
        access = reach(self.probe, self.obstacles, points, normals)
        reached = np.flatnonzero(access.reachable)
        centres = points[reached] + self.probe.radius * normals[reached]
        doubtful = self.unsure(centres, access.axes[reached])
        refused, unmeasured, outward = [], 0, None
        ends = time.perf_counter() + EXACT_SECONDS
        for index, centre, doubt in zip(reached, centres, doubtful):
            touches = self.exact.ball_gap(centre) < -TOUCH_TOLERANCE
            if not touches and outward is None:   # one face's normals all point out of the part, or all in
                outward = not self.exact.inside(centre)
            if doubt and not touches and outward and time.perf_counter() > ends:
                unmeasured += 1
            elif touches or not outward or (doubt and not self.exact.body_clear(centre, access.axes[index])):
                refused.append(int(index))
        if refused:
            access.reachable[refused] = False
            access.axes[refused] = np.nan
            access.tilts[refused] = np.nan
            access.angles[refused] = np.nan
            access.ranks[refused] = -1
        return access, refused, unmeasured

    def unsure(self, centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
        """(M,) bool: the poses, ball centres (M, 3) mm along axes (M, 3) unit, whose stylus or body
        the fast test finds blocked once widened by another margin (it found them clear with
        one): near enough to the part for OCC to judge them."""
        probe, count = self.probe, len(centres)
        starts = np.concatenate([centres + probe.stylus_start * axes, centres + probe.stylus_length * axes])
        ends = np.concatenate([centres + probe.stylus_length * axes, centres + probe.reach * axes])
        radii = np.repeat([0.5 * probe.stylus_diameter, 0.5 * probe.body_diameter], count) + self.obstacles.margin
        blocked = self.obstacles.cylinders_blocked(starts, ends, radii) if count else np.zeros(0, bool)
        return blocked[:count] | blocked[count:]
