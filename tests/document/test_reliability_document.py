"""The document never loses work and never keeps half-made objects (issue 10), headless.

A fault in any step of adding or re-evaluating a result rolls everything back, with undo on or
off; undo and redo restore every property; copies of a result group stay consistent; orphaned
points survive saving and reopening.
"""
import numpy as np
import pytest
from support.faces import FreeCAD, Part, closed, reference_document

import cmmsampling
from cmmsampling import document
from cmmsampling.geometry.surface import make_bspline_surface, reference_poles

RUN = {"n": 16, "strategy": "pso", "population": 6, "iterations": 10, "seed": 4}


class SimulatedFault(Exception):
    """Raised by the steps the tests break on purpose."""


@pytest.fixture(scope="module")
def result():
    """A short PSO run on the reference face."""
    return cmmsampling.sample(cmmsampling.reference_face(), **RUN)


@pytest.fixture(params=[1, 0], ids=["undo on", "undo off"])
def doc(request):
    """A fresh document (undo on, or off as in headless documents) with the reference face 'Body'."""
    d = reference_document("Reliability", request.param)
    name = d.Name
    yield d
    closed(name)


def names(doc):
    return [o.Name for o in doc.Objects]


def state(doc):
    """What must not change when a step is rolled back: objects, undo stack, open transactions."""
    return (names(doc), doc.UndoCount, doc.UndoMode, doc.HasPendingTransaction,
            FreeCAD.getActiveTransaction(), doc.Body.Visibility)


def fail(*args, **kwargs):
    raise SimulatedFault("simulated fault")


def failing_execute(self, obj):
    raise SimulatedFault("simulated fault in execute")


def plain(value):
    """A property value as plain, comparable Python data (objects by name, shapes by geometry)."""
    if isinstance(value, Part.Shape):
        poles = [plain(row) for face in value.Faces for row in face.Surface.getPoles()]
        return [tuple(v.Point) for v in value.Vertexes] + poles
    if isinstance(value, FreeCAD.Vector):
        return tuple(value)
    if isinstance(value, FreeCAD.Placement):
        return tuple(value.Base) + tuple(value.Rotation.Q)
    if isinstance(value, FreeCAD.Units.Quantity):
        return value.Value
    if hasattr(value, "TypeId") and hasattr(value, "Name"):
        return value.Name
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, float) and value != value:
        return "nan"
    if isinstance(value, (bool, int, float, str, type(None))):
        return value
    return type(value).__name__


def snapshot(group):
    """Every property of the group and of its objects, a sheet by its saved cells:
    {object name: {property: value}}."""
    def properties(obj):
        if obj.TypeId == "Spreadsheet::Sheet":
            return {"Label": obj.Label, "cells": obj.cells.Content}
        return {prop: plain(getattr(obj, prop)) for prop in obj.PropertiesList}

    return {obj.Name: properties(obj) for obj in [group] + list(group.Group)}


def changed_face():
    poles = reference_poles()
    poles[..., 2] *= 1.3
    return make_bspline_surface(poles, (5, 5)).toShape()


FAULTS = {
    "substitute surface": ("write_substitute", fail),
    "report spreadsheet": ("write_deviation_report", fail),
    "probe points": ("make_probe_points", fail),
}


@pytest.mark.parametrize("step", list(FAULTS))
def test_a_fault_in_a_step_of_add_to_document_adds_nothing(doc, result, monkeypatch, step):
    before = state(doc)
    monkeypatch.setattr(document.results, *FAULTS[step])
    with pytest.raises(SimulatedFault, match="simulated fault"):
        document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    assert state(doc) == before
    monkeypatch.undo()
    group = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    assert sorted(names(doc)) == sorted(["Body", group.Name] + [o.Name for o in group.Group])
    assert group.Group[0].Status == "up to date"


def test_a_fault_in_the_recompute_adds_nothing_and_names_the_object(doc, result, monkeypatch):
    before = state(doc)
    monkeypatch.setattr(document.ProbePoints, "execute", failing_execute)
    with pytest.raises(RuntimeError, match="Probe points could not be computed: simulated fault in execute"):
        document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    assert state(doc) == before and doc.Body.Visibility


def test_a_fault_while_reevaluating_keeps_the_old_result(doc, result, monkeypatch):
    group = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    doc.Body.Shape = changed_face()
    doc.recompute()
    before, kept = state(doc), snapshot(group)
    monkeypatch.setattr(document.results, "write_deviation_report", fail)
    with pytest.raises(SimulatedFault):
        document.reevaluate(group.Group[0])
    assert state(doc) == before and snapshot(group) == kept
    assert group.Group[0].Outdated


def test_a_deleted_source_object_is_refused_with_a_message(doc, result):
    body = doc.Body
    doc.removeObject("Body")
    with pytest.raises(ValueError, match="the source object of Face1 was deleted; name a face of an object"):
        document.add_to_document(result, doc, source=(body, "Face1"))
    assert names(doc) == [] and not doc.HasPendingTransaction


def test_undo_removes_everything_and_redo_brings_it_back_intact(result):
    doc = FreeCAD.newDocument("UndoRedo")
    try:
        doc.UndoMode = 1
        body = doc.addObject("Part::Feature", "Body")
        body.Shape = cmmsampling.reference_face()
        doc.recompute()
        group = document.add_to_document(result, doc, source=(body, "Face1"))
        made, kept = names(doc), snapshot(group)
        doc.undo()
        assert names(doc) == ["Body"] and body.Visibility
        doc.redo()
        assert names(doc) == made and snapshot(group) == kept and body.Visibility
        points = group.Group[0]
        assert points.Substitute == group.Group[1] and points.Report == group.Group[2]
        doc.recompute()
        assert points.Status == "up to date" and len(points.Proxy.point_set(points)) == RUN["n"]
        assert group.Group[2].get("max_mm") == pytest.approx(result.deviation.maximum, rel=1e-9)

        body.Shape = changed_face()
        doc.recompute()
        outdated = snapshot(group)
        document.reevaluate(points)
        again = snapshot(group)
        assert again[points.Name]["MaxDeviation"] != outdated[points.Name]["MaxDeviation"]
        doc.undo()
        assert snapshot(group) == outdated
        doc.redo()
        assert snapshot(group) == again
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_a_second_result_on_the_same_face_keeps_the_face_in_its_label(doc, result):
    first = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    second = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    assert first.Label == "Sampling Body Face1 (pso)"
    assert second.Label == "Sampling Body Face1 (pso)001"


def test_a_copy_of_the_group_links_its_own_objects_and_the_same_face(doc, result):
    group = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    copies = doc.copyObject([group] + group.Group, False, True)
    doc.recompute()
    copy = copies[0]
    points, surface, report = copy.Group
    assert copy.Label == "Sampling Body Face1 (pso)001"
    assert {o.Name for o in copy.Group}.isdisjoint(o.Name for o in group.Group)
    assert points.Substitute == surface and points.Report == report
    assert points.Source == (doc.Body, ["Face1"]) and points.Status == "up to date"
    assert isinstance(points.Proxy, document.ProbePoints)
    assert isinstance(surface.Proxy, document.SubstituteSurface)
    original = group.Group[0]
    assert np.array_equal(points.Proxy.point_set(points).uv, original.Proxy.point_set(original).uv)
    assert "Invalid" not in points.State and "Invalid" not in surface.State

    doc.Body.Shape = changed_face()
    doc.recompute()
    document.reevaluate(points)
    assert not points.Outdated and original.Outdated
    assert report.get("max_mm") == pytest.approx(points.MaxDeviation.Value, rel=1e-9)
    assert group.Group[2].get("max_mm") == pytest.approx(original.MaxDeviation.Value, rel=1e-9)


def test_a_copy_with_its_dependencies_links_the_copied_face(doc, result):
    group = document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    copies = doc.copyObject(group, True, True)
    doc.recompute()
    [points] = document.probe_points_in(copies)
    [body] = [o for o in copies if o.TypeId == "Part::Feature"]
    assert body is not doc.Body and points.Source == (body, ["Face1"])
    assert points.Status == "up to date" and points not in group.Group
    assert points.Substitute in copies and points.Report in copies


def test_orphaned_points_survive_saving_and_reopening(doc, result, tmp_path):
    document.add_to_document(result, doc, source=(doc.Body, "Face1"))
    doc.removeObject("Body")
    doc.recompute()
    path = str(tmp_path / "orphaned.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    reopened = FreeCAD.openDocument(path)
    try:
        [points] = reopened.getObjectsByLabel("Probe points")
        points.touch()
        reopened.recompute()
        assert points.Orphaned and points.Status == "orphaned: its source face Body:Face1 was deleted"
        assert "Invalid" not in points.State and len(points.Shape.Vertexes) == RUN["n"]
        with pytest.raises(ValueError, match="Body:Face1 was deleted"):
            document.reevaluate(points)
    finally:
        FreeCAD.closeDocument(reopened.Name)


def test_reevaluate_finds_its_face_by_geometry_after_the_parts_faces_are_renumbered():
    """Issue 33 #21: the part's faces renumbered (the same solid built from its faces in reverse
    order), Re-evaluate took the new Face6, another face, and said "up to date"."""
    box = Part.makeBox(30, 20, 10)
    doc = FreeCAD.newDocument("Renumbered")
    try:
        body = doc.addObject("Part::Feature", "Body")
        body.Shape = box
        doc.recompute()
        result = cmmsampling.sample(box.Faces[5], 9, "halton", grid=20)
        points = cmmsampling.add_to_document(result, doc, source=(body, "Face6")).Group[0]
        body.Shape = Part.Solid(Part.Shell(list(reversed(box.Faces))))
        doc.recompute()
        assert points.Outdated
        again = cmmsampling.reevaluate(points)
        doc.recompute()
        assert points.Source[1] == ["Face1"] and points.SourceName == "Body:Face1"
        np.testing.assert_allclose(again.points, result.points, atol=1e-9)
        assert "the part's faces were renumbered: the points' face Face6 is now Face1" in points.Notes
        assert points.Status == "up to date"
    finally:
        FreeCAD.closeDocument("Renumbered")
