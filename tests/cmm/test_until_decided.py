"""measure_until_decided on the simulated CMM: the paper's reference face made with a known form
error and misplaced on the table is touched over I++ DME until its profile verdict is decided.
The verdict must be the one an independent minimum zone of the true error over a dense raster of
the face gives (a linear programme over the rigid motions, not the run's own alignment), with
far fewer points than the face's candidate places; a part whose profile is the tolerance itself
is never decided; a dropped connection leaves the points measured in the file."""
import os
import re
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest
from scipy.optimize import linprog
from support.dropping_server import serve_then_drop
from support.faulty_cmm import FaultyCMM, held_at
from support.ippdme import check_commands, checker
from support.paths import ROOT

import cmmsampling
from cmmsampling.cmm.client import MeasurementStopped
from cmmsampling.cmm.decided import FIRST, face_candidates, measure_until_decided
from cmmsampling.cmm.server import SimulatedCMM, VirtualPart
from cmmsampling.fitting.series import greedy_design
from cmmsampling.formats.qif.schema import schema_errors
from cmmsampling.geometry.validation import InputError
from cmmsampling.inspection.datums import Datum
from cmmsampling.inspection.simulate import Misplacement, form_waves
from cmmsampling.strategies.sampling import probe_edge_offset

TOLERANCE = 0.05
PLACED = Misplacement(x=0.3, y=-0.2, rz=0.1)
NOISE_MM = 0.0005
# The raster per direction of the face on which the true profile is found.
DENSE = 40
PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable


@pytest.fixture(scope="module")
def places(reference):
    return face_candidates(reference)[0]


def true_profile(face, form):
    """The minimum zone (mm, about the nominal, rigid motions free) of the form error over a
    DENSE x DENSE raster of the face, from OCC's points and normals: a linear programme."""
    u0, u1, v0, v1 = face.ParameterRange
    grid = [(u, v) for u in np.linspace(u0, u1, DENSE) for v in np.linspace(v0, v1, DENSE)]
    points = np.array([tuple(face.valueAt(u, v)) for u, v in grid])
    normals = np.array([tuple(face.normalAt(u, v)) for u, v in grid])
    error = form(points)
    jacobian = np.hstack([normals, np.cross(points - points.mean(axis=0), normals)])
    zone = -np.ones((len(error), 1))
    upper = np.vstack([np.hstack([jacobian, zone]), np.hstack([-jacobian, zone])])   # |error - J m| <= z
    found = linprog(np.r_[np.zeros(6), 1.0], A_ub=upper, b_ub=np.r_[-error, error],
                    bounds=[(None, None)] * 6 + [(0, None)], method="highs")
    assert found.success, found.message
    return 2.0 * found.x[-1]


def made(places, amplitude, seed=3):
    """(the VirtualPart: waves of amplitude mm over the face, misplaced by PLACED, probing noise),
    its form error."""
    form = form_waves(places.points, amplitude, seed)
    return VirtualPart(form, PLACED.matrix(places.points.mean(axis=0)), NOISE_MM, np.random.default_rng(seed)), form


@pytest.mark.parametrize("amplitude", [0.02, 0.07])
def test_the_verdict_is_the_true_profiles_with_few_points(reference, places, amplitude, tmp_path):
    part, form = made(places, amplitude)
    truth = true_profile(reference, form)
    assert abs(truth - TOLERANCE) > 0.01, "a part clearly on one side"
    with SimulatedCMM(part) as cmm:
        found = measure_until_decided(reference, cmm.address, TOLERANCE, out=tmp_path / "m.csv")
    assert found.decision == ("conforms" if truth <= TOLERANCE else "does not conform"), (truth, found)
    assert found.stopped.startswith("decided") and max(found.p_conform, found.p_nonconform) >= 0.95
    assert FIRST <= found.points <= 3 * FIRST < len(places) / 10
    measured = cmmsampling.read_points(tmp_path / "m.csv")
    assert len(measured) == found.points and found.history[-1][0] == found.points
    assert found.inspection.measured_file == str(tmp_path / "m.csv")
    assert found.inspection.profile <= truth + 4 * NOISE_MM, "the measured points' zone within the whole face's"
    report = cmmsampling.export(found, tmp_path / "results.qif")
    assert schema_errors(open(tmp_path / "results.qif", encoding="utf-8").read()) == []
    assert report.passed is found.inspection.passed and report.count == found.points
    assert cmmsampling.read_points(tmp_path / "results.qif").labels == measured.labels
    if checker() is not None:
        assert check_commands(found.run.commands, str(tmp_path)) == []


def test_a_part_whose_profile_is_the_tolerance_is_not_decided(reference, places, tmp_path):
    part, form = made(places, 0.04)
    truth = true_profile(reference, form)
    with SimulatedCMM(part) as cmm:
        found = measure_until_decided(reference, cmm.address, truth + 3 * NOISE_MM, out=tmp_path / "m.csv",
                                      max_points=FIRST + 4)
    assert found.decision is None and found.stopped == f"undecided at the limit of {FIRST + 4} points"
    assert found.points == FIRST + 4 == len(cmmsampling.read_points(tmp_path / "m.csv"))
    assert max(found.p_conform, found.p_nonconform) < 0.95


def test_a_part_within_u_of_the_tolerance_stops_as_undecided_once_the_belief_says_so(reference, places, tmp_path):
    """t set to the part's true profile and U = 2 um: ISO 14253-1 decides neither way, and the run
    stops, undecided, once the belief puts the profile within U of t with probability 1 - risk,
    long before every place is touched."""
    part, form = made(places, 0.045)
    truth = true_profile(reference, form)
    with SimulatedCMM(part) as cmm:
        found = measure_until_decided(reference, cmm.address, truth, 0.001, tmp_path / "m.csv")
    assert found.decision is None and found.stopped.startswith("undecided: the profile lies within U of t with "
                                                               "probability"), found.stopped
    assert 1.0 - found.p_conform - found.p_nonconform >= 0.95
    assert found.points < int(places.touchable.sum()) / 2


def test_a_run_whose_probabilities_stall_stops_undecided():
    """The rule for a verdict the points cannot settle (e.g. an error only where the probe cannot
    touch): STALL_POINTS points that moved neither probability by more than STALL_MOVE."""
    from cmmsampling.cmm.decided import STALL_MOVE, STALL_POINTS, _Limits, _Rules

    rules = _Rules(None, None, np.array([], dtype=int), _Limits(TOLERANCE, 0.0, 0.05, 500, 0))
    flat = [(FIRST + k, 0.6 + 0.4 * STALL_MOVE * np.sin(k), 0.2) for k in range(STALL_POINTS + 1)]
    rules.history = flat[:-1]
    assert not rules._stalled(), "too few points yet"
    rules.history = flat
    assert rules._stalled()
    rules.history = flat[:-1] + [(FIRST + STALL_POINTS, 0.6 + 2 * STALL_MOVE, 0.2)]
    assert not rules._stalled(), "a probability that moved"


def test_a_dropped_connection_keeps_the_points_measured(reference, tmp_path):
    with pytest.raises(MeasurementStopped, match="the CMM closed the connection during|the connection to the CMM was "
                                                 "lost during") as caught:
        measure_until_decided(reference, serve_then_drop(5 + 2 * 8), TOLERANCE, out=tmp_path / "m.csv")
    assert len(caught.value.run.labels) == 8 and not caught.value.run.missing[1:]
    kept = cmmsampling.read_points(tmp_path / "m.csv")
    assert len(kept) == 8 and kept.metadata["run_end"].startswith("stopped")
    assert cmmsampling.inspect(reference, tmp_path / "m.csv").profile < 1e-3, "usable: the perfect part it touched"


@pytest.mark.parametrize("arguments, message", [
    ({"tolerance": 0.0}, "tolerance"),
    ({"risk": 0.5}, "risk"),
    ({"max_points": 5}, "max_points"),
    ({"out": "m.dmi"}, r"written as XYZIJK text \(.xyz, .txt\) or CSV"),
])
def test_bad_arguments_are_refused_before_connecting(reference, tmp_path, arguments, message):
    given = {"tolerance": TOLERANCE, "out": tmp_path / "m.csv", **arguments}
    if not str(given["out"]).startswith("/"):
        given["out"] = tmp_path / given["out"]
    with pytest.raises((InputError, ValueError), match=message):
        measure_until_decided(reference, "127.0.0.1:1", **given)


def test_a_plane_whose_slides_move_nothing_is_decided(tmp_path):
    """A plane's own slides and turn change no deviation: the belief keeps the three motions
    that do, and decides a good and a bad plate."""
    import Part

    plate = next(face for face in Part.makeBox(120, 80, 10).Faces if face.normalAt(0, 0).z > 0.5)
    flat = face_candidates(plate)[0]
    assert flat.rigid.shape[1] == 3
    for amplitude, expected in ((0.01, "conforms"), (0.08, "does not conform")):
        part, form = made(flat, amplitude, seed=4)
        truth = true_profile(plate, form)
        assert (truth <= TOLERANCE) == (expected == "conforms"), truth
        with SimulatedCMM(part) as cmm:
            found = measure_until_decided(plate, cmm.address, TOLERANCE, 0.0005, tmp_path / "m.csv", max_points=40)
        assert found.decision == expected, (truth, found)


@pytest.fixture(scope="module")
def series(reference, places):
    """(form(scale, seed): a part of a series on the reference face, a shape whose size varies
    from part to part plus 2 um of waves of its own; two earlier parts' inspections, 100 points
    each, their shape at 0.03 and 0.036 mm)."""
    shape = form_waves(places.points, 1.0, 11)

    def form(scale, seed):
        own = form_waves(places.points, 0.002, 20 + seed)
        return lambda p: scale * shape(p) + own(p)

    result = cmmsampling.sample(reference, 100, "uniform_parametric", occ_check=False)
    planned = cmmsampling.PointSet.from_result(result)
    earlier = []
    for seed, scale in enumerate((0.03, 0.036)):
        moved = planned.points + form(scale, seed)(planned.points)[:, None] * planned.normals
        earlier.append(cmmsampling.inspect(reference, cmmsampling.PointSet(planned.labels, moved, planned.normals),
                                           alignment="none"))
    return form, earlier


def test_earlier_parts_of_the_series_decide_a_part_near_the_limit_sooner(reference, places, series, tmp_path):
    form, earlier = series
    error = form(0.06, 5)
    truth = true_profile(reference, error)
    assert 0.9 * TOLERANCE < truth < TOLERANCE, truth
    found = {}
    for prior in (None, earlier):
        part = VirtualPart(error, PLACED.matrix(places.points.mean(axis=0)), NOISE_MM, np.random.default_rng(1))
        with SimulatedCMM(part) as cmm:
            found[prior is None] = measure_until_decided(reference, cmm.address, TOLERANCE, NOISE_MM,
                                                         tmp_path / "m.csv", prior=prior)
    aimed, blind = found[False], found[True]
    assert aimed.decision == blind.decision == "conforms", (aimed, blind)
    assert aimed.points < blind.points, (aimed.points, blind.points)
    model = cmmsampling.series_model(reference, earlier)
    touched, uv = face_candidates(reference, edge_offset=probe_edge_offset(reference))
    touchable = np.flatnonzero(touched.touchable)
    first = [f"C{row + 1}" for row in touchable[greedy_design(model, uv[touchable], FIRST, judged=uv)[0]]]
    assert cmmsampling.read_points(tmp_path / "m.csv").labels[:FIRST] == first, "part_error's first design"


def ball_paths_clear(part, commands, radius):
    """(moves between the run's GoTo positions, those whose straight path brings the ball centre
    nearer the part than radius mm: OCC's distance of each segment to the part)."""
    import FreeCAD
    import Part

    positions = np.array([[float(value) for value in re.findall(r"[XYZ]\(([-+0-9.eE]+)\)", command)]
                          for command in commands if " GoTo(" in command])
    moves = [(a, b) for a, b in zip(positions[:-1], positions[1:]) if np.linalg.norm(b - a) > 1e-9]
    near = [a for a, b in moves
            if Part.LineSegment(FreeCAD.Vector(*a), FreeCAD.Vector(*b)).toShape().distToShape(part)[0] < radius - 1e-6]
    return len(moves), len(near)


def test_on_a_part_the_probe_goes_round_what_stands_on_the_face(tmp_path):
    """A base whose upward face surrounds a pillar: with part= and probe= (or the face's probe
    points sampled with them) the run goes round the pillar (no move brings the ball nearer the
    part than its radius, by OCC's distance), and it touches more than the first design; without
    the part its straight moves cross the pillar."""
    import FreeCAD
    import Part

    part = Part.makeBox(80, 60, 10).fuse(Part.makeBox(12, 12, 40, FreeCAD.Vector(34, 24, 10))).removeSplitter()
    face = next(face for face in part.Faces if len(face.Wires) == 2)
    probe = cmmsampling.Probe()

    def form(points):
        return 0.02 * np.sin(points[:, 0] / 9.0) * np.cos(points[:, 1] / 7.0)

    document = FreeCAD.newDocument("pillar")
    try:
        base = document.addObject("Part::Feature", "Base")
        base.Shape = part
        name = f"Face{next(k for k, one in enumerate(base.Shape.Faces, start=1) if len(one.Wires) == 2)}"
        sampled = cmmsampling.sample(base.Shape.getElement(name), 16, "uniform_parametric", part=part, probe=probe,
                                     occ_check=False)
        points = cmmsampling.add_to_document(sampled, document, source=(base, name)).Group[0]
        found = {}
        for key, source, given in (("part", face, {"part": part, "probe": probe}), ("object", points, {}),
                                   ("none", face, {})):
            virtual = VirtualPart(form, np.eye(4), NOISE_MM, np.random.default_rng(1))
            with SimulatedCMM(virtual) as cmm:
                found[key] = measure_until_decided(source, cmm.address, TOLERANCE, out=tmp_path / "m.csv", **given)
    finally:
        FreeCAD.closeDocument(document.Name)
    around, straight = found["part"], found["none"]
    assert around.decision == straight.decision == "conforms" and around.points > FIRST, (around, straight)
    moves, near = ball_paths_clear(part, around.run.commands, probe.radius)
    assert moves > around.points and near == 0, "detours, every one clear"
    assert ball_paths_clear(part, straight.run.commands, probe.radius)[1] > 0, "straight moves cross the pillar"
    gotos = [[command.split(" ", 1)[1] for command in run.run.commands if " GoTo(" in command]
             for run in (around, found["object"])]
    assert gotos[0] == gotos[1], "probe points sampled with the part and probe bring both"
    if checker() is not None:
        assert check_commands(around.run.commands, str(tmp_path)) == []


def test_kill_9_mid_run_leaves_the_points_measured_for_inspect(reference, places, tmp_path):
    """The measuring process killed (kill -9) while it waits for its 15th touch, chosen by the
    belief: the 14 points before are in the file, which inspect reads."""
    part, _ = made(places, 0.045)
    reached, release = threading.Event(), threading.Event()
    script = (f"import sys\nsys.path.insert(0, {ROOT!r})\nimport cmmsampling\n"
              f"cmmsampling.measure_until_decided(cmmsampling.reference_face(), sys.argv[1], {TOLERANCE}, "
              f"out={str(tmp_path / 'm.csv')!r})\n")
    with FaultyCMM(part, held_at(FIRST + 3, reached, release)) as cmm:
        process = subprocess.Popen([PYTHON, "-c", script, cmm.address], stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True)
        try:
            assert reached.wait(300), f"the run never asked for point {FIRST + 3}: {process.poll()}"
            process.send_signal(signal.SIGKILL)
        finally:
            release.set()
            _, err = process.communicate(timeout=60)
    assert process.returncode == -signal.SIGKILL, err
    kept = cmmsampling.read_points(tmp_path / "m.csv")
    assert len(kept) == FIRST + 2 and kept.metadata["run_end"] == "in progress"
    assert np.isfinite(kept.points).all() and len(set(kept.labels)) == FIRST + 2
    found = cmmsampling.inspect(reference, tmp_path / "m.csv", tolerance=TOLERANCE)
    assert len(found.labels) == FIRST + 2 and found.profile < TOLERANCE


def test_a_face_judged_on_datums_is_measured_after_them_and_its_location_counts(tmp_path):
    """A block's top face 0.03 mm too high, with 5 um waves, misplaced on the table: without
    datums its form conforms; on datums A | B | C (bottom, front, left: their points measured
    first, as a plan's) its profile holds the height, twice 0.035 mm, and it does not conform. A
    top only 0.012 mm high conforms on the datums, also where datum A brings its own points (six
    contacts on the bottom, measured before: only B and C are measured). The true profiles: twice the largest error over
    a raster of the top (the datum faces are exact, so the frame is the nominal)."""
    import Part

    block = Part.makeBox(60, 40, 20)

    def face(normal):
        return next(one for one in block.Faces if np.allclose(tuple(one.normalAt(0.5, 0.5)), normal))

    top, frame = face((0, 0, 1)), [face((0, 0, -1)), face((0, -1, 0)), face((-1, 0, 0))]
    grid = np.array([(x, y, 20.0) for x in np.linspace(0, 60, 61) for y in np.linspace(0, 40, 41)])
    placed = PLACED.matrix(np.array([30.0, 20.0, 10.0]))
    found = {}
    for height, datums in ((0.03, None), (0.03, frame), (0.012, frame)):
        def form(points, height=height):
            on_top = points[:, 2] > 20.0 - 1e-6
            return np.where(on_top, height + 0.005 * np.sin(points[:, 0] / 8.0) * np.cos(points[:, 1] / 6.0), 0.0)

        truth = 2.0 * np.abs(form(grid)).max()
        with SimulatedCMM(VirtualPart(form, placed, NOISE_MM, np.random.default_rng(2))) as cmm:
            run = measure_until_decided(top, cmm.address, TOLERANCE, NOISE_MM, tmp_path / "m.csv", datums=datums,
                                        max_points=40)
        found[height, datums is None] = run
        if datums is not None:
            assert run.decision == ("conforms" if truth < TOLERANCE else "does not conform"), (truth, run)
            labels = cmmsampling.read_points(tmp_path / "m.csv").labels
            assert labels[:14] == [f"D{label}{k}" for label, count in (("A", 6), ("B", 4), ("C", 4))
                                   for k in range(1, count + 1)], "the datum points first"
            assert [fit.label for fit in run.inspection.datums] == ["A", "B", "C"]
            assert abs(run.inspection.profile - truth) < 0.01 and run.points == len(labels) - 14
            assert run.inspection.measured_file == str(tmp_path / "m.csv")
            if checker() is not None:
                assert check_commands(run.run.commands, str(tmp_path)) == []
    assert found[0.03, True].decision == "conforms", "the form alone is within t"
    bottom = np.array([(x, y, 0.0) for x in (5.0, 30.0, 55.0) for y in (5.0, 35.0)])   # the last form's part
    own = Datum("A", frame[0], points=bottom @ placed[:3, :3].T + placed[:3, 3])
    with SimulatedCMM(VirtualPart(form, placed, NOISE_MM, np.random.default_rng(2))) as cmm:
        run = measure_until_decided(top, cmm.address, TOLERANCE, NOISE_MM, tmp_path / "own.csv",
                                    datums=[own, Datum("B", frame[1]), Datum("C", frame[2])], max_points=40)
    labels = cmmsampling.read_points(tmp_path / "own.csv").labels
    assert labels[:8] == [f"D{label}{k}" for label in "BC" for k in range(1, 5)], "datum A brought its points"
    assert run.decision == "conforms" and [fit.label for fit in run.inspection.datums] == ["A", "B", "C"]
    report = cmmsampling.export(found[0.03, False], tmp_path / "results.qif")
    written = open(tmp_path / "results.qif", encoding="utf-8").read()
    assert schema_errors(written) == [] and "DatumReferenceFrame" in written and "DA1" in written
    assert report.passed is False
