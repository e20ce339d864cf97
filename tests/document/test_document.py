"""The document layer headless: objects, one transaction, save/reopen, re-evaluate, orphans."""
import json
import zipfile

import numpy as np
import pytest
from support.faces import FreeCAD, Part, closed, reference_document

import cmmsampling
from cmmsampling import document
from cmmsampling.document.object_types import is_probe_points
from cmmsampling.formats.pointset import PointSet
from cmmsampling.geometry.surface import make_bspline_surface, reference_poles

RUN = {"n": 25, "strategy": "pso", "population": 8, "iterations": 20, "seed": 1}


@pytest.fixture(scope="module")
def result():
    """A short PSO run on the reference face."""
    return cmmsampling.sample(cmmsampling.reference_face(), **RUN)


@pytest.fixture
def doc():
    """A fresh document with undo on and the reference face as Part::Feature 'Body'."""
    d = reference_document("SamplingTest", 1)
    name = d.Name
    yield d
    closed(name)


@pytest.fixture
def group(doc, result):
    return document.add_to_document(result, doc, source=(doc.Body, "Face1"))


def changed_face():
    """The reference face with its heights scaled by 1.3 (same parameter range)."""
    poles = reference_poles()
    poles[..., 2] *= 1.3
    return make_bspline_surface(poles, (5, 5)).toShape()


def vectors(values):
    return np.array([tuple(v) for v in values], dtype=float)


def test_add_to_document_makes_a_group_of_three_in_one_transaction(doc, result):
    before = doc.UndoCount
    group = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    assert group.TypeId == "App::DocumentObjectGroup" and group.Label == "Sampling Body Face1 (pso)"
    points, surface, report = group.Group
    assert (points.TypeId, surface.TypeId, report.TypeId) == (
        "Part::FeaturePython", "Part::FeaturePython", "Spreadsheet::Sheet")
    assert doc.UndoCount == before + 1 and not doc.HasPendingTransaction
    assert doc.Body.Visibility
    doc.undo()
    assert [o.Name for o in doc.Objects] == ["Body"] and doc.Body.Visibility
    doc.redo()
    assert len(doc.Objects) == 5


def test_probe_points_hold_the_result(group, result, doc):
    points = group.Group[0]
    assert is_probe_points(points)
    assert list(points.Labels) == [f"P{i}" for i in range(1, 26)]
    assert np.allclose(vectors(points.Points), result.points, atol=1e-12)
    assert np.allclose(vectors(points.Normals), result.normals, atol=1e-12)
    assert np.allclose(np.column_stack([points.U, points.V]), result.uv, atol=0)
    expected = PointSet.from_result(result)
    assert np.allclose(points.Deviation, expected.deviation, atol=1e-12)
    assert points.Source == (doc.Body, ["Face1"]) and points.SourceName == "Body:Face1"
    assert json.loads(points.Parameters) == result.settings
    assert points.Strategy == "pso" and not points.Cancelled
    assert points.MaxDeviation.Value == pytest.approx(result.deviation.maximum, rel=1e-12)
    assert points.OccMaxDeviation.Value == pytest.approx(result.deviation.occ_maximum, rel=1e-12)
    assert points.Status == "up to date" and not points.Orphaned and not points.Outdated
    vertexes = points.Shape.Vertexes
    assert len(vertexes) == 25
    assert np.allclose([tuple(v.Point) for v in vertexes], result.points, atol=1e-9)


def test_point_set_of_the_object(group, result):
    points = group.Group[0]
    ps = points.Proxy.point_set(points)
    expected = PointSet.from_result(result, "Body:Face1")
    assert ps.labels == expected.labels
    for name in ("points", "normals", "uv", "deviation"):
        assert np.allclose(getattr(ps, name), getattr(expected, name), atol=1e-12)
    assert ps.metadata["source"] == "Body:Face1" and ps.metadata["population"] == 8
    assert ps.metadata["max_mm"] == pytest.approx(result.deviation.maximum, rel=1e-12)


def test_substitute_surface_is_the_fit_with_its_deviation_field(group, result):
    surface = group.Group[1]
    fitted = surface.Shape.Faces[0].Surface
    assert isinstance(fitted, Part.BSplineSurface)
    assert np.allclose(vectors(p for row in fitted.getPoles() for p in row),
                       vectors(p for row in result.substitute.getPoles() for p in row), atol=1e-12)
    u, v, field = surface.Proxy.deviation_grid(surface)
    assert field.shape == (60, 60) and np.allclose(field, result.deviation.field, atol=0)
    grid_uv = result.deviation.grid_uv
    assert np.allclose(u, grid_uv[:, 0, 0]) and np.allclose(v, grid_uv[0, :, 1])
    assert surface.MaxDeviation.Value == pytest.approx(result.deviation.maximum)
    assert np.nanmax(field) <= result.deviation.maximum, "the edge nodes count too"


def test_report_has_summary_and_point_table(group, result):
    report = group.Group[2]
    assert report.get("strategy") == "pso" and report.get("n") == 25
    assert report.get("max_mm") == pytest.approx(result.deviation.maximum, rel=1e-9)
    assert report.get("occ_max_mm") == pytest.approx(result.deviation.occ_maximum, rel=1e-9)
    assert report.get("normal_angle_deg") == pytest.approx(result.deviation.normal_angle, rel=1e-9)
    assert 0 < result.deviation.normal_angle < 90
    header = next((row for row in range(1, 60) if cell(report, f"A{row}") == "Label"), None)
    assert header is not None and cell(report, f"J{header}") == "Deviation"
    first = [report.get(f"{c}{header + 1}") for c in "ABCDEFGHIJ"]
    assert first[0] == "P1"
    assert np.allclose([float(x) for x in first[1:4]], result.points[0], atol=5e-5)
    assert np.allclose([float(x) for x in first[7:9]], result.uv[0], rtol=1e-5)
    deviation = cmmsampling.PointSet.from_result(result).deviation[0]
    assert isinstance(first[9], float) and first[9] == pytest.approx(deviation, rel=1e-9, abs=1e-15), \
        "a number in mm, not text"
    assert report.getDisplayUnit(f"J{header + 1}") == "µm" and report.getDisplayUnit(f"J{header + 25}") == "µm"
    names = [cell(report, f"A{row}") for row in range(1, header)]
    named = [name for name in names if name and name != "Note"]
    assert len(set(named)) == len(named), "no name twice"
    assert {"Processes asked", "Processes the swarm used"} <= set(named)
    rows = {cell(report, f"A{row}"): row for row in range(1, header)}
    maximum = rows["Max deviation"]   # a number in mm, shown in micrometres (two decimals: 10 nm)
    assert report.get(f"B{maximum}") == pytest.approx(result.deviation.maximum, rel=1e-9)
    assert report.getDisplayUnit(f"B{maximum}") == "µm" and cell(report, f"C{maximum}") == ""
    report.set("K1", "=max_mm * 1000")
    report.recompute()
    assert report.get("K1") == pytest.approx(1000 * result.deviation.maximum, rel=1e-9)
    report.clear("K1")
    assert report.getColumnWidth("A") >= 7 * len("OCC max deviation")
    assert cell(report, f"B{rows['Edge offset (mm)']}") == 0 and "fit_degree" not in rows
    assert cell(report, f"A{header + 25}") == "P25" and cell(report, f"A{header + 26}") == ""


def cell(sheet, address):
    """A cell's value, "" when it is empty. (getContents gives the content as stored: FreeCAD 1.x
    stores text with a leading apostrophe, 0.20 without.)"""
    return sheet.get(address) if sheet.getContents(address) else ""


def test_save_and_reopen_keeps_everything(group, result, doc, tmp_path):
    path = str(tmp_path / "sampling.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    reopened = FreeCAD.openDocument(path)
    try:
        group = reopened.getObjectsByLabel("Sampling Body Face1 (pso)")[0]
        points, surface, report = group.Group
        assert isinstance(points.Proxy, document.ProbePoints)
        assert isinstance(surface.Proxy, document.SubstituteSurface)
        assert points.Substitute == surface and points.Report == report
        ps = points.Proxy.point_set(points)
        assert np.allclose(ps.uv, result.uv, atol=0) and ps.labels[-1] == "P25"
        assert surface.Proxy.deviation_grid(surface)[2].shape == (60, 60)
        assert report.get("max_mm") == pytest.approx(result.deviation.maximum, rel=1e-9)
        points.touch()
        reopened.recompute()
        assert points.Status == "up to date" and "Invalid" not in points.State
    finally:
        FreeCAD.closeDocument(reopened.Name)


def test_a_document_saved_before_the_document_room_had_modules_opens(group, result, doc, tmp_path):
    """Files saved by the earlier layout name the proxies' module cmmsampling.document."""
    new_path, old_path = str(tmp_path / "new.FCStd"), str(tmp_path / "old.FCStd")
    doc.saveAs(new_path)
    with zipfile.ZipFile(new_path) as new, zipfile.ZipFile(old_path, "w", zipfile.ZIP_DEFLATED) as old:
        for item in new.infolist():
            data = new.read(item.filename)
            if item.filename == "Document.xml":
                assert b'module="cmmsampling.document.objects"' in data
                data = data.replace(b'module="cmmsampling.document.objects"', b'module="cmmsampling.document"')
            old.writestr(item, data)
    FreeCAD.closeDocument(doc.Name)
    reopened = FreeCAD.openDocument(old_path)
    try:
        points, surface, _ = reopened.getObjectsByLabel("Sampling Body Face1 (pso)")[0].Group
        assert isinstance(points.Proxy, document.ProbePoints) and isinstance(surface.Proxy, document.SubstituteSurface)
        assert np.allclose(points.Proxy.point_set(points).uv, result.uv, atol=0)
        assert document.reevaluate(points).deviation.maximum == pytest.approx(result.deviation.maximum, rel=1e-9)
    finally:
        FreeCAD.closeDocument(reopened.Name)


def test_changed_face_is_flagged_and_reevaluated_with_the_same_uv(group, result, doc):
    points, surface, report = group.Group
    old_max = points.MaxDeviation.Value
    doc.Body.Shape = changed_face()
    doc.recompute()
    assert points.Outdated and points.Status.startswith("outdated")
    again = document.reevaluate(points)
    assert np.allclose(np.column_stack([points.U, points.V]), result.uv, atol=0)
    expected = cmmsampling.evaluate(changed_face(), result.uv, fit_degree=3, fit_poles=(4, 4))
    assert points.MaxDeviation.Value == pytest.approx(expected.deviation.maximum, rel=1e-9)
    assert abs(points.MaxDeviation.Value - old_max) > 0.1
    assert np.allclose(vectors(points.Points), expected.points, atol=1e-9)
    assert not points.Outdated and points.Status == "up to date"
    assert points.Strategy == "pso" and json.loads(points.Parameters) == result.settings
    assert surface.MaxDeviation.Value == pytest.approx(again.deviation.maximum)
    assert report.get("max_mm") == pytest.approx(again.deviation.maximum, rel=1e-9)
    doc.undo()
    assert points.MaxDeviation.Value == pytest.approx(old_max)


def test_deleted_source_orphans_the_points_without_errors(group, doc):
    points = group.Group[0]
    doc.removeObject("Body")
    doc.recompute()
    assert points.Orphaned and points.Status == "orphaned: its source face Body:Face1 was deleted"
    assert "Invalid" not in points.State and len(points.Shape.Vertexes) == 25
    with pytest.raises(ValueError, match="Body:Face1 was deleted"):
        document.reevaluate(points)
    assert points.Proxy.point_set(points).metadata["source"] == "Body:Face1"


def test_vanished_face_name_orphans_the_points(doc):
    box = doc.addObject("Part::Feature", "Box")
    box.Shape = Part.makeBox(40, 30, 20)
    doc.recompute()
    run = cmmsampling.sample(box.Shape.Faces[2], 9, "uniform_parametric", occ_check=False)
    points = document.add_to_document(run, doc, source=(box, "Face3")).Group[0]
    box.Shape = Part.makeBox(40, 30, 20).Faces[0]
    doc.recompute()
    assert points.Orphaned and "Box has no Face3" in points.Status


def test_source_is_hidden_when_asked(doc, result):
    document.add_to_document(result, doc, source=(doc.Body, "Face1"), hide_source=True)
    assert not doc.Body.Visibility
    doc.undo()
    assert doc.Body.Visibility


def test_one_result_is_shown_at_a_time_and_undo_shows_the_earlier_again(doc, result):
    first = document.add_to_document(result, doc, source=(doc.Body, "Face1")).Group
    second = document.add_to_document(result, doc, source=(doc.Body, "Face1")).Group
    assert [o.Visibility for o in first[:2]] == [False, False]
    assert [o.Visibility for o in second[:2]] == [True, True] and doc.Body.Visibility
    doc.undo()
    assert [o.Visibility for o in first[:2]] == [True, True]


def test_result_without_source(doc, result):
    group = document.add_to_document(result, doc)
    points = group.Group[0]
    assert group.Label == "Sampling pso" and points.Source is None
    assert not points.Orphaned and points.Status == "it was made without a source face"
    with pytest.raises(ValueError, match="without a source face"):
        document.reevaluate(points)


@pytest.mark.parametrize("source, error, message", [
    (lambda d: ("Body", "Face1"), ValueError, "is not in document"),
    (lambda d: "Body.Face1", TypeError, "source must be"),
    (lambda d: (d.Body, "Edge1"), ValueError, "Body.Edge1 is not a face"),
])
def test_bad_source_is_refused(doc, result, source, error, message):
    with pytest.raises(error, match=message):
        document.add_to_document(result, doc, source=source(doc))
    assert [o.Name for o in doc.Objects] == ["Body"] and not doc.HasPendingTransaction


def test_file_export_hook_writes_the_points_of_a_group(group, tmp_path):
    path = str(tmp_path / "points.csv")
    document.export([group], path)
    with open(path) as f:
        rows = [line for line in f if not line.startswith("#")]
    assert rows[0].startswith("label,x,y,z,i,j,k") and len(rows) == 26
    with pytest.raises(ValueError, match="exactly one set of probe points"):
        document.export([group.Group[1]], path)


def test_a_substitute_saved_before_max_location_gets_it_at_its_largest_raster_deviation(group, result):
    surface = group.Group[1]
    assert surface.MaxLocation.distanceToPoint(FreeCAD.Vector(*result.deviation.max_location())) < 1e-9
    surface.removeProperty("MaxLocation")   # as a document saved by an earlier version
    surface.Proxy.onDocumentRestored(surface)
    u, v, field = surface.Proxy.deviation_grid(surface)
    i, j = np.unravel_index(int(np.nanargmax(field)), field.shape)
    node = result.deviation.nodes[i, j]
    assert surface.MaxLocation.distanceToPoint(FreeCAD.Vector(*node)) <= 2 * result.deviation.maximum   # near it
    assert surface.MaxLocation.Length > 0   # not the origin an added property starts at
