"""File > Open and File > Import of a QIF 3.0 MBD model (cmmsampling.document.mbd_import, the
hook Init.py registers for .qif), headless on NIST's ctc_01 (skipped where the shared models
are absent): a new document with the part (the file's B-rep, a valid solid) and its
Characteristics sheet, one row per characteristic; Import adds them to a document as one Undo
step; a file that is no MBD model is refused in one line and no document is made."""

import pytest
from support.faces import FreeCAD
from support.mbd import shared_mbd

from cmmsampling.document import mbd_import
from cmmsampling.geometry.validation import InputError

@pytest.fixture
def ctc_01():
    return shared_mbd("nist_ctc_01_asme1_ap242.qif")


def test_open_makes_a_document_with_the_part_and_its_characteristics(ctc_01):
    doc = mbd_import.open(ctc_01)
    try:
        part = doc.getObject("nist_ctc_01_asme1_ap242")
        assert part.Shape.ShapeType == "Solid" and part.Shape.isValid() and len(part.Shape.Faces) == 117
        sheet = doc.getObject("Characteristics")
        assert sheet.get("A1").startswith("nist_ctc_01_asme1_ap242.qif: 14 characteristics (4 judged by this tool)")
        assert [sheet.get(f"{column}2") for column in "ABCDEFGHI"] == list(mbd_import.HEADER)
        rows = {sheet.get(f"A{row}"): row for row in range(3, 17)}
        profile = rows["1457"]
        assert (sheet.get(f"C{profile}"), sheet.get(f"D{profile}"), sheet.get(f"F{profile}"), sheet.get(f"H{profile}")) \
            == ("SurfaceProfile", 1.25, "A | B | C", "yes")
        faces = sheet.get(f"G{profile}").split()
        assert len(faces) == 2 and all(part.Shape.getElement(face).Area > 0 for face in faces)
        size = rows["1485"]
        assert sheet.get(f"H{size}") == "no" and "feature's own fit" in sheet.get(f"I{size}")
        assert sheet.get("A18") == "datum" and [sheet.get(f"A{row}") for row in (19, 20, 21)] == ["A", "B", "C"]
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_import_adds_the_model_to_a_document_in_one_undo_step(ctc_01):
    doc = FreeCAD.newDocument("MbdImport")
    try:
        doc.UndoMode = 1
        box = doc.addObject("Part::Box", "Box")
        doc.recompute()
        undo = doc.UndoCount
        part = mbd_import.insert(ctc_01, doc.Name)
        assert part.Document is doc and doc.getObject("Characteristics") is not None
        assert doc.UndoCount == undo + 1
        doc.undo()
        assert [obj.Name for obj in doc.Objects] == [box.Name]
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_a_file_that_is_no_mbd_model_is_refused_before_a_document_is_made(tmp_path):
    path = tmp_path / "points.qif"
    path.write_text("x,y,z\n1,2,3\n", encoding="utf-8")
    documents = set(FreeCAD.listDocuments())
    with pytest.raises(InputError) as refused:
        mbd_import.open(str(path))
    assert str(refused.value).startswith(str(path)) and "\n" not in str(refused.value)
    assert set(FreeCAD.listDocuments()) == documents


def test_a_models_characteristics_judged_become_a_first_article_sheet(ctc_01, tmp_path):
    import cmmsampling

    model = cmmsampling.read_mbd(ctc_01)
    found = cmmsampling.inspect(plan := cmmsampling.plan(model, strategy="hammersley"),
                                cmmsampling.simulate_measurement(plan, tmp_path / "m.csv", form_error=0.05).path)
    doc = FreeCAD.newDocument("FirstArticle")
    try:
        doc.UndoMode = 1
        sheet = cmmsampling.add_inspection_to_document(found, doc)
        assert sheet.TypeId == "Spreadsheet::Sheet" and sheet.Label.startswith("First article nist_ctc_01")
        assert sheet.get("A1").startswith("nist_ctc_01_asme1_ap242.qif: 4 of 14 characteristics judged")
        assert sheet.get("A2") == "Characteristic" and sheet.get("K2") == "Conforms"
        rows = {sheet.get(f"A{row}"): row for row in range(3, 3 + len(model.characteristics))}
        assert set(rows) == {c.id for c in model.characteristics}
        for result in found.characteristics:
            row = rows[result.id]
            assert sheet.get(f"H{row}") == pytest.approx(result.value, abs=5e-5)
            assert sheet.get(f"K{row}") == ("yes" if result.passed else "no")
        assert sheet.get(f"K{rows['1485']}") == "not judged" and "own fit" in sheet.get(f"J{rows['1485']}")
        doc.undo()
        assert doc.getObject("FirstArticle") is None
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_a_models_plan_in_the_document_states_the_model_and_is_judged_as_the_plan_is(ctc_01, tmp_path):
    import cmmsampling

    doc = mbd_import.open(ctc_01)
    try:
        part = doc.getObject("nist_ctc_01_asme1_ap242")
        plan = cmmsampling.plan(cmmsampling.read_mbd(part.MbdFile, shape=part.Shape), strategy="hammersley",
                                n_max=25)
        group = cmmsampling.add_plan_to_document(plan, doc, part)
        assert group.MbdFile == ctc_01 and [line.split()[0] for line in group.Characteristics] == \
            [c.id for c in plan.characteristics]
        assert group.FrameDatums == ["A Face36", "B Face43 Face44", "C Face57 Face58"]
        cmmsampling.export(group, tmp_path / "group.dmi")
        cmmsampling.export(plan, tmp_path / "plan.dmi")
        programs = [(tmp_path / name).read_text().splitlines() for name in ("group.dmi", "plan.dmi")]
        assert [line for line in programs[0] if "DAT" in line] == [line for line in programs[1] if "DAT" in line]
        assert "D(DRF)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XORIG,YORIG" in programs[0], "the same frame from the group"
        measured = cmmsampling.simulate_measurement(group, tmp_path / "m.csv", form_error=0.05, seed=3).path
        in_document = cmmsampling.inspect(group, measured)
        in_hand = cmmsampling.inspect(plan, measured)
        assert [(r.id, r.passed) for r in in_document.characteristics] == \
            [(r.id, r.passed) for r in in_hand.characteristics]
        for there, here in zip(in_document.characteristics, in_hand.characteristics):
            assert there.value == pytest.approx(here.value, abs=1e-9) and there.points == here.points
    finally:
        FreeCAD.closeDocument(doc.Name)
