"""QIF 3.0 MBD models opened with ``cmmsampling.read_mbd`` on NIST's four PMI test models
(../shared/reference/qif3/mbd, skipped where absent): the B-rep the file describes is built
into a valid solid in mm, every face of the file's body a face of it; where NIST's STEP file of
the same model is shared, the built solid has its face count, area and volume to 1e-6, and
the STEP's faces are matched to the file's (distances stated, faces with no counterpart named);
the characteristics and datums name the shape's faces."""
import os
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from support.mbd import MODELS, shared_mbd

import cmmsampling
import Part  # after cmmsampling, which makes FreeCAD importable
from cmmsampling.formats.qif.model import MATCH_MM
from cmmsampling.formats.qif.xml import QIF_NS
from cmmsampling.geometry.validation import InputError

NS = {"q": QIF_NS}


@pytest.fixture(scope="module", params=MODELS)
def opened(request):
    """(the file's parsed root, its model as read_mbd builds it) for each shared model."""
    path = shared_mbd(request.param + ".qif")
    return ET.parse(path).getroot(), cmmsampling.read_mbd(path)


def test_the_file_s_b_rep_is_built_into_a_valid_solid_face_by_face(opened):
    root, model = opened
    body_faces = root.find(".//q:Body", NS).findall("q:FaceIds/q:Id", NS)
    assert model.shape.ShapeType == "Solid" and model.shape.isValid() and model.failed == []
    assert len(model.shape.Faces) == len(body_faces) == len(model.matches)
    assert sorted(m.face_id for m in model.matches) == sorted(i.text.strip() for i in body_faces)
    assert model.shape.Volume > 0


def test_every_point_of_the_file_lies_on_the_solid_in_mm(opened):
    """The vertices of the file's part (its first body; the others hold sketches), times its
    unit's mm (25.4 for ftc_09's inches), are the solid's."""
    root, model = opened
    unit = root.find("q:FileUnits/q:PrimaryUnits/q:LinearUnit/q:UnitName", NS).text
    scale = {"mm": 1.0, "inch": 25.4}[unit]
    body = root.find(".//q:Body", NS)
    in_body = {i.text.strip() for i in body.findall("q:VertexIds/q:Id", NS)}
    vertex_points = {v.find("q:Point/q:Id", NS).text.strip() for v in root.iter(f"{{{QIF_NS}}}Vertex")
                     if v.get("id") in in_body}
    points = [p for p in root.iter(f"{{{QIF_NS}}}Point") if p.get("id") in vertex_points]
    xyz = scale * np.array([[float(x) for x in p.find("q:XYZ", NS).text.split()] for p in points])
    vertices = np.array([tuple(v.Point) for v in model.shape.Vertexes])
    gaps = np.linalg.norm(xyz[:, None] - vertices[None], axis=-1).min(axis=1)
    print(f"{os.path.basename(model.path)} ({unit}): {len(xyz)} vertices, at most {gaps.max():.2g} mm from the "
          f"solid's; {model.summary()}")
    assert gaps.max() < 1e-4


def test_the_characteristics_name_the_faces_their_features_lie_on(opened):
    root, model = opened
    by_id = {m.face_id: m.faces[0] for m in model.matches}
    for characteristic in model.characteristics:
        assert characteristic.faces == tuple(dict.fromkeys(by_id[i] for i in characteristic.face_ids))
    for datum in model.datums.values():
        assert datum.faces == tuple(by_id[i] for i in datum.face_ids)
    judged = model.judged()
    assert judged and all(c.faces for c in judged)


def test_ctc_01_built_from_its_qif_is_nist_s_step_to_1e_6():
    step = Part.read(shared_mbd("nist_ctc_01_asme1_ap242.stp"))
    model = cmmsampling.read_mbd(shared_mbd("nist_ctc_01_asme1_ap242.qif"))
    built = model.shape
    assert len(built.Faces) == len(step.Faces) == 117
    assert built.Area == pytest.approx(step.Area, rel=1e-6) and built.Volume == pytest.approx(step.Volume, rel=1e-6)
    print(f"ctc_01: area {built.Area:.6f} / {step.Area:.6f} mm^2, volume {built.Volume:.3f} / {step.Volume:.3f} mm^3")


def test_ctc_01_s_faces_are_matched_to_its_step_one_to_one():
    step = Part.read(shared_mbd("nist_ctc_01_asme1_ap242.stp"))
    model = cmmsampling.read_mbd(shared_mbd("nist_ctc_01_asme1_ap242.qif"), shape=step)
    assert model.shape is step and not model.built_from_file and model.unmatched == []
    assert all(len(m.faces) == 1 for m in model.matches) and len({m.faces for m in model.matches}) == 117
    assert max(m.distance for m in model.matches) < 1e-6
    report = model.match_report()
    print(report)
    assert "117 QIF faces, 117 on faces of the given shape (117 faces)" in report
    flatness = next(c for c in model.characteristics if c.kind == "Flatness")
    [face] = flatness.faces
    assert step.Faces[int(face[4:]) - 1].Surface.isPlanar()


def test_ftc_06_s_other_revision_names_the_faces_with_no_counterpart():
    step = Part.read(shared_mbd("nist_ftc_06_asme1_rd.stp"))
    model = cmmsampling.read_mbd(shared_mbd("nist_ftc_06_asme1_ap242.qif"), shape=step)
    report = model.match_report()
    print(report)
    assert len(model.matches) == 187 and len(step.Faces) == 144
    assert all(m.distance <= MATCH_MM for m in model.matches if m.faces)
    assert all(m.distance > MATCH_MM for m in model.matches if not m.faces)
    assert 0 < len(model.unmatched) <= 4, "a face on a torus built as its loop's other side matches no STEP face"
    named = re.findall(r"QIF face (\w+): no counterpart", report)
    assert named == model.unmatched
    matched = [m for m in model.matches if m.faces]
    assert len({face for m in matched for face in m.faces}) < len(matched), "several QIF faces lie on one STEP face"


def test_a_shape_that_is_no_shape_is_refused_before_any_work():
    with pytest.raises(InputError, match="give the model as a Part.Shape"):
        cmmsampling.read_mbd(shared_mbd("nist_ctc_01_asme1_ap242.qif"), shape="part.stp")
