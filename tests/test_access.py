"""Where the probe reaches a part and a collision-free path through the points, on parts built
here with Part: a deep narrow slot, a floor under an overhang, a floor beside a tall wall.

The checks use OCC directly (the probe built here as solids from its dimensions, distToShape),
not the code under test."""
import numpy as np
import pytest
from geometry import FreeCAD, Part

import cmmsampling
from cmmsampling.access.obstacles import Obstacles
from cmmsampling.access.probe import Probe, candidate_axes, head_angles
from cmmsampling.access.reach import reach
from cmmsampling.planning.probe_moves import probe_moves

PROBE = Probe()
UP = np.array([0.0, 0.0, 1.0])


def vector(values):
    return FreeCAD.Vector(*(float(v) for v in values))


def floor_of(part, height):
    """The upward face of the part at z = height with the largest area."""
    faces = [f for f in part.Faces if abs(f.BoundBox.ZMin - height) < 1e-9 and abs(f.BoundBox.ZMax - height) < 1e-9
             and f.normalAt(*f.Surface.parameter(f.CenterOfMass)).z > 0.5]
    return max(faces, key=lambda f: f.Area)


@pytest.fixture(scope="module")
def slot():
    """A 60 x 40 x 30 mm block with a slot 6 mm wide and 15 mm deep along x: floor at z = 15,
    walls at y = 17 and 23."""
    return Part.makeBox(60, 40, 30).cut(Part.makeBox(60, 6, 15, vector((0, 17, 15))))


@pytest.fixture(scope="module")
def overhang():
    """A base (top at z = 10) with a wall along y = 0..5 holding a shelf over y = 0..20 at
    z = 25..30: the floor under the shelf is 15 mm below it."""
    base = Part.makeBox(60, 40, 10)
    wall = Part.makeBox(60, 5, 20, vector((0, 0, 10)))
    shelf = Part.makeBox(60, 20, 5, vector((0, 0, 25)))
    return base.fuse([wall, shelf]).removeSplitter()


@pytest.fixture(scope="module")
def beside_wall():
    """A base (top at z = 10) with a wall 50 mm high over x = 0..10."""
    return Part.makeBox(60, 40, 10).fuse(Part.makeBox(10, 40, 60, vector((0, 0, 10)))).removeSplitter()


def occ_gaps(part, point, normal, axis, probe=PROBE):
    """(ball centre's distance to the part less the ball radius, distance from the stylus and the
    body to the part), mm, with the probe built here."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    centre = np.asarray(point, float) + probe.radius * np.asarray(normal, float)
    stylus = Part.makeCylinder(probe.stylus_diameter / 2, probe.stylus_length, vector(centre), vector(axis))
    body = Part.makeCylinder(probe.body_diameter / 2, probe.body_length,
                             vector(centre + probe.stylus_length * axis), vector(axis))
    ball = part.distToShape(Part.Vertex(vector(centre)))[0] - probe.radius
    return ball, part.distToShape(stylus.fuse(body))[0]


def floor_points(xs, ys, height):
    xx, yy = np.meshgrid(xs, ys, indexing="ij")
    points = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, height)], axis=1)
    return points, np.tile(UP, (len(points), 1))


def assert_clear(part, points, normals, access):
    """Every reachable point's probe touches with its ball only, checked with OCC."""
    for k in np.flatnonzero(access.reachable):
        ball, rest = occ_gaps(part, points[k], normals[k], access.axes[k])
        assert ball > -1e-6 and rest > 0.0, (points[k], access.axes[k], ball, rest)


def test_the_probe_is_checked_and_its_head_angles_are_the_axis():
    with pytest.raises(ValueError, match="thicker than its 2.0 mm ball"):
        Probe(stylus_diameter=3.0)
    with pytest.raises(ValueError, match="ball_diameter must be greater than 0"):
        Probe(ball_diameter=0.0)
    axes = np.array([[0, 0, 1.0], [1, 0, 0], [0, -np.sqrt(0.5), np.sqrt(0.5)]])
    np.testing.assert_allclose(head_angles(axes), [[0, 0], [90, 0], [45, -90]], atol=1e-9)
    candidates, usable = candidate_axes([UP], PROBE)
    tilts = np.degrees(np.arccos(np.clip(candidates[0, usable[0]] @ UP, -1, 1)))
    assert tilts[0] == 0.0 and np.all(np.diff(tilts) >= -1e-9) and tilts.max() <= PROBE.max_tilt + 1e-9
    angles = head_angles(candidates[0, usable[0]])
    assert np.allclose(np.round(angles / 7.5) * 7.5, angles, atol=1e-6), "an index step of 7.5 deg"


def test_a_narrow_slot_floor_is_reachable_only_near_its_middle(slot):
    floor = floor_of(slot, 15.0)
    points, normals = floor_points([10.0, 30.0, 50.0], np.linspace(17.1, 22.9, 30), 15.0)
    access = reach(PROBE, Obstacles(slot), points, normals)
    off_middle = np.abs(points[:, 1] - 20.0)
    assert access.reachable.any() and not access.reachable.all()
    assert off_middle[access.reachable].max() < 2.0, "the ball cannot touch within its radius of a wall"
    assert access.reachable[off_middle < 0.5].all()
    assert floor.Area == pytest.approx(360.0)
    assert_clear(slot, points, normals, access)
    for k in np.flatnonzero(off_middle > 2.05):
        ball, _ = occ_gaps(slot, points[k], normals[k], UP)
        assert ball < 0.0, "refused: the ball itself cuts into the wall"


def test_a_floor_under_an_overhang_needs_tilts_and_refuses_deep_under(overhang):
    points, normals = floor_points([30.0], np.linspace(6.0, 38.0, 33), 10.0)
    access = reach(PROBE, Obstacles(overhang), points, normals)
    y = points[:, 1]
    assert access.reachable[y > 30].all() and (access.tilts[y > 30] == 0).all()
    assert access.tilted.any(), "points near the shelf's edge are reached tilted"
    assert not access.reachable[y < 10].any(), "deep under the shelf nothing is reachable"
    tilted = access.axes[access.tilted]
    assert (tilted[:, 1] > 0).all(), "tilted out from under the shelf"
    assert_clear(overhang, points, normals, access)
    margin = Obstacles(overhang).margin
    for k in np.flatnonzero(access.tilted):
        _, rest = occ_gaps(overhang, points[k], normals[k], UP, PROBE.with_values(body_length=40.0 + 30.0))
        assert rest < margin, "upright, the stylus or the body on its way up would come within the margin"


def test_a_floor_beside_a_wall_tilts_away_from_it(beside_wall):
    points, normals = floor_points(np.linspace(10.5, 30.0, 40), [20.0], 10.0)
    access = reach(PROBE, Obstacles(beside_wall), points, normals)
    x = points[:, 0]
    assert not access.reachable[x < 10.9].any()
    assert access.reachable[x > 12.0].all()
    assert access.tilted.any() and (access.axes[access.tilted][:, 0] > 0).all()
    assert (access.tilts[x > 25] == 0).all()
    assert_clear(beside_wall, points, normals, access)


def path_through(part, points, normals):
    obstacles = Obstacles(part)
    access = reach(PROBE, obstacles, points, normals)
    kept = access.reachable
    return probe_moves(PROBE, obstacles, points[kept], normals[kept], access.axes[kept])


@pytest.mark.parametrize("name", ["slot", "overhang", "beside_wall"])
def test_every_travel_move_keeps_the_clearance_and_the_path_is_short(name, request):
    part = request.getfixturevalue(name)
    rng = np.random.default_rng(7)
    low, high = {"slot": ((2, 18.5), (58, 21.5)), "overhang": ((2, 6), (58, 38)),
                 "beside_wall": ((11, 2), (58, 38))}[name]
    height = 15.0 if name == "slot" else 10.0
    points = np.column_stack([rng.uniform(low, high, (40, 2)), np.full(40, height)])
    normals = np.tile(UP, (40, 1))
    moves = path_through(part, points, normals)
    print(f"{name}: {len(moves.order)} points, path {moves.travel:.1f} mm, straight nearest-neighbour order "
          f"{moves.straight:.1f} mm (with its detours {moves.baseline:.1f} mm), {moves.detours} detours, "
          f"about {moves.seconds:.0f} s")
    assert len(moves.order) >= 10 and sorted(moves.order) == list(range(len(moves.order)))
    assert moves.travel <= moves.baseline + 1e-6
    need = {"travel": PROBE.radius + PROBE.clearance, "axis": PROBE.radius}
    for kind, gap in need.items():
        for start, end in zip(*moves.segments(kind)):
            if np.linalg.norm(end - start) < 1e-9:
                continue
            distance = part.distToShape(Part.LineSegment(vector(start), vector(end)).toShape())[0]
            assert distance >= gap - 1e-6, (kind, start, end, distance)
    touches = moves.segments("touch")
    assert len(touches[0]) == 2 * len(moves.order)


def test_sampling_with_the_part_keeps_to_what_the_probe_reaches(slot):
    floor = floor_of(slot, 15.0)
    result = cmmsampling.sample(floor, 16, "halton", part=slot, grid=20)
    assert result.access.reachable.all() and not result.notes
    assert np.abs(result.points[:, 1] - 20.0).max() < 2.0
    for point, normal, axis in zip(result.points, result.normals, result.access.axes):
        ball, rest = occ_gaps(slot, point, normal, axis)
        assert ball > -1e-6 and rest > 0.0
    assert result.settings["probe"]["ball_diameter"] == 2.0
    with pytest.raises(ValueError, match="give part="):
        cmmsampling.sample(floor, 16, "halton", probe=PROBE)
    with pytest.raises(ValueError, match="the probe reaches no point of this face"):
        cmmsampling.sample(floor, 16, "halton", part=slot, probe=Probe(ball_diameter=7.0, stylus_diameter=2.0))
