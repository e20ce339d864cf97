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
The final points of a run then take as few of an indexing head's orientations as reach them all
(:func:`fewest_orientations`), each change of orientation costing the CMM seconds.
"""
from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..geometry.freecad_env import import_part
from ..geometry.surface import lies_on
from ..geometry.validation import InputError
from .obstacles import MAX_POINTS, Obstacles
from .orientations import Reaches, greedy_cover
from .probe import Probe, Vector, candidate_axes, head_angles, index_axes

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()


@dataclass
class Access:
    """How each point is reached: reachable (N,) bool; axes (N, 3) unit, the probe's axis at
    each reachable point (NaN where none); tilts (N,) degrees between axis and normal; angles
    (N, 2) head angles A, B in degrees (see :func:`cmmsampling.access.probe.head_angles`); ranks
    (N,) int, the first of the head's orientations nearest the normal that reaches it (0: the
    nearest, -1: none; the axis taken may be another that serves more points, see
    :func:`fewest_orientations`); unreached: (K, 4) parameter rectangles (u0, u1, v0, v1) of the face where the
    probe reaches no point, so none was placed there (cmmsampling.geometry.domain), None when
    not judged; unreached_area: their area, mm^2; out_of_reach: (K', 4) rectangles of the face's
    raster cells the probe was found not to reach, on the face or just off it, which a judge of
    the same points leaves out again (:func:`cmmsampling.geometry.domain.face_domain`), None when
    not judged."""

    reachable: np.ndarray
    axes: np.ndarray
    tilts: np.ndarray
    angles: np.ndarray
    ranks: np.ndarray
    unreached: np.ndarray | None = None
    unreached_area: float = 0.0
    out_of_reach: np.ndarray | None = None

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


def orientation_choices(probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray,
                        axes: np.ndarray, judged: bool) -> tuple[np.ndarray, np.ndarray, Reaches, np.ndarray]:
    """Which of an indexing head's orientations reach each of some reachable points, for a set cover.

    points, normals, axes: (N, 3) mm, unit, unit: the points, their normals and the axes they are
    reached along (:func:`reach`). Returns (grid (K, 3) unit, the head's orientations
    (:func:`cmmsampling.access.probe.index_axes`); tilts (N, K) degrees from each normal; reaches,
    a Reaches: an orientation may reach a point within max_tilt of its normal and max_head_angle
    of the vertical, and does where its pose is clear of the part (:func:`poses_blocked`, tested
    when the cover asks), and, unless ``judged`` (a judge will measure them), is not one the fast
    test is unsure of (:func:`unsure_poses`); each point's own axis reaches it; unsure (N, K) bool,
    filled in as the poses are tested: the clear poses the fast test is unsure of).
    """
    grid = index_axes(probe)
    tilts = np.degrees(np.arccos(np.clip(normals @ grid.T, -1.0, 1.0)))
    upright = np.degrees(np.arccos(np.clip(grid[:, 2], -1.0, 1.0))) <= probe.max_head_angle + 1e-9
    unsure = np.zeros(tilts.shape, dtype=bool)

    def test(rows: np.ndarray, column: int) -> np.ndarray:
        axes_k = np.repeat(grid[column][None, :], len(rows), axis=0)
        clear = ~poses_blocked(probe, obstacles, points[rows], normals[rows], axes_k)
        centres = points[rows[clear]] + probe.radius * normals[rows[clear]]
        unsure[rows[clear], column] = unsure_poses(probe, obstacles, centres, axes_k[clear])
        return clear if judged else clear & ~unsure[rows, column]

    reaches = Reaches((tilts <= probe.max_tilt + 1e-9) & upright[None, :], test)
    everyone = np.arange(len(points))
    own = np.argmax(axes @ grid.T, axis=1)
    reaches.possible[everyone, own] = True
    reaches.set(everyone, own, True)
    return grid, tilts, reaches, unsure


# A judge of probe poses: ball centres (M, 3) mm, axes (M, 3) unit -> (M,) int8, 1 where the stylus
# and the body are clear of the part, 0 where not, -1 where it gave no answer (its time ran out).
PoseJudge = Callable[[np.ndarray, np.ndarray], np.ndarray]


def fewest_orientations(probe: Probe, obstacles: Obstacles, points: np.ndarray, normals: np.ndarray,
                        access: Access, judge: PoseJudge | None = None) -> tuple[Access, np.ndarray]:
    """Points (N, 3) mm with normals (N, 3) unit re-aimed so that as few of an indexing head's
    orientations as can serve them do: (their Access, judged (N,) bool: the axis taken was found
    clear by ``judge``).

    The greedy set cover (:func:`cmmsampling.access.orientations.greedy_cover`) over the
    orientations clear of the part (:func:`orientation_choices`); a pose the fast test is unsure
    of, other than the point's own axis in access, is taken only once ``judge`` (e.g. OCC's,
    :meth:`Reachability.final`) finds it clear, and the cover runs again without those it finds
    blocked or leaves unanswered (without a judge, not at all). The axes, tilts and angles change,
    the reach and the ranks stay. A continuous head (index_step None), which needs no index move,
    keeps each point's axis nearest its normal: the Access comes back as it is.
    """
    judged = np.zeros(len(access.reachable), dtype=bool)
    if probe.index_step is None or not access.reachable.any():
        return access, judged
    reached = np.flatnonzero(access.reachable)
    points = np.asarray(points, dtype=float).reshape(-1, 3)[reached]
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)[reached]
    grid, tilts, reaches, unsure = orientation_choices(probe, obstacles, points, normals, access.axes[reached],
                                                       judge is not None)
    everyone = np.arange(len(reached))
    found = np.zeros(tilts.shape, dtype=bool)
    while True:
        chosen = greedy_cover(reaches, tilts)
        asking = unsure[everyone, chosen] & ~found[everyone, chosen]
        if not asking.any():
            break
        assert judge is not None   # without one, the unsure poses reach nothing
        rows, columns = everyone[asking], chosen[asking]
        answers = np.asarray(judge(points[rows] + probe.radius * normals[rows], grid[columns]))
        found[rows[answers == 1], columns[answers == 1]] = True
        reaches.set(rows[answers != 1], columns[answers != 1], False)
    judged[reached] = found[everyone, chosen]
    axes, tilted, angles = access.axes.copy(), access.tilts.copy(), access.angles.copy()
    axes[reached] = grid[chosen]
    tilted[reached] = tilts[everyone, chosen]
    angles[reached] = head_angles(axes[reached])
    return Access(access.reachable.copy(), axes, tilted, angles, access.ranks.copy(), access.unreached,
                  access.unreached_area), judged


def unsure_poses(probe: Probe, obstacles: Obstacles, centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(M,) bool: the poses, ball centres (M, 3) mm along axes (M, 3) unit, whose stylus or body
    the fast test finds blocked once widened by another margin (``obstacles.margin``): near
    enough to the part for OCC to judge them (:meth:`Reachability.final`)."""
    count = len(centres)
    if not count:
        return np.zeros(0, dtype=bool)
    starts = np.concatenate([centres + probe.stylus_start * axes, centres + probe.stylus_length * axes])
    ends = np.concatenate([centres + probe.stylus_length * axes, centres + probe.reach * axes])
    radii = np.repeat([0.5 * probe.stylus_diameter, 0.5 * probe.body_diameter], count) + obstacles.margin
    blocked = obstacles.cylinders_blocked(starts, ends, radii)
    return blocked[:count] | blocked[count:]


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
# The seconds OCC's stylus and body checks may take for the final points of one run, and the
# share of them the orientations' cover may take first (the poses it would take instead of the
# axes nearest the normals).
EXACT_SECONDS = 20.0
COVER_SHARE = 0.5
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
        point's axis from the fast test, as few of an indexing head's orientations as serve them
        all (:func:`fewest_orientations`), then its pose measured with OCC (:class:`ExactPoses`):
        the ball's touch at every point, the stylus and the body where the fast test is unsure
        (:meth:`unsure`), for at most EXACT_SECONDS in all (the cover's own questions, the poses
        it would take instead of the axis nearest the normal, in the first COVER_SHARE of them).
        A pose OCC finds touching the part anywhere but at the ball's contact is unreachable.
        Returns (Access, [index of each point OCC refused], the number of unsure poses the time
        left to the fast test, which errs on the side of blocking)."""
        ends = time.perf_counter() + EXACT_SECONDS
        access = reach(self.probe, self.obstacles, points, normals)
        access, judged = fewest_orientations(self.probe, self.obstacles, points, normals, access,
                                             self.judge_until(ends - (1.0 - COVER_SHARE) * EXACT_SECONDS))
        reached = np.flatnonzero(access.reachable)
        centres = points[reached] + self.probe.radius * normals[reached]
        doubtful = self.unsure(centres, access.axes[reached]) & ~judged[reached]
        refused, unmeasured, outward = [], 0, None
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

    def judge_until(self, deadline: float) -> PoseJudge:
        """A PoseJudge (:func:`fewest_orientations`) that measures the stylus and the body with OCC
        (:meth:`ExactPoses.body_clear`) until time.perf_counter() passes ``deadline`` (s), then
        answers -1."""
        def judge(centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
            answers = np.full(len(centres), -1, dtype=np.int8)
            for k, (centre, axis) in enumerate(zip(centres, axes)):
                if time.perf_counter() > deadline:
                    break
                answers[k] = int(self.exact.body_clear(centre, axis))
            return answers
        return judge

    def unsure(self, centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
        """(M,) bool: the poses, ball centres (M, 3) mm along axes (M, 3) unit, whose stylus or body
        the fast test finds blocked once widened by another margin (it found them clear with
        one): near enough to the part for OCC to judge them (:func:`unsure_poses`)."""
        return unsure_poses(self.probe, self.obstacles, centres, axes)
