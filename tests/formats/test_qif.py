"""QIF 3.0 plans and results: every document written passes the official QIF 3.0 schemas
(resources/qif3, the same files as ../shared/reference/qif3), carries what the plan or the
inspection holds, and reads back; other programs' QIF files give their measured points, and a
file that is not valid QIF results is refused in one line."""
import dataclasses
import hashlib
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from support.faces import FreeCAD, walled_part
from support.paths import ROOT

import cmmsampling
from cmmsampling.geometry.blocks import datum_block
from cmmsampling import cli
from cmmsampling.access.probe import Probe
from cmmsampling.formats import qif
from cmmsampling.formats.qif.schema import SCHEMA_PATH, schema_errors
from cmmsampling.formats.qif.xml import QIF_NS, decimal
from cmmsampling.geometry.validation import InputError

SHARED_QIF = os.path.join(os.path.dirname(ROOT), "shared", "reference", "qif3")
NS = {"q": QIF_NS}


def shared_sample(name):
    """A QIF sample of ../shared/reference/qif3 (skipped where the shared folder is absent)."""
    path = os.path.join(SHARED_QIF, "samples", name)
    if not os.path.isfile(path):
        pytest.skip(f"{path} is not beside the checkout")
    return path


def valid(path):
    """The document at path, asserted to pass the QIF 3.0 schemas; returns its root."""
    text = open(path, encoding="utf-8").read()
    assert schema_errors(text) == []
    return ET.fromstring(text.encode())


@pytest.fixture(scope="module")
def result(reference):
    return cmmsampling.sample(reference, 16, "halton", grid=16, occ_check=False)


@pytest.fixture(scope="module")
def walled():
    """A base with a wall, its two upward faces planned with a probe (a collision-free path)."""
    part, upward = walled_part()
    plan = cmmsampling.plan(part, tolerance=0.5, strategy="uniform_parametric", faces=upward, probe=Probe(),
                            processes=1, grid=20, n_max=60)
    return part, plan


def measured_like(point_set, shift=(0.3, -0.2, 0.0), noise=0.004, seed=3):
    """The planned points as a CMM would give them: moved rigidly, with noise along the vectors."""
    rng = np.random.default_rng(seed)
    bumps = noise * rng.standard_normal(len(point_set))[:, None] * point_set.normals
    return cmmsampling.PointSet(list(point_set.labels), point_set.points + bumps + shift, point_set.normals)


def test_the_shipped_schemas_are_the_official_ones():
    folder = os.path.dirname(SCHEMA_PATH)
    assert len(os.listdir(folder)) == 21 and os.path.isfile(os.path.join(ROOT, "resources", "qif3", "LICENSE.md"))
    official = os.path.join(SHARED_QIF, "schema")
    if not os.path.isdir(official):
        pytest.skip("../shared/reference/qif3 is not beside the checkout")
    for name in os.listdir(official):
        digest = [hashlib.sha256(open(os.path.join(where, name), "rb").read()).hexdigest()
                  for where in (official, folder)]
        assert digest[0] == digest[1], name


def test_a_faces_plan_passes_the_schemas_and_reads_back(result, tmp_path):
    report = cmmsampling.export(result, tmp_path / "face.qif", probe_radius=1.5, label="plate.step:Face1")
    assert report.format == "qif" and "QIF 3.0" in str(report)
    root = valid(tmp_path / "face.qif")
    assert root.findtext("q:Product/q:PartSet/q:Part/q:Header/q:Name", namespaces=NS) == "plate.step"
    assert root.findtext(".//q:SimpleTactileProbeSensor/q:TipEndDiameter", namespaces=NS) == "3"
    nominal = root.find("q:Features/q:FeatureNominals/q:PointDefinedSurfaceFeatureNominal", NS)
    assert nominal.findtext("q:Name", namespaces=NS) == "Face1"
    defining = nominal.findall("q:DefiningPoints/q:DefiningPoint", NS)
    assert [int(p.findtext("q:SequenceNumber", namespaces=NS)) for p in defining] == list(range(1, 17))
    written = np.array([p.findtext("q:Point", namespaces=NS).split() for p in defining], dtype=float)
    assert np.array_equal(written, result.points), "contact points, exactly"
    method = root.find("q:Plan/q:ActionMethods/q:CoordinateMeasureFeatureMethod", NS)
    facts = {a.get("name"): a.get("value") for a in method.iter(f"{{{QIF_NS}}}AttributeStr")}
    facts.update({a.get("name"): a.get("value") for a in method.iter(f"{{{QIF_NS}}}AttributeD1")})
    assert facts["samplingStrategy"] == "halton" and float(facts["expectedMaxDeviation_mm"]) == result.deviation.maximum
    assert method.findtext("q:NumberOfMeasurementPoints", namespaces=NS) == "16"
    rule = root.find("q:Rules/q:FeatureRules/q:IfThenElseFeatureRules/q:IfThenPointDefinedSurfaceRule", NS)
    assert rule.findtext("q:ThenPoints/q:NumberOfPoints", namespaces=NS) == "16"
    assert rule.findtext("q:ThenPointStrategy/q:UserDefinedStrategy", namespaces=NS) == "halton"
    assert root.find("q:Characteristics", NS) is None, "QIF requires a tolerance value: none without one"
    back = cmmsampling.read_points(tmp_path / "face.qif")
    assert back.labels == result.labels and np.array_equal(back.points, result.points)
    assert np.abs(back.normals - result.normals).max() < 1e-15 and back.metadata["ball_radius_mm"] == 1.5


def test_a_part_plan_with_a_probe_path_passes_the_schemas(walled, tmp_path):
    part, plan = walled
    report = cmmsampling.export(plan, tmp_path / "part.qif", order="probe_path")
    root = valid(tmp_path / "part.qif")
    names = [e.text for e in root.findall(".//q:PointDefinedSurfaceFeatureItem/q:FeatureName", NS)]
    assert sorted(names) == sorted(face.name for face in plan.placed)
    steps = root.findall("q:Plan/q:OrderedPlanRoot/q:Steps/q:NumberedPlanElement", NS)
    assert [int(s.findtext("q:SequenceNumber", namespaces=NS)) for s in steps] == [1, 2, 3]
    assert steps[-1].find("q:EvaluateSpecifiedCharacteristics", NS) is not None
    assert root.findtext(".//q:SurfaceProfileCharacteristicDefinition/q:ToleranceValue", namespaces=NS) == "0.5"
    moves = root.findall(".//{urn:cmmsampling:qif:1}Move")
    assert len(moves) == plan.n_total + 1 and float(root.find(".//{urn:cmmsampling:qif:1}ProbePath").get(
        "travel_mm")) == pytest.approx(report.length_after)
    targets = {e.get("id"): np.array(e.findtext("q:Point", namespaces=NS).split(), float)
               for e in root.iter(f"{{{QIF_NS}}}MeasurePoint")}
    visited = np.array([targets[m.get("to")] for m in moves[:-1]])
    from cmmsampling.access.probe_moves import probe_moves

    order = probe_moves(plan).order
    assert np.array_equal(visited, plan.point_set().points[order])
    back = cmmsampling.read_points(tmp_path / "part.qif")
    assert sorted(back.labels) == sorted(plan.point_set().labels)


def test_an_inspections_results_pass_the_schemas_and_read_back(result, tmp_path):
    planned = cmmsampling.PointSet.from_result(result)
    inspection = cmmsampling.inspect(result, measured_like(planned), tolerance=0.01)
    report = cmmsampling.export(inspection, tmp_path / "results.qif", label="plate.step")
    assert report.passed is inspection.passed and f"{inspection.profile:.4f} mm" in str(report)
    root = valid(tmp_path / "results.qif")
    results = root.find("q:Results/q:MeasurementResultsSet/q:MeasurementResults", NS)
    status = "PASS" if inspection.passed else "FAIL"
    assert results.findtext("q:InspectionStatus/q:InspectionStatusEnum", namespaces=NS) == status
    profile = results.find(".//q:SurfaceProfileCharacteristicMeasurement", NS)
    assert float(profile.findtext("q:Value", namespaces=NS)) == inspection.profile
    transform = root.find("q:Transforms/q:Transform", NS)
    columns = [np.array(transform.findtext(f"q:Rotation/q:{axis}Direction", namespaces=NS).split(), float)
               for axis in "XYZ"]
    assert np.array_equal(np.column_stack(columns), inspection.transform[:3, :3])
    assert np.array_equal(np.array(transform.findtext("q:Origin", namespaces=NS).split(), float),
                          inspection.transform[:3, 3])
    sets = results.findall("q:MeasuredPointSets/q:MeasuredPointSet", NS)
    as_read, aligned = (np.array(s.findtext("q:Points", namespaces=NS).split(), float).reshape(-1, 3) for s in sets)
    assert np.array_equal(as_read, inspection.measured) and np.array_equal(aligned, inspection.points)
    back = cmmsampling.read_points(tmp_path / "results.qif")
    assert back.labels == inspection.labels and np.abs(back.deviation - inspection.deviations).max() < 1e-12
    again = cmmsampling.inspect(result, tmp_path / "results.qif", tolerance=0.01)
    assert again.labels == inspection.labels
    assert np.abs(again.deviations - inspection.deviations).max() < 1e-6 and again.passed is inspection.passed


def test_a_failed_part_and_one_without_a_tolerance_say_so(walled, tmp_path):
    part, plan = walled
    planned = plan.point_set()
    bent = measured_like(planned, noise=0.05)
    failed = cmmsampling.inspect(plan, bent, part=part, tolerance=0.02)
    assert failed.passed is False
    cmmsampling.export(failed, tmp_path / "failed.qif")
    root = valid(tmp_path / "failed.qif")
    assert root.findtext(".//q:InspectionStatus/q:InspectionStatusEnum", namespaces=NS) == "FAIL"
    verdicts = [e.text for e in root.iter(f"{{{QIF_NS}}}CharacteristicStatusEnum")]
    assert verdicts == ["PASS" if failed.face_passed(v) else "FAIL" for v in failed.face_profiles.values()]
    forms = [float(e.text) for e in root.iter(f"{{{QIF_NS}}}Form")]
    assert forms == [failed.face_forms[name] for name in failed.face_profiles]
    untoleranced = cmmsampling.inspect(dataclasses.replace(plan, mode="points", tolerance=None), bent, part=part)
    cmmsampling.export(untoleranced, tmp_path / "free.qif")
    root = valid(tmp_path / "free.qif")
    assert root.findtext(".//q:InspectionStatus/q:InspectionStatusEnum", namespaces=NS) == "NOT_CALCULATED"
    assert root.find("q:Characteristics", NS) is None
    again = cmmsampling.inspect(plan, tmp_path / "free.qif", part=part)
    assert np.abs(again.deviations - untoleranced.deviations).max() < 1e-6


def test_results_of_a_bare_face_name_each_points_foot(reference, result, tmp_path):
    planned = cmmsampling.PointSet.from_result(result)
    inspection = cmmsampling.inspect(reference, measured_like(planned, shift=(0, 0, 0)), alignment="none")
    cmmsampling.export(inspection, tmp_path / "bare.qif")
    root = valid(tmp_path / "bare.qif")
    nominal = np.array([p.findtext("q:Point", namespaces=NS).split() for p in
                        root.iter(f"{{{QIF_NS}}}DefiningPoint") if p.find("q:Normal", NS) is not None], float)
    feet = np.array([reference.Surface.value(*reference.Surface.parameter(FreeCAD.Vector(*p))) for p in nominal])
    assert np.abs(feet - nominal).max() < 1e-6, "the nominal of an unplanned point is its foot on the face"


def test_the_command_line_writes_a_plans_qif(walled, tmp_path, capsys):
    part, _ = walled
    brep = tmp_path / "walled.brep"
    part.exportBrep(str(brep))
    upward = ",".join(str(k) for k, face in enumerate(part.Faces, start=1)
                      if face.normalAt(*face.Surface.parameter(face.CenterOfMass)).z > 0.5)
    assert cli.main(["plan", str(brep), "--faces", upward, "--tolerance", "0.5", "--strategy", "uniform_parametric",
                     "--max-points", "40", "--processes", "1", "--probe", "2", "--out", str(tmp_path / "plan.qif")]) == 0
    assert "QIF 3.0" in capsys.readouterr().out
    root = valid(tmp_path / "plan.qif")
    assert root.findtext("q:Product/q:PartSet/q:Part/q:Header/q:Name", namespaces=NS) == "walled.brep"
    assert len(root.findall(".//q:PointDefinedSurfaceFeatureNominal", NS)) == 2
    assert root.find(".//{urn:cmmsampling:qif:1}ProbePath") is not None


def test_a_document_the_schemas_refuse_is_never_written(result, tmp_path, monkeypatch):
    target = tmp_path / "kept.qif"
    target.write_text("the user's file")
    real = qif.plan.write
    monkeypatch.setattr(qif.plan, "write", lambda *a: real(*a).replace("<SequenceNumber>1<", "<SequenceNumber>0<"))
    with pytest.raises(qif.QIFSchemaError, match="QIF 3.0 schemas"):
        cmmsampling.export(result, target)
    assert target.read_text() == "the user's file"


def test_results_go_to_qif_only_and_as_measured(result, tmp_path):
    inspection = cmmsampling.inspect(result, cmmsampling.PointSet.from_result(result))
    with pytest.raises(InputError, match=r"written as QIF 3.0 \(\.qif\), not DMIS"):
        cmmsampling.export(inspection, tmp_path / "results.dmi")
    with pytest.raises(InputError, match="leave probe_radius at the default"):
        cmmsampling.export(inspection, tmp_path / "results.qif", probe_radius=2.0)
    assert not os.listdir(tmp_path)


def test_other_programs_results_give_their_measured_points():
    points = cmmsampling.read_points(shared_sample("QIF_PTS_SAMPLE.QIF"))
    assert len(points) == 219 * 3 + 18 + 8 + 2 + 6 and points.metadata["probe_radius_mm"] == 2.49978271104
    assert points.points[0].tolist() == [3.54516458565, 0.0037440421, -1.82916012241]
    widget = cmmsampling.read_points(shared_sample("WIDGET_QIF_RESULTS.QIF"))
    assert len(widget) == 6 and "BACK_FACE" in widget.labels and np.isnan(widget.normals).all()


@pytest.mark.parametrize("name, message", [
    ("mitutoyo_results_serialized_pass_fail_sample.QIF", "neither measured nor planned points"),
    ("simplePlan.QIF", "neither measured nor planned points"),
])
def test_a_qif_file_without_measured_points_is_refused_in_one_line(reference, name, message):
    with pytest.raises(InputError, match=message) as caught:
        cmmsampling.inspect(reference, shared_sample(name))
    assert "\n" not in str(caught.value)


def test_a_plan_an_invalid_file_or_other_xml_is_refused_in_one_line(result, tmp_path):
    cmmsampling.export(result, tmp_path / "plan.qif")
    with pytest.raises(InputError, match="a QIF plan") as caught:
        cmmsampling.inspect(result, tmp_path / "plan.qif")
    text = (tmp_path / "plan.qif").read_text()
    (tmp_path / "broken.qif").write_text(text.replace("<SequenceNumber>1<", "<SequenceNumber>0<"))
    with pytest.raises(InputError, match=r"the QIF 3.0 schemas refuse it \(line \d+: .*SequenceNumber") as caught:
        cmmsampling.read_points(tmp_path / "broken.qif")
    (tmp_path / "other.qif").write_text('<?xml version="1.0"?><svg xmlns="http://www.w3.org/2000/svg"/>')
    with pytest.raises(InputError, match="not a QIF 3.0 document"):
        cmmsampling.read_points(tmp_path / "other.qif")
    (tmp_path / "cut.qif").write_text(text[: len(text) // 2])
    with pytest.raises(InputError, match="not well-formed XML") as caught:
        cmmsampling.inspect(result, tmp_path / "cut.qif")
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("value", [2.1316282072803006e-14, -1e-30, 0.1, 123456.78901234567, 1e20, -0.0, 3.0,
                                   0.00012345678901234567])
def test_decimals_are_positional_and_exact_to_1e_24_mm(value):
    text = decimal(value)
    assert "e" not in text.lower() and abs(float(text) - value) <= 1e-24
    assert len(text.lstrip("-").replace(".", "").lstrip("0")) <= 24


def test_a_datum_referenced_verdict_with_its_uncertainty_passes_the_schemas(tmp_path):
    block = datum_block()
    plan = cmmsampling.plan(block, n_total=80, strategy="uniform_parametric", faces=[3, 1, 5, 4], processes=1)
    planned = plan.point_set()
    out = np.array([0.024 if face == "Face3" else 0.0 for face in planned.faces])
    read = cmmsampling.PointSet(list(planned.labels), planned.points + out[:, None] * planned.normals, planned.normals)
    inspection = cmmsampling.inspect(plan, read, part=block, tolerance=0.05, datums=["Face1", "Face5", "Face4"],
                                     uncertainty=0.002)
    assert inspection.decision == "undecided"
    cmmsampling.export(inspection, tmp_path / "datums.qif")
    root = valid(tmp_path / "datums.qif")
    assert root.findtext(".//q:InspectionStatus/q:InspectionStatusEnum", namespaces=NS) == "UNKNOWN"
    assert [e.text for e in root.iter(f"{{{QIF_NS}}}CharacteristicStatusEnum")] == ["INDETERMINATE"]
    value = root.find(".//q:SurfaceProfileCharacteristicMeasurement/q:Value", NS)
    assert float(value.text) == inspection.profile
    assert float(value.get("combinedUncertainty")) == inspection.profile_uncertainty / 2
    facts = {e.get("name"): e.get("value") for e in root.find("q:Attributes", NS)}
    assert float(facts["expandedUncertainty_mm"]) == inspection.profile_uncertainty
    assert facts["profileIs"].startswith("relative to datums A|B|C: location and form")
    assert facts["decision"].startswith("ISO 14253-1: undecided") and facts["datumA"].startswith("A (Face1, tangent")
