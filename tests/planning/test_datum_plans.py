"""A plan made with datums: the datum faces planned for the frame (points spread to hold the
motions each fixes, measured first), its DMIS program setting the part's frame from them
(CONST/PLANE BF, DATDEF, DATSET, the move to the CAD frame) and stating the profile (TOL/PROFS,
TA), run by a simulated CMM that fills its OUTPUT, and the output judged with the plan's datums
as inspect(..., datums=...) judges the same points: no datum or tolerance typed twice."""
import re

import numpy as np
import pytest
from support.dmis_cmm import DmisCMM
from support.dmis_syntax import check

import cmmsampling
from cmmsampling.geometry.blocks import DATUM_FACES, TOP, datum_block
from cmmsampling.geometry.validation import InputError
from cmmsampling.inspection.align import transform
from cmmsampling.inspection.simulate import Misplacement, form_waves

MISPLACED = {"rx": 0.4, "ry": -0.3, "rz": 0.9, "x": 1.2, "y": -2.0, "z": 0.5}


@pytest.fixture(scope="module")
def block():
    return datum_block()


@pytest.fixture(scope="module")
def planned(block):
    return cmmsampling.plan(block, tolerance=0.05, faces=[3], datums=[1, 5, 4], processes=1,
                            strategy="uniform_parametric")


def test_the_datum_faces_come_first_with_points_spread_for_the_frame(planned):
    assert [(face.name, face.datum) for face in planned.faces] == [
        ("Face1", "A"), ("Face5", "B"), ("Face4", "C"), ("Face3", "")]
    assert planned.datums == ["Face1", "Face5", "Face4"]
    motions = [face.settings["motions"] for face in planned.faces[:3]]
    assert motions == [3, 2, 1], "a primary plane fixes 3 motions, the secondary 2, the tertiary 1"
    assert [face.n for face in planned.faces[:3]] == [6, 4, 4]
    base = planned.faces[0].points
    assert np.ptp(base[:, 0]) > 60 and np.ptp(base[:, 1]) > 30, "spread over the 100 x 60 base"
    assert "datum A: points spread to fix 3 motions" in planned.table()
    assert np.isfinite(planned.worst) and planned.worst == planned.faces[3].maximum


def test_inspect_takes_the_datums_from_the_plan(planned, block, tmp_path):
    measured = cmmsampling.simulate_measurement(planned, tmp_path / "m.csv", form_error=0.02, noise=0.001, seed=7,
                                                misplacement=MISPLACED)
    own = cmmsampling.inspect(planned, measured.path, part=block, tolerance=0.05)
    typed = cmmsampling.inspect(planned, measured.path, part=block, tolerance=0.05, datums=list(DATUM_FACES))
    assert [datum.label for datum in own.datums] == ["A", "B", "C"]
    assert own.profile == typed.profile and own.passed == typed.passed


def test_a_datum_the_probe_cannot_reach_is_refused_naming_it(block):
    from cmmsampling.access.probe import Probe

    with pytest.raises(InputError) as refused:
        cmmsampling.plan(block, tolerance=0.05, faces=[3], datums=[1], processes=1, probe=Probe(), n_max=30)
    assert str(refused.value) == (
        "datum A (Face1): the probe reaches no point of it on the part (a face the part rests on, or one its own "
        "material hides); measure the datums in a second set-up with the part turned, or choose a face the probe "
        "reaches as datum A (the Datums field; datums=)")


@pytest.mark.parametrize("datums, message", [
    ([9], "the shape has faces 1 to 6; there is no face 9"),
    (["Face9"], "datum 'Face9' is no face of the part"),
    (["Face1", "Face1"], "a datum face is given twice"),
])
def test_bad_datums_are_refused_before_any_run(block, datums, message):
    with pytest.raises(InputError, match=message):
        cmmsampling.plan(block, tolerance=0.05, faces=[3], datums=datums, processes=1)


def test_the_program_sets_the_frame_from_the_datums_and_states_the_profile(planned, block, tmp_path):
    cmmsampling.export(planned, tmp_path / "block.dmi")
    text = (tmp_path / "block.dmi").read_text()
    assert check(text) == []
    statements = [line for line in text.splitlines() if not line.startswith("$$")]
    assert "DATDEF/FA(DAT_A),DAT(A)" in statements and "DATDEF/FA(DAT_C),DAT(C)" in statements
    assert "D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XDIR,XORIG,DAT(C),YORIG" in statements
    assert "T(PROF_Face3)=TOL/PROFS,-0.0250000,0.0250000,DAT(A),DAT(B),DAT(C)" in statements
    assert "$$+ expanded uncertainty U and ISO 14253-1's decision, which DMIS cannot state" in text
    assert "OUTPUT/FA(Face3),TA(PROF_Face3)" in statements
    first_toleranced = next(k for k, line in enumerate(statements) if line.startswith("F(Face3_P1)="))
    assert statements.index("D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XDIR,XORIG,DAT(C),YORIG") < first_toleranced
    assert max(k for k, line in enumerate(statements) if line.startswith("PTMEAS")) > first_toleranced

    points = planned.point_set().points
    part = run_on_simulated_cmm(text, block, ("Face1", "Face3", "Face4", "Face5"), points, tmp_path / "block.dmo")
    read = cmmsampling.read_points(tmp_path / "block.dmo")
    assert read.labels == planned.point_set().labels, "every point reported, datums first"
    nominal = planned.point_set().points
    on_table = transform(part, nominal)
    assert np.abs(on_table - nominal).max() > 1.0, "the part lies mm away from its CAD place on the table"
    toleranced = np.array([label.startswith("Face3_") for label in read.labels])
    assert np.abs(read.points - nominal)[toleranced].max() < 0.1, \
        "touched where planned and reported in the CAD frame the datums set"
    own = cmmsampling.inspect(planned, tmp_path / "block.dmo", part=block)
    typed = cmmsampling.inspect(planned, tmp_path / "block.dmo", part=block, tolerance=0.05, datums=list(DATUM_FACES))
    assert own.tolerance == 0.05, "the plan's tolerance, as its program states it"
    assert abs(own.profile - typed.profile) < 1e-12 and own.passed is typed.passed is True
    assert own.profile < 0.05 and TOP == "Face3"


def run_on_simulated_cmm(text, shape, faces, points, output):
    """Run the DMIS program text on DmisCMM with the shape's named faces, misplaced by MISPLACED
    about (50, 30, 15) with 0.02 mm form waves over the planned points (N, 3); write its output
    file and return the misplacement (4, 4)."""
    part = Misplacement(**MISPLACED).matrix(np.array([50.0, 30.0, 15.0]))
    cmm = DmisCMM({name: shape.Faces[int(name[4:]) - 1] for name in faces}, part, form_waves(points, 0.02, 7))
    output.write_text(cmm.run(text))
    return part


def test_the_qif_plan_carries_the_datum_features_and_the_frame(planned, tmp_path):
    from xml.etree import ElementTree

    cmmsampling.export(planned, tmp_path / "block.qif")   # refused unless the QIF 3.0 schemas take it
    root = ElementTree.parse(tmp_path / "block.qif").getroot()
    ns = {"q": "http://qifstandards.org/xsd/qif3"}
    definitions = root.findall("q:DatumDefinitions/q:DatumDefinition", ns)
    assert [d.findtext("q:DatumLabel", namespaces=ns) for d in definitions] == ["A", "B", "C"]
    nominal_names = {n.get("id"): n.findtext("q:Name", namespaces=ns)
                     for n in root.iter("{http://qifstandards.org/xsd/qif3}PointDefinedSurfaceFeatureNominal")}
    features = [nominal_names[d.findtext("q:FeatureNominalIds/q:Id", namespaces=ns)] for d in definitions]
    assert [name.split()[0] for name in features] == ["Face1", "Face5", "Face4"]
    frame = root.find("q:DatumReferenceFrames/q:DatumReferenceFrame", ns)
    precedences = [d.findtext("q:Precedence/q:PrecedenceEnum", namespaces=ns) for d in frame.findall("q:Datums/q:Datum", ns)]
    assert precedences == ["PRIMARY", "SECONDARY", "TERTIARY"]
    profiles = root.findall(".//q:SurfaceProfileCharacteristicDefinition", ns)
    assert len(profiles) == 1 and profiles[0].findtext("q:DatumReferenceFrameId", namespaces=ns) == frame.get("id")
    assert len(root.findall(".//q:SurfaceProfileCharacteristicItem", ns)) == 1, "the top's profile, none on a datum"


def test_a_live_cmm_measures_the_datums_first_and_the_plan_judges_them(planned, block, tmp_path):
    with cmmsampling.SimulatedCMM.measuring(planned, form_error=0.02, misplacement=MISPLACED, seed=7) as cmm:
        run = cmmsampling.measure(planned, cmm.address, tmp_path / "live.csv")
    touched = np.array([[float(value) for value in re.findall(r"[XYZ]\(([-\d.]+)\)", command)]
                        for command in run.commands if " PtMeas(" in command])
    assert len(touched) == planned.n_total
    np.testing.assert_allclose(touched[:14], planned.point_set().points[:14], atol=1e-6)   # the datums first
    own = cmmsampling.inspect(planned, run, part=block, tolerance=0.05)
    typed = cmmsampling.inspect(planned, run, part=block, tolerance=0.05, datums=list(DATUM_FACES))
    assert [datum.label for datum in own.datums] == ["A", "B", "C"]
    assert abs(own.profile - typed.profile) < 1e-12 and own.passed is typed.passed is True


def test_a_probe_plan_with_datums_measures_them_first_along_its_collision_free_path(block, tmp_path):
    from cmmsampling.access.probe import Probe

    probed = cmmsampling.plan(block, tolerance=0.05, faces=[3], datums=[5, 4], processes=1,
                              strategy="uniform_parametric", probe=Probe(), n_max=30)   # the base lies on the table
    assert probed.faces[0].access is not None and probed.faces[0].access.reachable.all()
    report = cmmsampling.export(probed, tmp_path / "probed.dmi")
    assert report.order == "probe_path", "made with a probe: its path by default"
    assert f"{report.orientations} head orientation(s), {report.tip_changes} tip change(s)" in str(report)
    assert 1 <= report.orientations and report.tip_changes <= report.orientations + 1
    text = (tmp_path / "probed.dmi").read_text()
    assert check(text) == [] and "GOTO/" in text
    measured = [line.split("(")[1].split(")")[0] for line in text.splitlines() if line.startswith("MEAS/POINT,")]
    datum_points = sum(face.n for face in probed.faces if face.datum)
    assert [label.split("_")[0] for label in measured[:datum_points]] == ["Face5"] * 6 + ["Face4"] * 4
    assert "D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XDIR,XORIG" in text
    assert all(label.startswith("Face3_") for label in measured[datum_points:])


@pytest.mark.parametrize("yaw, pitch, roll", [(30, 10, 5), (10, 90, 0), (30, 90, 25), (-120, -90, 40),
                                              (-120, 89.9999, 40), (170, -45, -170)])
def test_the_frame_turns_recompose_the_rotation_at_any_pitch(yaw, pitch, roll):
    """DATSET's move back to the CAD frame (ROTAT about Z, Y, X): Rz Ry Rx of the angles written
    is the rotation, also at a pitch of +-90 deg, where only yaw -+ roll is fixed."""
    from cmmsampling.formats.dmis_datums import yaw_pitch_roll

    from support.dmis_cmm import rotation as turn

    rotation = turn(2, yaw) @ turn(1, pitch) @ turn(0, roll)
    a, b, c = yaw_pitch_roll(rotation)
    assert np.allclose(turn(2, a) @ turn(1, b) @ turn(0, c), rotation, atol=1e-9)


@pytest.fixture
def block_doc(block):
    from support.faces import FreeCAD, closed

    doc = FreeCAD.newDocument("DatumPlan")
    name = doc.Name
    try:
        doc.addObject("Part::Feature", "Block").Shape = block
        doc.recompute()
        yield doc
    finally:
        closed(name)


def statements_of(path):
    """The DMIS statements of a program (its comments left out)."""
    return [line for line in path.read_text().splitlines() if not line.startswith("$$")]


def written(source, folder):
    """export(source) to folder/block.dmi (the folder made): (the ExportReport, the path)."""
    folder.mkdir()
    return cmmsampling.export(source, folder / "block.dmi"), folder / "block.dmi"


def test_the_plan_in_the_document_keeps_its_datums_and_tolerance_for_its_program_and_inspection(
        planned, block, block_doc, tmp_path):
    from support.faces import FreeCAD, closed

    doc = block_doc
    group = cmmsampling.add_plan_to_document(planned, doc, doc.Block)
    assert group.Datums == ["Face1", "Face5", "Face4"] and group.Tolerance.Value == 0.05
    subs = [g for g in group.Group if g.TypeId == "App::DocumentObjectGroup"]
    assert [g.Label for g in subs] == ["Datum A Block Face1", "Datum B Block Face5", "Datum C Block Face4",
                                       "Sampling Block Face3 (uniform_parametric)"]
    datum = subs[0].Group[0]
    assert len(subs[0].Group) == 1 and datum.Substitute is None and datum.Strategy == "datum"
    assert list(datum.Labels) == [f"Face1_P{i}" for i in range(1, 7)]
    np.testing.assert_allclose([tuple(p) for p in datum.Points], planned.faces[0].points, atol=1e-12)
    sheet = doc.getObject("PlanReport")
    assert sheet.get("A6") == "Face1" and sheet.get("G6").startswith("datum A: points spread to fix 3 motions")
    with pytest.raises(InputError, match="Block:Face1 holds a datum's points, spread to hold the part's frame"):
        cmmsampling.reevaluate(datum)

    _, program = written(group, tmp_path / "doc")
    _, console_program = written(planned, tmp_path / "console")
    assert statements_of(program) == statements_of(console_program), \
        "the document's plan writes the console's program: datums, frame, TOL/PROFS"
    cmmsampling.export(group, tmp_path / "doc.qif")   # refused unless the QIF 3.0 schemas take it
    qif = (tmp_path / "doc.qif").read_text()
    assert qif.count("<DatumDefinition ") == 3 and qif.count("<SurfaceProfileCharacteristicItem ") == 1
    run_on_simulated_cmm(program.read_text(), block, ("Face1", "Face3", "Face4", "Face5"), planned.point_set().points,
                         tmp_path / "doc.dmo")
    own = cmmsampling.inspect(group, tmp_path / "doc.dmo")
    typed = cmmsampling.inspect(group, tmp_path / "doc.dmo", tolerance=0.05, datums=list(DATUM_FACES))
    console = cmmsampling.inspect(planned, tmp_path / "doc.dmo", part=block)
    assert own.tolerance == 0.05 and [datum.label for datum in own.datums] == ["A", "B", "C"]
    assert abs(own.profile - typed.profile) < 1e-12 and abs(own.profile - console.profile) < 1e-9
    assert own.passed is typed.passed is console.passed is True

    path, name = str(tmp_path / "plan.FCStd"), group.Name
    doc.saveAs(path)
    closed(doc.Name)
    again = FreeCAD.openDocument(path)
    try:
        reopened = again.getObject(name)
        assert reopened.Datums == ["Face1", "Face5", "Face4"] and reopened.Tolerance.Value == 0.05
        assert statements_of(written(reopened, tmp_path / "reopened")[1]) == statements_of(console_program)
    finally:
        closed(again.Name)


def test_a_probe_plan_with_datums_in_the_document_exports_the_consoles_path(block, block_doc, tmp_path):
    from cmmsampling.access.probe import Probe

    probed = cmmsampling.plan(block, tolerance=0.05, faces=[3], datums=[5, 4], processes=1,
                              strategy="uniform_parametric", probe=Probe(), n_max=30)
    group = cmmsampling.add_plan_to_document(probed, block_doc, block_doc.Block)
    from_document, program = written(group, tmp_path / "doc")
    from_console, console_program = written(probed, tmp_path / "console")
    assert from_document.order == "probe_path" and from_document.tip_changes == from_console.tip_changes
    assert statements_of(program) == statements_of(console_program), \
        "datums first along the same collision-free path"


@pytest.fixture(scope="module")
def bored(block):
    """The datum block with a 16 mm bore through it at (30, 30): base Face1, side Face3 (y = 0),
    bore Face6, the wavy top Face7."""
    from support.faces import FreeCAD, Part

    part = block.cut(Part.makeCylinder(8, 40, FreeCAD.Vector(30, 30, -5)))
    assert [type(part.Faces[k - 1].Surface).__name__ for k in (1, 3, 6)] == ["Plane", "Plane", "Cylinder"]
    return part


def test_a_bore_as_datum_b_is_a_dmis_cylinder_that_sets_the_origin(bored, tmp_path):
    planned = cmmsampling.plan(bored, tolerance=0.05, faces=[7], datums=[1, 6, 3], processes=1,
                               strategy="uniform_parametric")
    assert [(face.name, face.settings.get("motions"), face.n) for face in planned.faces[:3]] == [
        ("Face1", 3, 6), ("Face6", 2, 8), ("Face3", 1, 4)], "a bore gets points for the CMM's cylinder fit"
    cmmsampling.export(planned, tmp_path / "bored.dmi")
    text = (tmp_path / "bored.dmi").read_text()
    assert check(text) == []
    statements = [line for line in dmis_statements_of(text)]
    feature = next(line for line in statements if line.startswith("F(DAT_B)="))
    assert re.fullmatch(r"F\(DAT_B\)=FEAT/CYLNDR,INNER,CART,30\.0000000,30\.0000000,[\d.]+,0\.000000000,"
                        r"0\.000000000,(-)?1\.000000000,16\.0000000,[\d.]+", feature)
    assert "D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XORIG,YORIG,DAT(C),XDIR" in statements
    assert "D(CAD)=TRANS/XORIG,30.0000000,YORIG,30.0000000,ZORIG,0.0000000" in statements, \
        "the frame's origin on the bore's axis, in the base"

    points = planned.point_set().points
    run_on_simulated_cmm(text, bored, ("Face1", "Face3", "Face6", "Face7"), points, tmp_path / "bored.dmo")
    read = cmmsampling.read_points(tmp_path / "bored.dmo")
    top = np.array([label.startswith("Face7_") for label in read.labels])
    assert np.abs(read.points - points)[top].max() < 0.05, "the top touched where planned, in the CAD frame"
    own = cmmsampling.inspect(planned, tmp_path / "bored.dmo", part=bored)
    typed = cmmsampling.inspect(planned, tmp_path / "bored.dmo", part=bored, tolerance=0.05,
                                datums=["Face1", "Face6", "Face3"])
    assert [datum.label for datum in own.datums] == ["A", "B", "C"] and own.datums[1].face == "Face6"
    assert abs(own.profile - typed.profile) < 1e-12 and own.passed is typed.passed is True


def dmis_statements_of(text):
    """The statements of a DMIS program's text (continuations joined, comments left out)."""
    from cmmsampling.formats.dmis import dmis_statements

    return [statement for _, statement in dmis_statements(text)[0]]


def test_a_datum_along_no_axis_of_the_frame_leaves_the_frame_to_the_operator(block, tmp_path):
    corner = next(edge for edge in block.Edges
                  if edge.BoundBox.XMax < 1e-6 and edge.BoundBox.YMax < 1e-6 and edge.BoundBox.ZLength > 1)
    chamfered = block.makeChamfer(10, [corner])
    slanted = next(k for k, face in enumerate(chamfered.Faces, start=1)
                   if face.Surface.__class__.__name__ == "Plane" and abs(abs(face.Surface.Axis.x) - 0.7071) < 1e-3)
    top = next(k for k, face in enumerate(chamfered.Faces, start=1) if face.Surface.__class__.__name__ != "Plane")
    side = next(k for k, face in enumerate(chamfered.Faces, start=1) if abs(face.CenterOfMass.y) < 1e-6)
    planned = cmmsampling.plan(chamfered, tolerance=0.05, faces=[top], datums=[1, side, slanted], processes=1,
                               strategy="uniform_parametric")
    cmmsampling.export(planned, tmp_path / "chamfered.dmi")
    text = (tmp_path / "chamfered.dmi").read_text()
    assert check(text) == [] and "DATSET" not in text and "DATDEF/FA(DAT_C),DAT(C)" in text
    assert ("$$ the datums set no frame here (datum C's plane's normal lies along no axis of the frame the "
            "datums set)") in " ".join(line.lstrip("$+ ") if line.startswith("$$+") else line
                                       for line in text.splitlines())
