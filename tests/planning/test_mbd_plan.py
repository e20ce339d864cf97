"""plan(read_mbd(path)): every characteristic the model judges is planned with its own tolerance
and its datums' faces, or listed with the reason; a tolerance per face in plan()."""
import dataclasses

import numpy as np
import pytest

import cmmsampling
from cmmsampling.geometry.validation import InputError
from support.mbd import shared_mbd


@pytest.fixture(scope="module")
def ctc_01():
    return cmmsampling.read_mbd(shared_mbd("nist_ctc_01_asme1_ap242.qif"))


@pytest.fixture(scope="module")
def ctc_01_plan(ctc_01):
    return cmmsampling.plan(ctc_01, strategy="hammersley")


def test_each_judged_characteristic_is_planned_on_its_faces_with_its_tolerance(ctc_01, ctc_01_plan):
    planned = {c.id for c in ctc_01_plan.characteristics}
    assert planned == {c.id for c in ctc_01.judged()} and not ctc_01_plan.unplanned
    faces = {face.name: face for face in ctc_01_plan.faces}
    for c in ctc_01_plan.characteristics:
        for name in c.faces:
            assert faces[name].n > 0 and faces[name].met
            tightest = min(other.tolerance for other in ctc_01_plan.characteristics if name in other.faces)
            assert ctc_01_plan.face_tolerances[name] == tightest


def test_datum_faces_are_planned_first_with_the_model_labels(ctc_01, ctc_01_plan):
    faces = {face.name: face for face in ctc_01_plan.faces}
    used = {label for c in ctc_01_plan.characteristics for label in c.datums}
    assert set(ctc_01_plan.datum_faces) == used
    toleranced = {name for c in ctc_01_plan.characteristics for name in c.faces}
    datum_only = [name for label in sorted(used) for name in ctc_01.datums[label].faces if name not in toleranced]
    assert datum_only and all(faces[name].datum and faces[name].n >= 8 for name in datum_only)
    assert all(faces[name].datum == label for label in used for name in ctc_01.datums[label].faces
               if name in datum_only)
    assert ctc_01_plan.datums == []   # the model's several frames: each characteristic judged on its own


def test_the_program_sets_its_frame_on_the_models_datums_measured_first(ctc_01, ctc_01_plan, tmp_path):
    from support.dmis_cmm import DmisCMM
    from support.dmis_syntax import check

    from cmmsampling.formats.dmis import dmis_statements
    from cmmsampling.inspection.simulate import Misplacement, form_waves

    frame = {"A": ("Face36",), "B": ("Face43", "Face44"), "C": ("Face57", "Face58")}
    assert ctc_01_plan.program_frame == frame, "the frame of most datums that DMIS can state (a plane, two bores)"
    first = [name for faces in frame.values() for name in faces]
    assert [face.name for face in ctc_01_plan.faces[:len(first)]] == first, "A's toleranced face measured first too"
    cmmsampling.export(ctc_01_plan, tmp_path / "ctc_01.dmi")
    text = (tmp_path / "ctc_01.dmi").read_text()
    assert check(text) == []
    statements = [statement for _, statement in dmis_statements(text)[0]]
    assert "DATDEF/FA(DAT_B),DAT(B)" in statements and "DATDEF/FA(DAT_C),DAT(C)" in statements
    assert any(line.startswith("F(DAT_B)=FEAT/CYLNDR,INNER,") for line in statements), "the bore's halves: one cylinder"
    assert "D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XORIG,YORIG" in statements
    assert "datum C (Face57 Face58) sets nothing DATSET can state" in text.replace("\n$$+", "")
    planned = ctc_01_plan.point_set()
    # Shifted and tilted on the table, not turned about A's normal (which C fixes and DATSET cannot state).
    misplaced = Misplacement(rx=0.3, ry=-0.25, x=1.5, y=-2.0, z=0.8).matrix(planned.points.mean(axis=0))
    names = sorted(set(planned.faces))
    cmm = DmisCMM({name: ctc_01.shape.getElement(name) for name in names}, misplaced, form_waves(planned.points, 0.01, 5))
    (tmp_path / "ctc_01.dmo").write_text(cmm.run(text))
    read = cmmsampling.read_points(tmp_path / "ctc_01.dmo")
    nominal = dict(zip(planned.labels, planned.points))
    offsets = np.linalg.norm(read.points - np.array([nominal[label] for label in read.labels]), axis=1)
    after = np.array([label.rsplit("_P", 1)[0] not in first for label in read.labels])
    assert len(read) == len(planned) and after.sum() > 100
    assert offsets[after].max() < 0.05 < offsets[~after].max(), \
        "touched where planned once the frame is set (the datum points where the misplaced part was)"
    found = cmmsampling.inspect(ctc_01_plan, tmp_path / "ctc_01.dmo")
    assert all(np.isfinite(c.value) for c in found.characteristics)


def test_the_qif_plan_carries_the_program_frame_each_datum_on_all_its_faces(ctc_01_plan, tmp_path):
    from xml.etree import ElementTree

    cmmsampling.export(ctc_01_plan, tmp_path / "ctc_01.qif")   # refused unless the QIF 3.0 schemas take it
    ns = {"q": "http://qifstandards.org/xsd/qif3"}
    root = ElementTree.parse(tmp_path / "ctc_01.qif").getroot()
    names = {n.get("id"): n.findtext("q:Name", namespaces=ns)
             for n in root.iter("{http://qifstandards.org/xsd/qif3}PointDefinedSurfaceFeatureNominal")}
    definitions = root.findall("q:DatumDefinitions/q:DatumDefinition", ns)
    assert {d.findtext("q:DatumLabel", namespaces=ns): [names[i.text].split()[0] for i in d.iterfind(
        "q:FeatureNominalIds/q:Id", ns)] for d in definitions} == {"A": ["Face36"], "B": ["Face43", "Face44"],
                                                                    "C": ["Face57", "Face58"]}
    assert len(root.findall("q:DatumReferenceFrames/q:DatumReferenceFrame/q:Datums/q:Datum", ns)) == 3


def test_the_program_names_the_model_and_each_characteristic(ctc_01_plan, tmp_path):
    points = ctc_01_plan.point_set()
    assert set(points.metadata["characteristics"]) == {c.id for c in ctc_01_plan.characteristics}
    assert "tolerance_mm" not in points.metadata
    cmmsampling.export(ctc_01_plan, tmp_path / "ctc_01.dmi")
    text = (tmp_path / "ctc_01.dmi").read_text().replace("\n$$+", "")
    assert "nist_ctc_01_asme1_ap242.qif" in text and "Perpendicularity 1.5 mm to A on Face85" in text


def test_a_characteristic_whose_datum_has_no_face_is_listed_not_planned(ctc_01):
    datums = {**ctc_01.datums, "B": dataclasses.replace(ctc_01.datums["B"], faces=())}
    changed = dataclasses.replace(ctc_01, datums=datums)
    found = cmmsampling.plan(changed, strategy="hammersley")
    unplanned = {c.id: why for c, why in found.unplanned}
    assert set(unplanned) == {c.id for c in ctc_01.judged() if "B" in c.datums}
    assert all("datum B has no face" in why for why in unplanned.values())
    assert all(any(line.startswith(c) for line in found.not_planned()) for c in unplanned)


def test_plan_takes_a_tolerance_per_face_and_names_a_face_left_out(ctc_01):
    shape = ctc_01.shape
    found = cmmsampling.plan(shape, tolerance={"Face36": 0.2, "Face85": 0.05}, faces=[36, 85], strategy="hammersley")
    assert found.face_tolerances == {"Face36": 0.2, "Face85": 0.05} and found.tolerance == 0.05
    assert found.point_set().metadata["tolerance_mm_by_face"] == {"Face36": 0.2, "Face85": 0.05}
    with pytest.raises(InputError, match="no tolerance for Face85"):
        cmmsampling.plan(shape, tolerance={"Face36": 0.2}, faces=[36, 85], strategy="hammersley")


def test_a_models_plan_and_inspection_refuse_what_the_model_states(ctc_01, ctc_01_plan):
    with pytest.raises(InputError, match="leave tolerance=, datums= out"):
        cmmsampling.plan(ctc_01, tolerance=0.05, datums=["Face36"])
    with pytest.raises(InputError, match="leave alignment=, tolerance= out"):
        cmmsampling.inspect(ctc_01_plan, "measured.csv", tolerance=0.1, alignment="best_fit")
