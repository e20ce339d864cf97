"""Inspections in the document headless: the measured points and the report in one transaction,
judged on the probe points' own face (or a plan's faces), saved and reopened; bad sources named."""
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from support.faces import FreeCAD, Part, closed, reference_document

import cmmsampling
from cmmsampling import document
from cmmsampling.document.object_types import is_measured_points
from cmmsampling.geometry.validation import InputError, InputTypeError

MISPLACED = {"rz": 0.7, "x": 1.1, "y": -0.6}


@pytest.fixture
def doc():
    d = reference_document("InspectionDoc", 1)
    name = d.Name
    yield d
    closed(name)


@pytest.fixture
def points(doc):
    result = cmmsampling.sample(doc.Body.Shape.Faces[0], 25, "halton", occ_check=False)
    return document.add_to_document(result, doc, source=(doc.Body, "Face1")).Group[0]


def test_an_inspection_goes_in_as_one_step_and_undoes(doc, points, tmp_path):
    cmmsampling.simulate_measurement(points, tmp_path / "m.dmi", form_error=0.05, misplacement=MISPLACED, seed=1)
    found = cmmsampling.inspect(points, tmp_path / "m.dmi", tolerance=0.02)
    before, undo = [o.Name for o in doc.Objects], doc.UndoCount
    group = cmmsampling.add_inspection_to_document(found, doc, source=points)
    measured, sheet = group.Group
    assert is_measured_points(measured) and doc.UndoCount == undo + 1 and not points.Visibility
    assert group.Label == f"Inspection Probe points ({'PASS' if found.passed else 'FAIL'})"
    assert np.allclose([tuple(p) for p in measured.Points], found.points, atol=1e-9)
    assert len(measured.Shape.Vertexes) == 25 and measured.Source == points
    assert measured.Profile.Value == pytest.approx(found.profile)
    assert list(measured.Bands) == found.bands.tolist() and set(found.bands) - {0}
    moved = measured.AlignmentPlacement.multVec(FreeCAD.Vector(*found.measured[3]))
    assert moved.distanceToPoint(FreeCAD.Vector(*found.points[3])) < 1e-9
    assert sheet.get("profile_mm") == pytest.approx(found.profile) and sheet.get("n") == 25
    assert sheet.get("outside") == int(np.count_nonzero(~found.within))
    assert sheet.get("A20") == "Label" and sheet.get("A21") == found.labels[0]
    assert sheet.get("A14") == "Motions the points do not hold" and sheet.get("B14") == "none"
    assert [sheet.get(f"{c}21") for c in "FGH"] == [f"{v:.4f}" for v in found.measured[0]], "as read"
    assert [sheet.get(f"{c}21") for c in "IJK"] == [f"{v:.4f}" for v in found.points[0]], "aligned"
    assert sheet.get(f"M{20 + 25}") in ("in", "near above", "near below", "OUT above", "OUT below")
    assert sheet.get("L20") == "Deviation" and sheet.get("L21") == pytest.approx(found.deviations[0], abs=1e-12)
    assert isinstance(sheet.get("L21"), float) and sheet.getDisplayUnit(f"L{20 + 25}") == "µm", \
        "a signed number in mm, shown in micrometres"
    doc.undo()
    assert [o.Name for o in doc.Objects] == before and points.Visibility


def test_the_points_are_judged_on_their_own_face_where_it_is_now(doc, points, tmp_path):
    cmmsampling.simulate_measurement(points, tmp_path / "m.csv", misplacement=MISPLACED)
    found = cmmsampling.inspect(points, tmp_path / "m.csv")
    assert np.abs(found.deviations).max() < 1e-3 and found.faces[0] == "Body:Face1"
    doc.Body.Shape = Part.makeLine((0, 0, 0), (1, 0, 0))
    doc.recompute()
    with pytest.raises(InputError, match="Probe points cannot be inspected: Body has no Face1"):
        cmmsampling.inspect(points, tmp_path / "m.csv")
    doc.removeObject("Body")
    with pytest.raises(InputError, match="its source face Body:Face1 was deleted"):
        cmmsampling.inspect(points, tmp_path / "m.csv")


def inspected_block_plan(doc, tmp_path):
    """A block's plan of two faces in the document, measured on a virtual CMM and inspected with a
    0.05 mm tolerance: (the plan's group, the Inspection)."""
    block = doc.addObject("Part::Feature", "Block")
    block.Shape = Part.makeBox(40, 30, 10)
    doc.recompute()
    plan = cmmsampling.plan(block.Shape, n_total=32, strategy="uniform_parametric", faces=[1, 6], processes=1)
    group = cmmsampling.add_plan_to_document(plan, doc, block)
    cmmsampling.simulate_measurement(group, tmp_path / "part.dmi", form_error=0.01, misplacement=MISPLACED)
    return group, cmmsampling.inspect(group, tmp_path / "part.dmi", tolerance=0.05)


def test_a_plan_group_is_inspected_on_its_faces(doc, tmp_path):
    group, found = inspected_block_plan(doc, tmp_path)
    assert sorted(set(found.faces)) == ["Block:Face1", "Block:Face6"] and len(found.labels) == 32
    assert found.labels[0].startswith("Face1_P") and found.passed
    inspected = cmmsampling.add_inspection_to_document(found, doc, source=group)
    assert inspected.Label == f"Inspection {group.Label} (PASS)"


def test_saved_and_reopened_the_inspection_keeps_its_figures(doc, points, tmp_path):
    cmmsampling.simulate_measurement(points, tmp_path / "m.dmi", form_error=0.02, seed=3)
    found = cmmsampling.inspect(points, tmp_path / "m.dmi", alignment="none", tolerance=0.1)
    name = cmmsampling.add_inspection_to_document(found, doc, source=points).Group[0].Name
    path = str(tmp_path / "inspected.FCStd")
    doc.saveAs(path)
    closed(doc.Name)
    again = FreeCAD.openDocument(path)
    try:
        measured = again.getObject(name)
        assert is_measured_points(measured) and measured.Verdict == "PASS" and measured.Alignment == "none"
        assert np.allclose(measured.Deviation, found.deviations, atol=1e-12)
        again.recompute()
        assert len(measured.Shape.Vertexes) == 25
    finally:
        closed(again.Name)


def test_what_is_not_an_inspection_or_not_in_the_document_is_refused(doc, points, tmp_path):
    with pytest.raises(InputTypeError, match="takes an Inspection"):
        cmmsampling.add_inspection_to_document(points, doc)
    cmmsampling.simulate_measurement(points, tmp_path / "m.csv")
    found = cmmsampling.inspect(points, tmp_path / "m.csv")
    other = reference_document("Elsewhere", 1)
    try:
        with pytest.raises(InputError, match="source must be the probe points"):
            cmmsampling.add_inspection_to_document(found, other, source=points)
        assert [o.Name for o in other.Objects] == ["Body"]
    finally:
        closed(other.Name)
    with pytest.raises(InputTypeError, match="cannot inspect against a Feature"):
        cmmsampling.inspect(doc.Body, tmp_path / "m.csv")


def test_file_export_writes_a_saved_inspections_results_as_qif(doc, tmp_path):
    from cmmsampling.formats.qif.schema import schema_errors

    group, found = inspected_block_plan(doc, tmp_path)
    inspected, label = cmmsampling.add_inspection_to_document(found, doc, source=group).Name, group.Label
    path = str(tmp_path / "inspected.FCStd")
    doc.saveAs(path)
    closed(doc.Name)
    again = FreeCAD.openDocument(path)
    try:
        report = document.export([again.getObject(inspected)], str(tmp_path / "results.qif"))
        assert report.count == 32 and report.passed is found.passed
        text = (tmp_path / "results.qif").read_text()
        assert schema_errors(text) == [] and f"<Name>{label}</Name>" in text
        back = cmmsampling.read_points(tmp_path / "results.qif")
        assert back.labels == found.labels and np.abs(back.deviation - found.deviations).max() < 1e-12
        assert np.abs(back.points - found.measured).max() < 1e-12, "the points as read"
        forms = [float(e.text) for e in ET.fromstring(text.encode()).iter("{http://qifstandards.org/xsd/qif3}Form")]
        assert forms == [found.face_forms[face] for face in found.face_profiles], "each face aligned alone"
    finally:
        closed(again.Name)


def test_a_datum_referenced_inspection_keeps_its_datums_and_uncertainty(doc, tmp_path):
    from cmmsampling.geometry.blocks import DATUM_FACES, datum_block

    block = doc.addObject("Part::Feature", "Block")
    block.Shape = datum_block()
    doc.recompute()
    plan = cmmsampling.plan(block.Shape, n_total=64, strategy="uniform_parametric", faces=[3, 1, 5, 4], processes=1)
    group = cmmsampling.add_plan_to_document(plan, doc, block)
    cmmsampling.simulate_measurement(group, tmp_path / "block.dmi", form_error=0.02, noise=0.001, seed=7,
                                     misplacement=MISPLACED)
    found = cmmsampling.inspect(group, tmp_path / "block.dmi", tolerance=0.05, datums=DATUM_FACES, uncertainty=0.001)
    assert [datum.face for datum in found.datums] == [f"Block:{face}" for face in DATUM_FACES]
    assert set(found.faces) == {"Block:Face3"} and found.decision is not None
    measured = cmmsampling.add_inspection_to_document(found, doc, source=group).Group[0]
    report = measured.Report
    assert report.get("uncertainty_mm") == pytest.approx(found.profile_uncertainty)
    assert report.get("decision") == found.decision == measured.Decision
    assert measured.ProfileKind.startswith("relative to datums A|B|C") and len(measured.Datums) == 3
    path = str(tmp_path / "datums.FCStd")
    doc.saveAs(path)
    name = measured.Name
    closed(doc.Name)
    again = FreeCAD.openDocument(path)
    try:
        back = again.getObject(name).Proxy.inspection(again.getObject(name))
        assert back.decision == found.decision and back.profile_uncertainty == found.profile_uncertainty
        assert [datum.text() for datum in back.datums] == [datum.text() for datum in found.datums]
        assert back.summary().splitlines()[-1] == found.summary().splitlines()[-1]
    finally:
        closed(again.Name)
