"""Few tip changes: the head orientations a run's points take (a set cover over those that reach
them), the path visiting them orientation by orientation, and the index moves in the time.

Points are checked against the part with OCC directly (the probe built here as solids from its
dimensions, distToShape), not with the code under test; the 4-face Ventilator plan (the issue's
figures: 28 orientations, 47 tip changes) runs with ``-m slow``."""
import os
import re

import numpy as np
import pytest
from support.faces import TESTDATA, FreeCAD, Part

import cmmsampling
from cmmsampling.access.obstacles import Obstacles
from cmmsampling.access.orientations import Reaches, greedy_cover, orientation_changes, orientation_labels
from cmmsampling.access.probe import Motion, Probe, axes_of, head_angles
from cmmsampling.access.probe_moves import moves_through
from cmmsampling.access.reach import TOUCH_TOLERANCE, fewest_orientations, reach

PROBE = Probe()
VENTILATOR = os.path.join(TESTDATA, "Ventilator.stp")
# The plan: four Ventilator faces to 0.05 mm with the 2 mm probe (benchmarks/probe_plans.py).
FOUR_FACES = [14, 57, 60, 61]


def vector(values):
    return FreeCAD.Vector(*(float(v) for v in values))


@pytest.fixture(scope="module")
def channel():
    """A base (top at z = 10) between two walls 50 mm high over x = 0..10 and 50..60."""
    walls = [Part.makeBox(10, 40, 50, vector((x, 0, 10))) for x in (0, 50)]
    return Part.makeBox(60, 40, 10).fuse(walls).removeSplitter()


def floor_of(part, height):
    """The upward face of the part at z = height with the largest area."""
    faces = [f for f in part.Faces if abs(f.BoundBox.ZMin - height) < 1e-9 and abs(f.BoundBox.ZMax - height) < 1e-9]
    return max(faces, key=lambda f: f.Area)


def occ_clear(part, points, normals, axes, probe=PROBE):
    """(N,) bool: the ball touches only (its centre's distance at least the radius, less
    TOUCH_TOLERANCE: OCC's distances to a free-form face) and the stylus and the body keep off
    the part, each point's probe built here with OCC; the smallest of each is printed."""
    balls, bodies = [], []
    for point, normal, axis in zip(points, normals, axes):
        centre = np.asarray(point) + probe.radius * np.asarray(normal)
        stylus = Part.makeCylinder(probe.stylus_diameter / 2, probe.stylus_length, vector(centre), vector(axis))
        body = Part.makeCylinder(probe.body_diameter / 2, probe.body_length,
                                 vector(centre + probe.stylus_length * np.asarray(axis)), vector(axis))
        balls.append(part.distToShape(Part.Vertex(vector(centre)))[0] - probe.radius)
        bodies.append(part.distToShape(stylus.fuse(body))[0])
    print(f"OCC: the balls at least {min(balls):.2g} mm off the part, the styli and bodies {min(bodies):.3g} mm")
    return (np.array(balls) > -TOUCH_TOLERANCE) & (np.array(bodies) > 0.0)


def assert_moves_keep_clear(part, moves, probe=PROBE):
    """Every travel move keeps the ball's radius and the clearance from the part, every move along
    the axis the ball's radius (OCC's distance to the segment)."""
    for kind, gap in {"travel": probe.radius + probe.clearance, "axis": probe.radius}.items():
        for start, end in zip(*moves.segments(kind)):
            if np.linalg.norm(end - start) > 1e-9:
                distance = part.distToShape(Part.LineSegment(vector(start), vector(end)).toShape())[0]
                assert distance >= gap - 1e-6, (kind, start, end, distance)


def selections(text):
    """The sensors a DMIS program selects, in order."""
    return re.findall(r"^SNSLCT/S\((\w[\w.-]*)\)", text, re.M)


def test_the_greedy_cover_serves_every_point_with_few_orientations_least_tilted():
    # four points; orientation 0 reaches the first two, 1 the last two, 2 all but the last, 3 all
    reaches = np.array([[1, 0, 1, 1], [1, 0, 1, 1], [0, 1, 1, 1], [0, 1, 0, 1]], dtype=bool)
    tilts = np.array([[0, 40, 10, 25], [5, 40, 10, 20], [40, 0, 10, 20], [40, 5, 40, 20]], dtype=float)
    chosen = greedy_cover(reaches, tilts)
    assert chosen.tolist() == [3, 3, 3, 3], "the one orientation that reaches them all"
    without_3 = greedy_cover(reaches[:, :3], tilts[:, :3])
    assert reaches[np.arange(4), without_3].all() and len(set(without_3.tolist())) == 2
    assert without_3.tolist() == [0, 0, 1, 1], "each point the least tilted of the two picked"
    with pytest.raises(ValueError, match="1 point"):
        greedy_cover(np.array([[True, False], [False, False]]), np.zeros((2, 2)))
    labels = orientation_labels(axes_of([[30, 60], [0, 0], [30, 60], [0, 45]]))
    assert labels.tolist() == [0, 1, 0, 1], "A0 is vertical whatever B"
    assert orientation_changes(labels, [0, 2, 1, 3]) == 1 and orientation_changes(labels, [0, 1, 2, 3]) == 3


def test_the_cover_tests_only_the_orientations_it_needs_and_picks_as_if_it_knew_them_all():
    rng = np.random.default_rng(5)
    points, orientations = 60, 80
    possible = rng.random((points, orientations)) < 0.4
    truth = possible & (rng.random((points, orientations)) < 0.6)
    truth[np.arange(points), rng.integers(0, orientations, points)] = True
    possible |= truth
    tilts = rng.uniform(0.0, 30.0, (points, orientations))
    asked = []

    def test(rows, column):
        asked.append(len(rows))
        return truth[rows, column]

    lazy = greedy_cover(Reaches(possible, test), tilts)
    assert lazy.tolist() == greedy_cover(truth, tilts).tolist()
    assert truth[np.arange(points), lazy].all()
    print(f"{sum(asked)} of the {int(possible.sum())} possible pairs tested")
    assert sum(asked) < possible.sum(), "each pair tested once at most, and not all of them"


def test_a_motion_counts_the_index_time_once_per_tip_change():
    motion = Motion()
    assert motion.index_time == 3.0, "a PH10-class head: about 3 s an index move"
    assert motion.seconds(200.0, 10, 3.0, 4) == pytest.approx(motion.seconds(200.0, 10, 3.0) + 4 * 3.0)
    assert Motion(index_time=0.0).seconds(200.0, 10, 3.0, 4) == pytest.approx(motion.seconds(200.0, 10, 3.0))
    with pytest.raises(ValueError, match="index_time"):
        Motion(index_time=-1.0)


def test_a_channel_floor_takes_few_orientations_each_selected_once_and_all_reached_clear(channel, tmp_path):
    floor = floor_of(channel, 10.0)
    result = cmmsampling.sample(floor, 25, "uniform_parametric", part=channel, grid=20, edge_offset=0.5)
    access, points, normals = result.access, result.points, result.normals
    assert access.reachable.all()
    obstacles = result.problem.reachability.obstacles
    nearest = reach(PROBE, obstacles, points, normals)   # each point's orientation nearest its normal, as before
    before = len(np.unique(np.round(head_angles(nearest.axes), 4), axis=0))
    after = len(np.unique(np.round(head_angles(access.axes), 4), axis=0))
    print(f"channel floor, 25 points: {before} orientations nearest the normals, {after} after the cover")
    assert 2 <= after < before
    tilts = np.degrees(np.arccos(np.clip(np.einsum("nc,nc->n", access.axes, normals), -1, 1)))
    np.testing.assert_allclose(access.tilts, tilts, atol=1e-9)
    assert tilts.max() <= PROBE.max_tilt + 1e-9 and (access.ranks == nearest.ranks).all()
    assert occ_clear(channel, points, normals, access.axes).all(), "every point reached without collision"
    moves = moves_through(PROBE, obstacles, points, normals, access.axes)
    assert moves.orientations == after and moves.tip_changes == after - 1
    assert_moves_keep_clear(channel, moves)
    cmmsampling.export(result, tmp_path / "channel.dmi")
    selected = selections((tmp_path / "channel.dmi").read_text())
    assert len(selected) == len(set(selected)) == after, "each orientation selected once"


def test_the_path_visits_the_orientations_in_turn_and_its_time_counts_each_index_move(channel):
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(11.5, 48.5, 40), rng.uniform(2, 38, 40), np.full(40, 10.0)])
    normals = np.tile([0.0, 0.0, 1.0], (40, 1))
    obstacles = Obstacles(channel)
    nearest = reach(PROBE, obstacles, points, normals)
    kept = nearest.reachable
    points, normals = points[kept], normals[kept]
    nearest = reach(PROBE, obstacles, points, normals)
    by_travel = moves_through(PROBE, obstacles, points, normals, nearest.axes, by_orientation=False)
    grouped = moves_through(PROBE, obstacles, points, normals, nearest.axes)
    print(f"{len(points)} points, {grouped.orientations} orientations nearest the normals: {by_travel.tip_changes} "
          f"tip changes by travel alone, {grouped.tip_changes} by orientation; {by_travel.seconds:.1f} s, "
          f"{grouped.seconds:.1f} s")
    assert grouped.orientations == by_travel.orientations >= 3
    assert by_travel.tip_changes > grouped.tip_changes == grouped.orientations - 1
    assert grouped.seconds < by_travel.seconds
    slow_head = Motion(index_time=10.0)
    timed = moves_through(PROBE, obstacles, points, normals, nearest.axes, slow_head)
    untimed = Motion(index_time=0.0).seconds(timed.travel, len(points), PROBE.approach)
    assert timed.seconds == pytest.approx(untimed + 10.0 * timed.tip_changes), "10 s per index move"
    continuous = PROBE.with_values(index_step=None)
    turning = moves_through(continuous, obstacles, points, normals, nearest.axes, slow_head)
    assert turning.seconds == pytest.approx(slow_head.seconds(turning.travel, len(points), PROBE.approach)), \
        "a continuous head turns while it moves: no index time"
    access = fewest_orientations(PROBE, obstacles, points, normals, nearest)[0]
    covered = moves_through(PROBE, obstacles, points, normals, access.axes)
    assert covered.orientations < grouped.orientations and covered.seconds < grouped.seconds
    assert_moves_keep_clear(channel, covered)


@pytest.mark.slow
@pytest.mark.skipif(not os.path.isfile(VENTILATOR), reason="the shared test data (Ventilator.stp) is not here")
def test_the_four_face_ventilator_plan_changes_tips_fewer_times_than_it_has_orientations(tmp_path):
    shape = Part.read(VENTILATOR)
    plan = cmmsampling.plan(shape, tolerance=0.05, faces=FOUR_FACES, probe=PROBE, processes=2)
    report = cmmsampling.export(plan, tmp_path / "v.dmi", order="probe_path")
    selected = selections((tmp_path / "v.dmi").read_text())
    changes = sum(a != b for a, b in zip(selected[:-1], selected[1:]))
    orientations = len(set(selected))
    moves = plan.probe_moves()
    print(f"Ventilator faces {FOUR_FACES}: {plan.n_total} points, {orientations} orientations, {changes} tip "
          f"changes, {report.length_after:.1f} mm of moves, about {report.seconds:.0f} s (issue 77 found 28 and 47)")
    assert changes <= orientations == moves.orientations <= 28 and changes < 47
    assert moves.tip_changes <= moves.orientations
    points = np.concatenate([face.points for face in plan.placed])
    normals = np.concatenate([face.normals for face in plan.placed])
    axes = np.concatenate([face.axes for face in plan.placed])
    assert occ_clear(shape, points, normals, axes).all(), "every point reached without collision"
    assert_moves_keep_clear(shape, moves)


@pytest.fixture(scope="module")
def sheltered():
    """A base (its top at z = 10) under a roof (its top at z = 35) that overhangs it by 10 mm
    on a pillar: the base's points under the roof are reached only with the stylus tilted."""
    pillar = Part.makeBox(40, 40, 20, vector((60, 0, 10)))
    roof = Part.makeBox(50, 40, 5, vector((50, 0, 30)))
    return Part.makeBox(100, 40, 10).fuse(pillar).fuse(roof).removeSplitter()


def top_face(shape, z: float) -> int:
    """The 1-based index of `shape`'s one horizontal face at height `z` (mm); OCC's numbering of a
    fused solid's faces differs between FreeCAD versions."""
    found = [k for k, face in enumerate(shape.Faces, start=1)
             if abs(face.BoundBox.ZLength) < 1e-9 and abs(face.BoundBox.ZMin - z) < 1e-9]
    assert len(found) == 1, f"one horizontal face at z = {z}: {found}"
    return found[0]


def test_a_plan_shares_one_orientation_across_faces_that_each_covered_with_their_own(sheltered, monkeypatch,
                                                                                       tmp_path):
    from cmmsampling.planning import part_plan

    sharing, own = part_plan.share_orientations, {}

    def recorded(plan):
        own.update({face.name: orientation_labels(face.axes).max() + 1 for face in plan.placed})
        own["together"] = orientation_labels(np.concatenate([face.axes for face in plan.placed])).max() + 1
        sharing(plan)

    monkeypatch.setattr(part_plan, "share_orientations", recorded)
    roof, base = (top_face(sheltered, z) for z in (35.0, 10.0))
    plan = cmmsampling.plan(sheltered, n_total=32, faces=[roof, base], probe=PROBE, processes=1,
                            strategy="uniform_parametric")
    assert own == {f"Face{roof}": 1, f"Face{base}": 1, "together": 2}, \
        "the roof vertical, the base tilted under the roof"
    points = np.concatenate([face.points for face in plan.placed])
    normals = np.concatenate([face.normals for face in plan.placed])
    axes = np.concatenate([face.axes for face in plan.placed])
    assert len(np.unique(np.round(head_angles(axes), 4), axis=0)) == 1, "one tilted orientation serves both"
    assert occ_clear(sheltered, points, normals, axes).all(), "every point reached without collision"
    moves = plan.probe_moves()
    assert moves.orientations == 1 and moves.tip_changes == 0
    assert_moves_keep_clear(sheltered, moves)
    cmmsampling.export(plan, tmp_path / "sheltered.dmi")
    assert len(set(selections((tmp_path / "sheltered.dmi").read_text()))) == 1
