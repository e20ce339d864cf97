"""Where the probe reaches a part and a collision-free path through the points, on parts built
here with Part: a deep narrow slot, a floor under an overhang, a floor beside a tall wall.

The checks use OCC directly (the probe built here as solids from its dimensions, distToShape),
not the code under test."""
import json
import re

import numpy as np
import pytest
from support.faces import FreeCAD, Part

import cmmsampling
from cmmsampling.access.obstacles import Obstacles
from cmmsampling.access.probe import Probe, candidate_axes, head_angles
from cmmsampling.access.reach import Reachability, reach
from cmmsampling.document.export_defaults import starting_options
from cmmsampling.access.probe_moves import moves_through

PROBE = Probe()
UP = np.array([0.0, 0.0, 1.0])
# The head's mounting vector in a sensor's SNSDEF, pivot to ball centre, whatever its angles.
MOUNTING = "0.000000000,0.000000000,-1.000000000"


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


@pytest.fixture(scope="module")
def channel():
    """A base (top at z = 10) between two walls 50 mm high over x = 0..10 and 50..60: the floor
    between them, 40 mm wide, takes the probe tilted away from each wall near it."""
    walls = [Part.makeBox(10, 40, 50, vector((x, 0, 10))) for x in (0, 50)]
    return Part.makeBox(60, 40, 10).fuse(walls).removeSplitter()


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


def test_a_continuous_head_starts_at_the_normal_and_tilts_in_rings(beside_wall):
    continuous = PROBE.with_values(index_step=None)
    normal = np.array([0.0, 0.6, 0.8])
    candidates, usable = candidate_axes([normal], continuous)
    tilts = np.degrees(np.arccos(np.clip(candidates[0] @ normal, -1, 1)))
    assert np.allclose(np.linalg.norm(candidates[0], axis=1), 1.0)
    assert tilts[0] < 1e-6 and usable[0, 0], "the normal itself first: no head grid to snap to"
    assert tilts.max() <= continuous.max_tilt + 1e-6 and len(np.unique(np.round(tilts, 6))) > 3
    points, normals = floor_points(np.linspace(10.5, 30.0, 40), [20.0], 10.0)
    access = reach(continuous, Obstacles(beside_wall), points, normals)
    assert access.reachable[points[:, 0] > 12.0].all() and not access.reachable[points[:, 0] < 10.9].any()
    assert_clear(beside_wall, points, normals, access)


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


def path_through(part, points, normals, by_orientation=True):
    obstacles = Obstacles(part)
    access = reach(PROBE, obstacles, points, normals)
    kept = access.reachable
    return moves_through(PROBE, obstacles, points[kept], normals[kept], access.axes[kept],
                         by_orientation=by_orientation)


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
    by_travel = path_through(part, points, normals, by_orientation=False)
    print(f"{name}: {len(moves.order)} points, path {moves.travel:.1f} mm, straight nearest-neighbour order "
          f"{moves.straight:.1f} mm (with its detours {moves.baseline:.1f} mm), {moves.detours} detours, "
          f"{moves.orientations} orientations, {moves.tip_changes} tip changes ({by_travel.tip_changes} ordered by "
          f"travel alone), about {moves.seconds:.0f} s")
    assert len(moves.order) >= 10 and sorted(moves.order) == list(range(len(moves.order)))
    assert by_travel.travel <= by_travel.baseline + 1e-6, "by travel alone, never longer than the straight order"
    assert moves.seconds <= by_travel.seconds + 1e-9 and moves.tip_changes < max(moves.orientations, 1)
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
    assert result.access.reachable.all()
    assert np.abs(result.points[:, 1] - 20.0).max() < 2.0
    rectangles = result.access.unreached
    area = float(np.prod(rectangles[:, 1::2] - rectangles[:, 0::2], axis=1).sum())
    assert result.access.unreached_area == pytest.approx(area) and 0.5 * floor.Area < area < floor.Area
    assert result.notes[0] == (f"the probe cannot reach {area:.4g} mm^2 of the face ({100 * area / floor.Area:.3g} %) "
                               "without touching the part elsewhere: no point was placed there")
    assert all("reproduces this face exactly" in note for note in result.notes[1:]), "the floor is a plane"
    given = cmmsampling.evaluate(floor, result.uv, part=slot, grid=20)
    assert given.notes[0].endswith("without touching the part elsewhere: none of the given points lies there")
    moved = result.uv.copy()
    moved[:2] = [tuple(floor.Surface.parameter(vector((x, 17.5, 15.0)))) for x in (10.0, 30.0)]
    assert cmmsampling.evaluate(floor, moved, part=slot, grid=20).notes[0].endswith(
        ": 2 of the 16 given points lie there"), "given points are not placed: they may lie out of reach"

    def inside(uv):
        return ((rectangles[:, 0] <= uv[0]) & (uv[0] <= rectangles[:, 1])
                & (rectangles[:, 2] <= uv[1]) & (uv[1] <= rectangles[:, 3])).any()

    assert not any(inside(floor.Surface.parameter(vector(p))) for p in result.points)
    for x, y in ((10.0, 17.5), (30.0, 22.5), (50.0, 17.6)):
        assert inside(floor.Surface.parameter(vector((x, y, 15.0))))
        assert occ_gaps(slot, (x, y, 15.0), UP, UP)[0] < 0.0
    for point, normal, axis in zip(result.points, result.normals, result.access.axes):
        ball, rest = occ_gaps(slot, point, normal, axis)
        assert ball > -1e-6 and rest > 0.0
    assert result.settings["probe"]["ball_diameter"] == 2.0
    with pytest.raises(ValueError, match="give part="):
        cmmsampling.sample(floor, 16, "halton", probe=PROBE)
    with pytest.raises(ValueError, match="the probe reaches no point of this face"):
        cmmsampling.sample(floor, 16, "halton", part=slot, probe=Probe(ball_diameter=7.0, stylus_diameter=2.0))


def test_a_probe_path_program_names_its_sensors_and_moves(channel, tmp_path):
    from support import dmis_syntax

    floor = floor_of(channel, 10.0)
    result = cmmsampling.sample(floor, 25, "uniform_parametric", part=channel, grid=20, edge_offset=0.5)
    assert result.access.reachable.all() and result.access.tilted.any()
    assert any("reached only with the stylus tilted" in note for note in result.notes)
    report = cmmsampling.export(result, tmp_path / "wall.dmi", order="probe_path")
    text = (tmp_path / "wall.dmi").read_text()
    assert dmis_syntax.check(text) == []
    moves = moves_through(PROBE, result.problem.reachability.obstacles, result.points, result.normals,
                        result.access.axes)
    gotos = np.array([[float(v) for v in line[5:].split(",")] for line in text.splitlines()
                      if line.startswith("GOTO/")])
    expected = np.round(np.concatenate([np.concatenate(pair) for pair in moves.travel_pairs()]), 7)
    repeats = [k for k in range(1, len(expected)) if (expected[k] == expected[k - 1]).all()]
    np.testing.assert_allclose(gotos, np.delete(expected, repeats, axis=0), atol=1e-3)   # no move to where it is
    assert "MODE/AUTO,PROG,MAN" in text.splitlines()   # a program with moves runs on DCC
    sensors = {tuple(np.round(a, 4) + 0.0) for a in head_angles(result.access.axes)}
    assert text.count("=SNSDEF/PROBE,INDEX,POL,") == len(sensors) >= 2
    assert text.count("SNSLCT/S(") == len(sensors), "each orientation selected once: its points together"
    reach = f"{PROBE.stylus_length + PROBE.body_length:.7f},{PROBE.ball_diameter:.7f}"
    for a, b in sensors:
        assert f"S(A{a:g}B{b:g})=SNSDEF/PROBE,INDEX,POL,{a:.4f},{b:.4f},{MOUNTING},{reach}" in text.replace("$\n", "")
    assert report.order == "probe_path" and report.length_after == pytest.approx(moves.travel)
    assert "Collision-free probe path" in str(report) and report.seconds > 0
    back = cmmsampling.read_points(tmp_path / "wall.dmi")
    assert sorted(back.labels) == sorted(result.labels)
    cmmsampling.export(result, tmp_path / "wall.csv", order="probe_path")
    table = cmmsampling.read_points(tmp_path / "wall.csv")
    order = [result.labels.index(label) for label in table.labels]
    np.testing.assert_allclose(table.axes, result.access.axes[order], atol=1e-6)
    plain = cmmsampling.sample(floor, 16, "uniform_parametric", grid=20)
    with pytest.raises(ValueError, match="sample the face with part="):
        cmmsampling.export(plain, tmp_path / "plain.dmi", order="probe_path")


def test_a_plan_with_a_probe_keeps_to_its_reach_and_writes_one_path(beside_wall, tmp_path):
    from support import dmis_syntax

    upward = [k for k, face in enumerate(beside_wall.Faces, start=1)
              if face.normalAt(*face.Surface.parameter(face.CenterOfMass)).z > 0.5]
    plan = cmmsampling.plan(beside_wall, tolerance=0.5, strategy="uniform_parametric", faces=upward, probe=PROBE,
                            processes=1, grid=20, n_max=60)
    assert len(plan.placed) == 2 and all(face.axes is not None and not face.unreached for face in plan.placed)
    assert sum(face.tilted for face in plan.placed) > 0
    assert any("tilted" in face.line for face in plan.placed)
    report = cmmsampling.export(plan, tmp_path / "part.dmi", order="probe_path")
    text = (tmp_path / "part.dmi").read_text()
    assert dmis_syntax.check(text) == [] and "GOTO/" in text and report.count == plan.n_total
    from support.faces import closed

    doc = FreeCAD.newDocument("PlanReach")
    try:
        part = doc.addObject("Part::Feature", "Part")
        part.Shape = beside_wall
        doc.recompute()
        group = cmmsampling.add_plan_to_document(plan, doc, part)
        kept = cmmsampling.document.probe_points_in([group])
        for face, points in zip(plan.placed, kept):
            np.testing.assert_allclose([tuple(a) for a in points.Axes], face.axes)
            assert sum(points.Tilted) == face.tilted and points.Report.get("tilted") == face.tilted
            assert list(points.Labels) == [f"{face.name}_P{k}" for k in range(1, face.n + 1)]
        sheet = next(obj for obj in group.Group if obj.TypeId == "Spreadsheet::Sheet")
        below = 7 + len(plan.faces)
        assert [sheet.get(f"A{below + k}") for k in (1, 2, 3, 4, 5)] == [
            "Probe", "Probe path", "Measuring time", "Orientations", "Tip changes"]
        assert sheet.get(f"B{below + 1}").startswith("2 mm ball, 20 mm stylus")
        assert sheet.get(f"B{below + 2}") == pytest.approx(report.length_after)
        assert sheet.get(f"B{below + 3}") == pytest.approx(report.seconds)
        moves = plan.probe_moves()
        assert [sheet.get(f"B{below + k}") for k in (4, 5)] == [moves.orientations, moves.tip_changes]
        assert text.count("SNSLCT/S(") == moves.tip_changes + 1 <= moves.orientations + 1
        exported = cmmsampling.document.export([group], str(tmp_path / "from_document.dmi"))
        from_document = (tmp_path / "from_document.dmi").read_text()
        assert dmis_syntax.check(from_document) == [] and exported.order == "probe_path"
        assert exported.count == plan.n_total and exported.length_after == pytest.approx(report.length_after)
        options = starting_options(group)
        assert options["order"] == "probe_path" and options["probe_radius"] == 1.0, "the plan's 2 mm ball"
        (tmp_path / "command").mkdir()
        cmmsampling.export(group, tmp_path / "command" / "from_document.dmi", **options)
        assert (tmp_path / "command" / "from_document.dmi").read_text() == from_document, \
            "File > Export writes what the Export command's dialog starts with"
        assert "$$ ball_radius_mm: 1.0" in from_document and "SNSDEF/" in from_document
        labels = re.findall(r"^F\((\w+)\)=FEAT/POINT", from_document, re.M)
        assert sorted(labels) == sorted(re.findall(r"^F\((\w+)\)=FEAT/POINT", text, re.M))
        assert len(set(labels)) == len(labels) == plan.n_total
        for program in (text, from_document):
            offsets = json.loads(re.search(r"^\$\$ edge_offset_mm: (.*)$", program, re.M).group(1))
            assert offsets == {face.name: face.settings["edge_offset"] for face in plan.placed}, "the offsets used"
        name = group.Name
        doc.saveAs(str(tmp_path / "planned.FCStd"))
        FreeCAD.closeDocument(doc.Name)
        reopened = FreeCAD.openDocument(str(tmp_path / "planned.FCStd")).getObject(name)
        assert cmmsampling.document.export([reopened], str(tmp_path / "reopened.dmi")).count == plan.n_total
        with pytest.raises(ValueError, match="found 2"):
            cmmsampling.document.export(cmmsampling.document.probe_points_in([reopened]), str(tmp_path / "two.dmi"))
    finally:
        closed("PlanReach")
        closed("planned")
    with pytest.raises(ValueError, match="give probe="):
        cmmsampling.plan(beside_wall, tolerance=0.5, part=beside_wall)


def test_the_document_keeps_the_reach_and_draws_the_path_in_two_objects(beside_wall, tmp_path):
    from support.faces import closed

    index = next(k for k, face in enumerate(beside_wall.Faces, start=1)
                 if abs(face.BoundBox.ZMax - 10.0) < 1e-9 and face.Area > 1000)
    result = cmmsampling.sample(beside_wall.Faces[index - 1], 16, "halton", part=beside_wall, grid=20)
    doc = FreeCAD.newDocument("ProbePathDocument")
    try:
        doc.UndoMode = 1
        body = doc.addObject("Part::Feature", "Body")
        body.Shape = beside_wall
        doc.recompute()
        group = cmmsampling.add_to_document(result, doc, source=(body, f"Face{index}"))
        labels = [obj.Label for obj in group.Group]
        assert labels[-2:] == ["Probe moves", "Probe touches"]
        moves = cmmsampling.probe_moves(result)
        touches = doc.getObject("ProbeTouches").Shape.Edges
        assert len(touches) == 2 * result.n
        assert doc.getObject("ProbeMoves").Shape.Length == pytest.approx(moves.travel, rel=1e-9)
        points, report = group.Group[0], group.Group[2]
        np.testing.assert_allclose([tuple(a) for a in points.Axes], result.access.axes)
        assert list(points.Tilted) == list(result.access.tilted) and any(points.Tilted)
        assert json.loads(points.Probe) == result.settings["probe"]
        np.testing.assert_allclose(np.reshape(points.Unreached, (-1, 4)), result.access.unreached)
        assert points.UnreachedArea.Value == pytest.approx(result.access.unreached_area)
        assert report.get("tilted") == int(result.access.tilted.sum()) and report.get("unreached") == 0
        assert report.get("unreached_mm2") == pytest.approx(result.access.unreached_area)
        for source, name in ((result, "result.dmi"), (points, "document.dmi")):
            cmmsampling.export(source, tmp_path / name, order="probe_path")
        assert (tmp_path / "document.dmi").read_text().count("GOTO/") > result.n
        assert gotos(tmp_path / "document.dmi") == gotos(tmp_path / "result.dmi")
        cmmsampling.reevaluate(points)   # judged again with its probe on its part: the axes and the path stay
        np.testing.assert_allclose([tuple(a) for a in points.Axes], result.access.axes)
        assert json.loads(points.Probe) == result.settings["probe"]
        cmmsampling.export(points, tmp_path / "reevaluated.dmi", order="probe_path")
        assert gotos(tmp_path / "reevaluated.dmi") == gotos(tmp_path / "result.dmi")
        doc.undo()
        doc.undo()
        assert doc.getObject("ProbeMoves") is None and [o.Name for o in doc.Objects] == ["Body"]
        plain = cmmsampling.add_to_document(cmmsampling.sample(beside_wall.Faces[index - 1], 9, "halton", grid=20),
                                            doc, source=(body, f"Face{index}")).Group[0]
        assert not plain.Probe and not plain.Axes and not plain.Unreached
        with pytest.raises(ValueError, match="sampled without the part"):
            cmmsampling.export(plain, tmp_path / "plain.dmi", order="probe_path")
    finally:
        closed("ProbePathDocument")


def gotos(path):
    """The GOTO lines of a DMIS file."""
    return [line for line in path.read_text().splitlines() if line.startswith("GOTO/")]


def test_the_command_line_keeps_to_the_probe_and_writes_its_path(beside_wall, tmp_path, capsys):
    from support import dmis_syntax
    from cmmsampling import cli

    brep = tmp_path / "walled.brep"
    beside_wall.exportBrep(str(brep))
    index = next(k for k, face in enumerate(beside_wall.Faces, start=1)
                 if abs(face.BoundBox.ZMax - 10.0) < 1e-9 and face.Area > 1000)
    out = tmp_path / "floor.dmi"
    assert cli.main(["sample", str(brep), "--face", str(index), "-n", "16", "--strategy", "halton",
                     "--probe", "2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "reached only with the stylus tilted" in printed and "Collision-free probe path" in printed
    text = out.read_text()
    assert dmis_syntax.check(text) == [] and "GOTO/" in text and "SNSLCT/S(" in text
    assert f"walled.brep:Face{index}" in text
    assert cli.main(["sample", str(brep), "--face", str(index), "-n", "16", "--order", "probe_path",
                     "--out", str(tmp_path / "plain.dmi")]) == 2
    assert "--order probe_path needs --probe" in capsys.readouterr().err
    upward = ",".join(str(k) for k, face in enumerate(beside_wall.Faces, start=1)
                      if face.normalAt(*face.Surface.parameter(face.CenterOfMass)).z > 0.5)
    assert cli.main(["plan", str(brep), "--faces", upward, "--tolerance", "0.5", "--strategy", "uniform_parametric",
                     "--max-points", "40", "--processes", "1", "--probe", "2",
                     "--out", str(tmp_path / "plan.dmi")]) == 0
    assert "tilted" in capsys.readouterr().out and "GOTO/" in (tmp_path / "plan.dmi").read_text()


def test_a_large_ball_touches_a_large_plain_face():
    """The ball's touch is tested by balls along its approach that reach at most half the
    tessellation's deflection beyond it: a 14 mm ball on a 200 mm plate was refused before
    ("the probe reaches no point of this face"), as the covering balls reached 0.06 mm past it."""
    plate = Part.makeBox(200, 200, 20)
    for ball in (12.0, 14.0, 20.0):
        probe = Probe(ball_diameter=ball, stylus_diameter=3.0)
        result = cmmsampling.sample(floor_of(plate, 20.0), 16, "halton", part=plate, probe=probe, grid=20)
        assert result.access.reachable.all() and not result.access.tilted.any()


@pytest.mark.parametrize("max_points", [2_000_000, 20_000])
def test_the_parts_points_are_capped_and_still_cover_its_faces(max_points):
    """A cylinder's caps tessellate into long thin triangles, filled in rows along their longest
    side; points inside a fine tessellation's triangles lie within the margin (spacing plus
    deflection) of the model's points, however far a cap on their number widened the spacing."""
    cylinder = Part.makeCylinder(20, 50)
    obstacles = Obstacles(cylinder, max_points=max_points)
    assert len(obstacles.points) <= max_points and obstacles.coarsened == (obstacles.spacing > 0.5)
    assert obstacles.tree.query(points_within(cylinder))[0].max() <= obstacles.margin


def points_within(shape, per_triangle=20, seed=0):
    """Random points inside the triangles of a fine tessellation of each face, (P, 3) mm."""
    random = np.random.default_rng(seed)
    found = []
    for face in shape.Faces:
        vertices, triangles = face.tessellate(0.01)
        corners = np.array([tuple(v) for v in vertices])[np.array(triangles)]
        weights = random.dirichlet(np.ones(3), size=(len(corners), per_triangle))
        found.append(np.einsum("tkc,tcd->tkd", weights, corners).reshape(-1, 3))
    return np.concatenate(found)


def poses_around(part, height, xs, ys):
    """Floor points of ``part`` at ``height`` on a grid and the fast test's Access of them."""
    points, normals = floor_points(xs, ys, height)
    return points, normals, Reachability(part, PROBE)


@pytest.mark.parametrize("name", ["slot", "overhang", "beside_wall"])
def test_final_poses_are_judged_as_occ_judges_them_on_the_whole_part(name, request):
    """final() measures each pose against the faces near it, and the stylus and body only where
    the fast test is unsure: it refuses exactly the poses the whole part refuses (occ_gaps)."""
    part = request.getfixturevalue(name)
    height, ys = {"slot": (15.0, np.linspace(17.5, 22.5, 9)), "overhang": (10.0, np.linspace(6.0, 38.0, 17)),
                  "beside_wall": (10.0, np.linspace(2.0, 38.0, 5))}[name]
    xs = np.linspace(10.5, 30.0, 9) if name == "beside_wall" else [10.0, 30.0]
    points, normals, reachability = poses_around(part, height, xs, ys)
    fast = reach(PROBE, reachability.obstacles, points, normals)
    access, refused, unmeasured = reachability.final(points, normals)
    expected = []
    for k in np.flatnonzero(fast.reachable):
        ball, rest = occ_gaps(part, points[k], normals[k], fast.axes[k])
        if ball < -1e-3 or rest <= 0.0:
            expected.append(int(k))
    assert refused == expected and unmeasured == 0
    assert access.reachable.sum() == fast.reachable.sum() - len(expected)
    unsure = reachability.unsure(points[fast.reachable] + PROBE.radius * normals[fast.reachable],
                                 fast.axes[fast.reachable])
    print(f"{name}: {fast.reachable.sum()} reached by the fast test, {unsure.sum()} unsure, {len(refused)} refused")
    assert not unsure.all(), "the poses far from the part are not measured again"
    if name == "slot":
        upside_down, _, _ = reachability.final(points, -normals)
        assert not upside_down.reachable.any(), "a ball centre inside the part touches nothing, and is refused"


def test_a_ball_that_grazes_a_low_step_is_refused_by_occ():
    """A 0.05 mm step lies within the fast touch test's allowance (the tessellation's deflection,
    0.1 mm here): the fast test lets the ball touch beside it, OCC finds the ball cutting the step."""
    plate = Part.makeBox(60, 40, 10).fuse(Part.makeBox(30, 40, 0.05, vector((30, 0, 10)))).removeSplitter()
    points, normals, reachability = poses_around(plate, 10.0, [29.0, 29.5, 29.8, 29.9], [20.0])
    fast = reach(PROBE, reachability.obstacles, points, normals)
    access, refused, _ = reachability.final(points, normals)
    gaps = [occ_gaps(plate, point, normal, UP)[0] for point, normal in zip(points, normals)]
    assert fast.reachable.all() and refused == [2, 3] and np.all(np.array(gaps)[refused] < -1e-3)
    assert access.reachable.tolist() == [True, True, False, False]


def test_poses_left_unmeasured_when_the_time_runs_out_keep_the_fast_answer(slot, monkeypatch):
    from cmmsampling.access import reach as reach_module

    points, normals, reachability = poses_around(slot, 15.0, [10.0, 30.0], np.linspace(17.5, 22.5, 9))
    fast = reach(PROBE, reachability.obstacles, points, normals)
    unsure = reachability.unsure(points[fast.reachable] + PROBE.radius * normals[fast.reachable],
                                 fast.axes[fast.reachable])
    monkeypatch.setattr(reach_module, "EXACT_SECONDS", -1.0)
    access, refused, unmeasured = reachability.final(points, normals)
    assert unsure.any() and unmeasured == unsure.sum() and refused == []
    np.testing.assert_array_equal(access.reachable, fast.reachable)
    floor = floor_of(slot, 15.0)
    uv = [tuple(floor.Surface.parameter(vector(point))) for point in points[fast.reachable]]
    result = cmmsampling.evaluate(floor, uv, part=reachability, grid=20, occ_check=False)
    assert f"{unsure.sum()} point(s) whose stylus or body passes near the part were judged by the fast test " \
        "only" in " ".join(result.notes)


def test_a_search_measures_only_the_result_it_returns(monkeypatch):
    """The tolerance search runs several N; OCC measures the probe's poses of the one it keeps."""
    calls = []
    measured = Reachability.final
    monkeypatch.setattr(Reachability, "final", lambda self, *a: calls.append(len(a[0])) or measured(self, *a))
    cylinder = Part.makeCylinder(20, 50)
    side = max(cylinder.Faces, key=lambda face: face.Area)
    answer = cmmsampling.points_needed(side, 1e-4, "halton", part=cylinder, grid=20, n_max=60, occ_check=False)
    assert len(answer.tried) > 1 and calls == [answer.n]
    assert answer.result.access is not None and answer.result.settings["probe"]["ball_diameter"] == 2.0
    assert answer.result.timings["reach_s"] > 0
