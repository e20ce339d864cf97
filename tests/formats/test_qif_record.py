"""The results QIF is the whole record of a verdict: with datums it holds every measured point
(the datum faces' too) and the datum reference frame, still valid by the official QIF 3.0
schemas, and the record read back (cmmsampling.read_record) judges the part again with the same
datums, profile, U and decision; without datums it records and judges again as well."""
import json
import os
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest
from support.paths import ROOT

import cmmsampling
from cmmsampling.formats.qif.schema import schema_errors
from cmmsampling.formats.qif.xml import QIF_NS
from cmmsampling.geometry.validation import InputError
from cmmsampling.inspection.align import transform
from cmmsampling.inspection.datums import Datum

NS = {"q": QIF_NS}
MISPLACED = cmmsampling.Misplacement(rx=1.0, ry=-0.5, rz=2.0, x=5.0, y=-3.0, z=1.0)
# The frame: the base A, the side B (least squares), the end C; Face3 (the wavy top) and Face6
# (the back side) are toleranced.
FRAME = (Datum("A", "Face1"), Datum("B", "Face5", criterion="least_squares"), Datum("C", "Face4"))
ASKED = dict(tolerance=0.05, zone_offset=0.004, alignment="best_fit", uncertainty=0.002, seed=7)
SETS = "q:Results/q:MeasurementResultsSet/q:MeasurementResults/q:MeasuredPointSets/q:MeasuredPointSet"


@pytest.fixture(scope="module")
def block():
    """(shape, plan): the datum block planned on its top, its back and the three datum faces, 16
    points each."""
    shape = cmmsampling.datum_block()
    return shape, cmmsampling.plan(shape, n_total=80, strategy="uniform_parametric", faces=[3, 6, 1, 5, 4],
                                   processes=1)


@pytest.fixture(scope="module")
def framed(block):
    """(measured PointSet, Inspection): the misplaced part as a CMM reads it, the top 0.024 mm
    high, 2 um of noise along the normals, its points in a shuffled order (the toleranced faces'
    and the datums' interleaved), judged relative to FRAME with ASKED."""
    shape, plan = block
    planned = plan.point_set()
    rng = np.random.default_rng(11)
    out = np.where(np.array(planned.faces) == "Face3", 0.024, 0.0) + rng.normal(0.0, 0.002, len(planned))
    matrix = MISPLACED.matrix(planned.points.mean(axis=0))
    order = rng.permutation(len(planned))
    measured = cmmsampling.PointSet([planned.labels[row] for row in order],
                                    transform(matrix, planned.points + out[:, None] * planned.normals)[order],
                                    planned.normals[order] @ matrix[:3, :3].T)
    return measured, cmmsampling.inspect(plan, measured, part=shape, datums=FRAME, **ASKED)


def valid(path):
    """The document at path, asserted to pass the QIF 3.0 schemas; returns its root."""
    text = open(path, encoding="utf-8").read()
    assert schema_errors(text) == []
    return ET.fromstring(text.encode())


def as_read(root):
    """{feature name: (labels, points (M, 3))} of the point sets as read (those with a TranformId)."""
    names = {nominal.get("id"): nominal.findtext("q:Name", namespaces=NS)
             for nominal in root.iterfind("q:Features/q:FeatureNominals/*", NS)}
    items = {item.get("id"): item for item in root.iterfind("q:Features/q:FeatureItems/*", NS)}
    point_ids = {point.get("id"): item for item in items.values()
                 for point in root.iterfind(f".//q:NominalPointSet[@id='{item.find('.//q:WholePointSetId', NS).text}']"
                                            "/q:MeasurePoint", NS)}
    found = {}
    for element in root.iterfind(SETS, NS):
        if element.find("q:TranformId", NS) is None:
            continue
        ids = element.findtext("q:MeasurePointNominalIds/q:Ids", namespaces=NS).split()
        item = point_ids[ids[0]]
        labels = json.loads(item.find("q:Attributes/q:AttributeStr[@name='pointLabels']", NS).get("value"))
        points = np.array(element.findtext("q:Points", namespaces=NS).split(), float).reshape(-1, 3)
        assert int(element.get("count")) == len(points) == len(ids) == len(labels)
        found[names[item.findtext("q:FeatureNominalId", namespaces=NS)]] = (labels, points)
    return found


def test_the_results_with_datums_hold_every_point_and_the_frame(framed, tmp_path):
    measured, inspection = framed
    cmmsampling.export(inspection, tmp_path / "results.qif")
    root = valid(tmp_path / "results.qif")
    features = as_read(root)
    assert sum(len(labels) for labels, _ in features.values()) == len(measured) == 80
    assert len(root.findall(SETS, NS)) == 2 * len(features) == 10
    where = {label: row for row, label in enumerate(measured.labels)}
    for name, (labels, points) in features.items():
        assert np.array_equal(points, measured.points[[where[label] for label in labels]]), name
    frame = root.find("q:DatumReferenceFrames/q:DatumReferenceFrame", NS)
    definitions = {d.get("id"): d for d in root.iterfind("q:DatumDefinitions/q:DatumDefinition", NS)}
    nominals = {n.get("id"): n.findtext("q:Name", namespaces=NS) for n in root.iterfind(".//q:FeatureNominals/*", NS)}
    listed = frame.findall("q:Datums/q:Datum", NS)
    defined = [definitions[d.findtext("q:SimpleDatum/q:DatumDefinitionId", namespaces=NS)] for d in listed]
    assert [d.findtext("q:DatumLabel", namespaces=NS) for d in defined] == ["A", "B", "C"]
    assert [nominals[d.findtext("q:FeatureNominalIds/q:Id", namespaces=NS)] for d in defined] == ["Face1", "Face5",
                                                                                                 "Face4"]
    assert [d.findtext("q:Precedence/q:PrecedenceEnum", namespaces=NS) for d in listed] == ["PRIMARY", "SECONDARY",
                                                                                           "TERTIARY"]
    assert [d.findtext(".//q:SubstituteFeatureAlgorithmEnum", namespaces=NS) for d in listed] == [
        "ONESIDED", "LEASTSQUARES", "ONESIDED"]
    for fit in inspection.datums:
        labels, points = features[fit.face]
        assert labels == fit.measurement.labels and np.array_equal(points, fit.measurement.measured)
    definition = root.find(".//q:SurfaceProfileCharacteristicDefinition", NS)
    assert definition.findtext("q:DatumReferenceFrameId", namespaces=NS) == frame.get("id")
    assert float(definition.findtext("q:UnequallyDisposedZone", namespaces=NS)) == ASKED["zone_offset"]
    assert len(root.findall(".//q:SurfaceProfileCharacteristicMeasurement", NS)) == 2, "the datums have none"
    back = cmmsampling.read_points(tmp_path / "results.qif")
    assert sorted(back.labels) == sorted(measured.labels)


def test_the_record_judges_the_part_again_as_it_was(block, framed, tmp_path):
    shape, plan = block
    _, inspection = framed
    assert inspection.decision is not None and len(inspection.datums) == 3
    cmmsampling.export(inspection, tmp_path / "results.qif")
    record = cmmsampling.read_record(tmp_path / "results.qif")
    assert record.options == {**ASKED, "locked": (), "datums": FRAME}
    assert record.profile == inspection.profile and record.expanded_uncertainty == inspection.profile_uncertainty
    assert record.decision == inspection.decision and np.array_equal(record.transform, inspection.transform)
    again = record.inspect(plan, part=shape)
    assert again.profile == pytest.approx(inspection.profile, abs=1e-9)
    assert again.profile_uncertainty == pytest.approx(inspection.profile_uncertainty, abs=1e-9)
    assert again.decision == inspection.decision and again.passed is inspection.passed
    assert [fit.text() for fit in again.datums] == [fit.text() for fit in inspection.datums]
    for fit, first in zip(again.datums, inspection.datums):
        assert np.abs(fit.deviations - first.deviations).max() < 1e-9
    assert again.labels == inspection.labels and np.abs(again.deviations - inspection.deviations).max() < 1e-9
    assert np.abs(again.transform - inspection.transform).max() < 1e-9
    looser = record.inspect(plan, part=shape, tolerance=0.2, uncertainty=None)
    assert looser.passed and looser.profile == pytest.approx(inspection.profile, abs=1e-9)
    with pytest.raises(InputError, match="got probe_radius"):
        record.inspect(plan, part=shape, probe_radius=1.0)


def test_a_datum_that_brought_its_own_points_is_recorded_with_them(block, framed, tmp_path):
    shape, plan = block
    measured, _ = framed
    faces = np.array(plan.point_set().faces)[[plan.point_set().labels.index(label) for label in measured.labels]]
    toleranced = np.isin(faces, ["Face3", "Face6"])
    top = replace(measured, labels=[label for label, kept in zip(measured.labels, toleranced) if kept],
                  points=measured.points[toleranced], normals=measured.normals[toleranced])
    own = [replace(datum, points=measured.points[faces == datum.face]) for datum in FRAME]
    inspection = cmmsampling.inspect(plan, top, part=shape, datums=own, tolerance=0.05)
    cmmsampling.export(inspection, tmp_path / "own.qif")
    features = as_read(valid(tmp_path / "own.qif"))
    assert sum(len(labels) for labels, _ in features.values()) == 80
    record = cmmsampling.read_record(tmp_path / "own.qif")
    assert [(d.label, d.face, d.criterion) for d in record.datums] == [(d.label, d.face, d.criterion) for d in FRAME]
    for datum, given in zip(record.datums, own):
        assert np.array_equal(datum.points.points, given.points) and datum.points.labels[0] == f"{datum.label}1"
    assert len(record.measured) == len(inspection.labels)
    again = record.inspect(plan, part=shape)
    assert again.profile == pytest.approx(inspection.profile, abs=1e-9) and again.passed is inspection.passed
    assert [fit.text() for fit in again.datums] == [fit.text() for fit in inspection.datums]


def test_an_inspection_without_datums_is_recorded_and_judged_again(reference, tmp_path):
    result = cmmsampling.sample(reference, 16, "halton", grid=16, occ_check=False)
    planned = cmmsampling.PointSet.from_result(result)
    bumps = 0.004 * np.random.default_rng(3).standard_normal(len(planned))[:, None] * planned.normals
    measured = cmmsampling.PointSet(list(planned.labels), planned.points + bumps + (0.3, -0.2, 0.0), planned.normals)
    inspection = cmmsampling.inspect(result, measured, tolerance=0.02, locked=("rz",), zone_offset=-0.001)
    cmmsampling.export(inspection, tmp_path / "floated.qif")
    root = valid(tmp_path / "floated.qif")
    assert root.find("q:DatumReferenceFrames", NS) is None and root.find("q:DatumDefinitions", NS) is None
    record = cmmsampling.read_record(tmp_path / "floated.qif")
    assert record.options == {"alignment": "min_max", "tolerance": 0.02, "locked": ("rz",), "zone_offset": -0.001,
                              "datums": (), "uncertainty": None, "seed": 0}
    again = record.inspect(result)
    assert again.labels == inspection.labels and again.passed is inspection.passed
    assert again.profile == pytest.approx(inspection.profile, abs=1e-9)


def test_a_qif_file_without_a_record_is_refused_in_one_line(reference, tmp_path):
    result = cmmsampling.sample(reference, 9, "halton", grid=9, occ_check=False)
    cmmsampling.export(result, tmp_path / "plan.qif")
    samples = os.path.join(os.path.dirname(ROOT), "shared", "reference", "qif3", "samples")
    others = [os.path.join(samples, "WIDGET_QIF_RESULTS.QIF")] if os.path.isdir(samples) else []
    for path in [tmp_path / "plan.qif"] + others:
        with pytest.raises(InputError, match="holds no complete inspection record") as caught:
            cmmsampling.read_record(path)
        assert "\n" not in str(caught.value)
