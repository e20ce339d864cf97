"""plan(read_mbd(path)): every characteristic the model judges is planned with its own tolerance
and its datums' faces, or listed with the reason; a tolerance per face in plan()."""
import dataclasses

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
    faces = ctc_01_plan.faces
    used = {label for c in ctc_01_plan.characteristics for label in c.datums}
    assert set(ctc_01_plan.datum_faces) == used
    toleranced = {name for c in ctc_01_plan.characteristics for name in c.faces}
    datum_only = [name for label in sorted(used) for name in ctc_01.datums[label].faces if name not in toleranced]
    assert [face.name for face in faces[:len(datum_only)]] == datum_only
    labels = {name: label for label in used for name in ctc_01.datums[label].faces}
    assert all(face.datum == labels[face.name] and face.n >= 8 for face in faces[:len(datum_only)])
    assert ctc_01_plan.datums == []   # the model's several frames: no single frame in the program


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
