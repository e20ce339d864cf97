"""Bad input on plans, probes and point files, refused up front in one line that names it (the
table of issue 33, its row in each test's name); each check here fails on the behaviour that
table found (no error, a raw exception, a point dropped or shifted)."""
import os
import subprocess

import numpy as np
import pytest
from support.faces import FreeCAD, Part
from support.paths import ROOT

import cmmsampling
from cmmsampling import InputError, Probe, cli
from cmmsampling.fitting.substitute import default_pole_count
from cmmsampling.planning import part_plan
from cmmsampling.planning.points_needed import fewest_points, step_counts

PYTHON = "/usr/bin/python3"


@pytest.fixture(scope="module")
def part():
    """A 60 x 40 x 10 mm box with a 20 mm bump on top: faces to plan, a part to probe."""
    return Part.makeBox(60, 40, 10).fuse(Part.makeBox(20, 20, 20, FreeCAD.Vector(20, 10, 0))).removeSplitter()


@pytest.fixture
def no_runs(monkeypatch):
    """Any face run fails the test: a refusal must come before the first."""
    def ran(*args, **kwargs):
        raise AssertionError("a face was run before the input was checked")
    monkeypatch.setattr(part_plan, "_run", ran)


@pytest.mark.parametrize("arguments, message", [
    ({"grid": 1}, "grid must be at least 2, got 1"),
    ({"strategy": "spiral"}, "unknown strategy 'spiral'"),
    ({"strategy": "pso", "iterations": 0}, "iterations must be at least 1, got 0"),
    ({"strategy": "optimal", "time_limit": -1}, "time_limit"),
    ({"min_spacing": -1}, "min_spacing must be at least 0.0, got -1.0"),
    ({"strategy": "pso", "population": 1}, "population must be at least 2, got 1"),
    ({"n_max": 10}, r"n_max \(10\) is below the fewest points a degree-3 substitute is searched from \(16\)"),
    ({"probe": 5}, "probe must be a cmmsampling.Probe"),
])
def test_3_4_11_a_plans_settings_are_checked_before_any_face_runs(part, no_runs, arguments, message):
    with pytest.raises(InputError, match=message):
        cmmsampling.plan(part, tolerance=5, faces=[1], **arguments)


def test_4_a_search_or_a_budget_below_the_fewest_points_is_refused(part, no_runs):
    with pytest.raises(InputError, match=r"give n_max of at least 16"):
        cmmsampling.points_needed(part.Faces[0], 0.5, n_max=10)
    with pytest.raises(InputError, match="give n_total of at least 36"):
        cmmsampling.plan(part, n_total=20, faces=[1], fit_degree=5)


def reference_steps(n_max, degree):
    """step_counts as it was: every N looked at in turn (O(n_max))."""
    steps, n = [], 4
    while n <= n_max:
        poles = default_pole_count(n, degree)
        last = n
        while last + 1 <= n_max and default_pole_count(last + 1, degree) == poles:
            last += 1
        if max(n, poles * poles) <= last:
            steps.append((poles, max(n, poles * poles), last))
        n = last + 1
    return steps


def test_5_the_steps_of_a_billion_points_are_found_by_bisection():
    for degree in (1, 3, (2, 5)):
        for n_max in (4, 15, 16, 17, 400, 2503):
            highest = degree if np.ndim(degree) == 0 else max(degree)
            assert step_counts(n_max, degree) == reference_steps(n_max, highest)
        assert fewest_points(degree) == reference_steps(400, highest)[0][1]
    steps = step_counts(10 ** 9)
    assert steps[-1][2] == 10 ** 9 and len(steps) == steps[-1][0] - 3


@pytest.mark.parametrize("faces, error, message", [
    ([1, 1], InputError, "face 1 is given twice in faces="),
    (1, TypeError, r"faces must be a list of face numbers, e.g. \[1, 3, 5\], got 1"),
    ([True], TypeError, "a face number must be a whole number, got True"),
    ([], InputError, "faces= is empty"),
    ([99], InputError, "there is no face 99"),
])
def test_8_10_face_numbers_are_whole_numbers_each_once(part, no_runs, faces, error, message):
    with pytest.raises(error, match=message):
        cmmsampling.plan(part, tolerance=5, faces=faces)


def test_9_10_numpy_face_numbers_plan_and_faces_with_a_list_of_faces_is_refused(part):
    plan = cmmsampling.plan(part, n_total=16, faces=[np.int64(1)], strategy="uniform_parametric", processes=1)
    assert [face.name for face in plan.faces] == ["Face1"] and plan.n_total == 16
    with pytest.raises(InputError, match="faces= picks faces of a shape by number"):
        cmmsampling.plan([part.Faces[0]], tolerance=5, faces=[1])


@pytest.mark.parametrize("values, message", [
    ({"stylus_length": 0.5}, r"ends inside its 2.0 mm ball; give stylus_length above the ball's radius, 1 mm"),
    ({"body_diameter": 0.1}, "a probe body of 0.1 mm is thinner than its 1.5 mm stylus"),
])
def test_13_a_probe_that_cannot_be_built_is_refused(values, message):
    with pytest.raises(InputError, match=message):
        Probe(**values)


def run_cli(capsys, *argv):
    """(exit code, the last line on stderr) of the command line."""
    code = cli.main([str(a) for a in argv])
    return code, capsys.readouterr().err.strip().splitlines()[-1]


def test_3_4_14_the_command_line_names_its_own_options(part, no_runs, tmp_path, capsys):
    brep = tmp_path / "part.brep"
    part.exportBrep(str(brep))
    assert run_cli(capsys, "plan", brep, "--faces", 1, "--points", 16, "--strategy", "pso", "--population", 1) == (
        2, "error: --population must be at least 2, got 1")
    assert run_cli(capsys, "plan", brep, "--faces", 1, "--tolerance", 0.5, "--max-points", 10) == (
        2, "error: --max-points (10) is below the fewest points a degree-3 substitute is searched from (16); "
           "give --max-points of at least 16")
    code, line = run_cli(capsys, "plan", tmp_path / "missing.step", "--points", 40, "--probe-radius", "nan",
                         "--out", tmp_path / "x.dmi")
    assert (code, line) == (2, "error: --probe-radius must be a finite number, got nan")
    with pytest.raises(SystemExit):
        cli.main(["plan", str(brep), "--faces", "1,1", "--points", "40"])
    assert "face 1 is given twice" in capsys.readouterr().err


def written(tmp_path, name, text, encoding="utf-8"):
    path = tmp_path / name
    path.write_text(text, encoding=encoding)
    return path


DMIS_POINTS = "".join(f"F(P{k})=FEAT/POINT,CART,{k}.0,0.0,0.0,0.0,0.0,1.0\n" for k in range(1, 5))


@pytest.mark.parametrize("line, message", [
    ("F(P1)=FEAT/POINT,CART,9.0,0.0,0.0,0.0,0.0,1.0", r"line 5: F\(P1\) is given twice"),
    ("F(P5=FEAT/POINT,CART,9.0,0.0,0.0,0.0,0.0,1.0", "line 5: a point statement that cannot be read"),
    ("F(P5)=FEAT POINT,CART,9.0,0.0,0.0,0.0,0.0,1.0", "line 5: a point statement that cannot be read"),
])
def test_15_a_dmis_point_is_never_dropped_silently(tmp_path, line, message):
    path = written(tmp_path, "p.dmi", DMIS_POINTS + line + "\n")
    with pytest.raises(InputError, match=message):
        cmmsampling.read_points(path)
    assert len(cmmsampling.read_points(written(tmp_path, "q.dmi", DMIS_POINTS))) == 4


CSV_HEADER = "label,x,y,z,i,j,k,deviation\n"
CSV_ROWS = "P1,1,2,3,0,0,1,0.1\nP2,4,5,6,0,0,1,0.2\n"


@pytest.mark.parametrize("row, message", [
    ("P3,7,8,9,0,0,1,0.3,5\n", "line 4: 9 cells where the header has 8"),
    ("P3,7,8,9,0,0,1\n", "line 4: 7 cells where the header has 8"),
    ("P3,7,8,9,0", "line 4: 5 cells where the header has 8"),
])
def test_16_a_csv_row_of_the_wrong_length_is_named(tmp_path, row, message):
    with pytest.raises(InputError, match=message):
        cmmsampling.read_points(written(tmp_path, "p.csv", CSV_HEADER + CSV_ROWS + row))


def test_17_a_bom_and_semicolons_are_read_and_a_decimal_comma_is_named(tmp_path):
    for name, text, encoding in (("bom.csv", CSV_HEADER + CSV_ROWS, "utf-8-sig"),
                                 ("semicolons.csv", (CSV_HEADER + CSV_ROWS).replace(",", ";"), "utf-8")):
        points = cmmsampling.read_points(written(tmp_path, name, text, encoding))
        assert points.labels == ["P1", "P2"]
        np.testing.assert_array_equal(points.points, [[1, 2, 3], [4, 5, 6]])
    commas = written(tmp_path, "commas.csv", "label;x;y;z;i;j;k\nP1;1,5;2;3;0;0;1\n")
    with pytest.raises(InputError, match=r"line 2: x '1,5' has a decimal comma; write numbers with a decimal "
                                         r"point \(1.5\)"):
        cmmsampling.read_points(commas)


@pytest.mark.parametrize("stated, message", [
    ("nan", "probe_radius_mm must be a finite number, got nan"),
    ("-5", r"probe_radius_mm must be at least 0.0, got -5.0"),
    ("abc", "the stated probe_radius_mm 'abc' is not a number"),
])
def test_18_a_stated_probe_radius_that_is_no_radius_is_refused(part, tmp_path, stated, message):
    path = written(tmp_path, "p.csv", f"# probe_radius_mm: {stated}\n" + CSV_HEADER + CSV_ROWS)
    with pytest.raises(InputError, match=message):
        cmmsampling.measured_deviation(part.Faces[0], path)


def test_19_a_point_a_kilometre_away_is_refused_before_occ(part, tmp_path):
    path = written(tmp_path, "p.csv", CSV_HEADER + CSV_ROWS.replace("P2,4,", "P2,1e308,"))
    with pytest.raises(InputError, match=r"point P2 lies 1e\+308 mm from the origin; check the file's numbers"):
        cmmsampling.measured_deviation(part.Faces[0], path)


def test_20_a_folder_or_a_missing_point_file_is_named(tmp_path):
    (tmp_path / "folder.csv").mkdir()
    with pytest.raises(InputError, match="is a folder, not a point file"):
        cmmsampling.read_points(tmp_path / "folder.csv")
    with pytest.raises(InputError, match="missing.csv: no such file"):
        cmmsampling.read_points(tmp_path / "missing.csv")


def test_20_a_reader_that_leaves_early_ends_the_command_line_quietly(tmp_path):
    brep = tmp_path / "part.brep"
    Part.makeBox(10, 10, 10).exportBrep(str(brep))
    run = subprocess.run(["bash", "-c", f"{PYTHON} -m cmmsampling faces {brep} | true; "
                                        "echo ${PIPESTATUS[0]}"],
                         capture_output=True, text=True, cwd=tmp_path, env={**os.environ, "PYTHONPATH": ROOT},
                         timeout=120)
    assert run.stdout.split() == ["141"] and run.stderr == ""


def test_12_a_part_that_does_not_hold_the_face_is_refused(part):
    far = part.copy()
    far.translate(FreeCAD.Vector(500, 0, 0))
    with pytest.raises(InputError, match=r"the face is not on part= \(a part within x 500..560"):
        cmmsampling.sample(part.Faces[0], 16, "halton", part=far, probe=Probe(), grid=20)
    plan = cmmsampling.plan(part, n_total=16, faces=[1], strategy="uniform_parametric", processes=1)
    doc = FreeCAD.newDocument("OtherPart")
    try:
        other = doc.addObject("Part::Feature", "Other")
        other.Shape = far
        doc.recompute()
        with pytest.raises(InputError, match="Other.Face1 is not the plan's Face1"):
            cmmsampling.add_plan_to_document(plan, doc, other)
        assert [obj.Name for obj in doc.Objects] == ["Other"]
    finally:
        FreeCAD.closeDocument("OtherPart")


@pytest.mark.parametrize("values, message", [
    ({"ball_diameter": 1e6, "stylus_diameter": 1.0}, "ball_diameter 1e\\+06 mm is larger than a CMM probe's"),
    ({"index_step": 0.2}, "index_step 0.2 degrees is finer than an indexing head's"),
    ({"clearance": 1e6}, "clearance 1e\\+06 mm is larger"),
    ({"approach": 1e6}, "approach 1e\\+06 mm is larger"),
    ({"body_length": 1e6}, "body_length 1e\\+06 mm is larger"),
])
def test_1_a_probe_beyond_any_cmms_is_refused_before_its_reach_is_built(values, message):
    with pytest.raises(InputError, match=message):
        Probe(**values)


def test_1_the_largest_probe_judges_a_plate_in_bounded_memory(tmp_path):
    """The largest probe taken, on a 200 mm plate, under a 3 GB address-space limit (FreeCAD's
    libraries take about 1 GB of it): before, each of the values above asked 4-23 GB."""
    script = tmp_path / "largest.py"
    script.write_text(
        "import sys; sys.path[:0] = ['/usr/lib/freecad-python3/lib', sys.argv[1]]\n"
        "import FreeCAD, Part, cmmsampling\n"
        "from cmmsampling.access.probe import LARGEST, Probe\n"
        "plate = Part.makeBox(200, 200, 20)\n"
        "top = next(f for f in plate.Faces if abs(f.BoundBox.ZMin - 20) < 1e-9)\n"
        "probe = Probe(**{**LARGEST, 'stylus_diameter': 3.0, 'body_diameter': 13.2})\n"
        "result = cmmsampling.sample(top, 16, 'halton', part=plate, probe=probe, grid=20)\n"
        "print(int(result.access.reachable.sum()))\n")
    run = subprocess.run(["bash", "-c", f"ulimit -v 3000000; {PYTHON} {script} {ROOT}"], capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0 and run.stdout.split()[-1] == "16", run.stderr[-2000:]


def test_2_a_part_too_large_for_the_ball_is_refused_in_bounded_memory(tmp_path):
    """A part 50 m across with a 2 mm ball: its model is capped at MAX_POINTS points, too coarse
    to judge the ball's touch, so it is refused (before, the part was modelled by points 0.5 mm
    apart: a 3 m part asked 9 GB)."""
    from cmmsampling.access.obstacles import MAX_POINTS, Obstacles

    hall = Part.makeBox(50000, 20000, 5000)
    obstacles = Obstacles(hall)
    assert obstacles.coarsened and len(obstacles.points) <= MAX_POINTS
    with pytest.raises(InputError, match="too coarse to judge a 2 mm ball's touch"):
        cmmsampling.sample(hall.Faces[0], 16, "halton", part=hall, probe=Probe(), grid=20)


def test_22_saving_a_document_again_removes_what_a_killed_save_left(part, tmp_path, capsys):
    brep = tmp_path / "part.brep"
    part.exportBrep(str(brep))
    leftover = tmp_path / "plan.FCStd.0f8fad5b-d9cb-469f-a165-70867728950e"
    other = tmp_path / "other.FCStd.0f8fad5b-d9cb-469f-a165-70867728950e"
    for path in (leftover, other):
        path.write_bytes(b"PK\x03\x04 cut short")
    assert cli.main(["sample", str(brep), "--face", "1", "-n", "9", "--strategy", "halton",
                     "--fcstd", str(tmp_path / "plan.FCStd")]) == 0
    assert f"removed {leftover}, left by a save that was killed midway" in capsys.readouterr().out
    assert not leftover.exists() and other.exists() and (tmp_path / "plan.FCStd").stat().st_size > 1000
