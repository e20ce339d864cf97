"""Sample face with a probe in the real FreeCAD GUI, on a block with a slot 12 mm wide and 20 mm
deep built here: the panel's probe choice, the echo with part= and probe=, the regions of the
slot's floor the probe cannot reach shaded over the face, the report's reach rows, reopening
the run, and the export dialog offering the collision-free path only where there is one."""
import __main__
import json
import os

import FreeCAD
import FreeCADGui
import numpy as np
import Part
import pytest
from pivy import coin
from PySide import QtGui

import cmmsampling
from cmmsampling import document
from cmmsampling.access.probe import PROBES
from cmmsampling.gui import echo, export_options, view_providers

from .helpers import (dock_text, document_with, fill, open_panel, process_events, task_button, task_form, texts,
                      wait_until)

OK = QtGui.QDialogButtonBox.Ok
PRESET = "2 mm ball, 20 mm stylus"


def slotted_block():
    """60 x 40 x 30 mm with a slot along x over y = 14..26, floor at z = 10."""
    return Part.makeBox(60, 40, 30).cut(Part.makeBox(60, 12, 20, FreeCAD.Vector(0, 14, 10)))


def floor_name(shape):
    """'FaceK' of the slot's floor."""
    return next(f"Face{k}" for k, face in enumerate(shape.Faces, start=1)
                if abs(face.BoundBox.ZMin - 10.0) < 1e-9 and abs(face.BoundBox.ZMax - 10.0) < 1e-9)


@pytest.fixture
def slot_doc(workbench):
    """A new active document holding the slotted block as 'Body'."""
    yield from document_with("ProbeReach", {"Body": slotted_block()})


def shade_points(points):
    """The vertices of the unreached shade drawn for probe points (an SoIndexedFaceSet below
    their annotation with the shade's transparency): (K, 3) mm, (0, 3) when none is drawn."""
    search = coin.SoSearchAction()
    search.setType(coin.SoMaterial.getClassTypeId())
    search.setInterest(coin.SoSearchAction.ALL)
    search.apply(points.ViewObject.Proxy.annotation)
    paths = search.getPaths()
    for i in range(paths.getLength()):
        material = paths[i].getTail()
        if abs(material.transparency[0] - view_providers.UNREACHED_TRANSPARENCY) < 1e-6:
            shade = paths[i].getNodeFromTail(1)
            coords = next(shade.getChild(k) for k in range(shade.getNumChildren())
                          if isinstance(shade.getChild(k), coin.SoCoordinate3))
            return np.array([tuple(p.getValue()) for p in coords.point.getValues()])
    return np.zeros((0, 3))


def test_sample_face_with_a_probe_keeps_to_its_reach_and_shades_the_rest(slot_doc, monkeypatch, artifacts, tmp_path):
    name = floor_name(slot_doc.Body.Shape)
    added = []
    add_result = echo.add_result

    def kept(source, face, arguments, result):
        added.append(result)
        return add_result(source, face, arguments, result)

    monkeypatch.setattr(echo, "add_result", kept)
    form = open_panel(slot_doc, name)
    assert form.probe.currentData() == "" and form.probe.itemText(0) == "not judged"
    fill(form, "halton", n=16, grid=20)
    form.probe.setCurrentIndex(form.probe.findData(PRESET))
    process_events(0.2)
    form.grab().save(os.path.join(artifacts, "sample_face_probe_form.png"))
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 120), form.status.text()

    [result] = added
    assert __main__.result is result
    console = dock_text("Python console")
    assert (f"edge_offset=1.5, min_spacing=None, part=App.getDocument('ProbeReach').getObject('Body').Shape, "
            f"probe=cmmsampling.PROBES['{PRESET}'])") in console
    group = next(o for o in slot_doc.Objects if o.TypeId == "App::DocumentObjectGroup")
    points, surface, report = group.Group[:3]
    assert [o.Label for o in group.Group[3:]] == ["Probe moves", "Probe touches"]
    assert json.loads(points.Probe) == json.loads(json.dumps(result.settings["probe"]))
    assert len(points.Axes) == 16 and points.UnreachedArea.Value == pytest.approx(result.access.unreached_area)
    assert 0.1 * 720.0 < points.UnreachedArea.Value < 0.8 * 720.0
    assert report.get("unreached") == 0 and report.get("unreached_mm2") == pytest.approx(points.UnreachedArea.Value)
    assert any(note.startswith("the probe cannot reach") for note in points.Notes)

    shade = shade_points(points)
    assert len(shade) > 0 and np.allclose(shade[:, 2], 10.0)
    along_walls = (shade[:, 1] < 14.0 + 3.0) | (shade[:, 1] > 26.0 - 3.0)
    at_the_ends = (shade[:, 0] < 5.0) | (shade[:, 0] > 55.0)
    assert (along_walls | at_the_ends).all(), "the shade covers the floor next to the walls (and the raster's ends)"
    probe = np.array([tuple(p) for p in points.Points])
    middle = shade[(shade[:, 0] > 10.0) & (shade[:, 0] < 50.0), 1]
    low, high = middle[middle < 20.0].max(), middle[middle > 20.0].min()
    assert ((probe[:, 1] >= low - 1e-9) & (probe[:, 1] <= high + 1e-9)).all(), "the points lie between the strips"
    key = f"Out of the probe's reach: {points.UnreachedArea.Value:.4g} mm^2"
    assert key in texts(points.ViewObject.Proxy.annotation)
    points.ViewObject.ShowUnreached = False
    assert len(shade_points(points)) == 0 and key not in texts(points.ViewObject.Proxy.annotation)
    points.ViewObject.ShowUnreached = True

    view = FreeCADGui.ActiveDocument.ActiveView
    view.viewTop()
    FreeCADGui.SendMsgToActiveView("ViewFit")
    process_events(0.5)
    view.saveImage(os.path.join(artifacts, "sample_face_unreached_top.png"), 1200, 900, "White")

    assert points.Proxy.follows_probe(points)
    dialog = export_options.ExportOptionsDialog(points, "slot")
    offered = [dialog.order.itemData(i) for i in range(dialog.order.count())]
    assert offered == ["as_optimised", "short_path", "probe_path"]
    assert dialog.order.currentData() == "probe_path", "points planned with a probe start along its path"
    assert dialog.probe_radius.value() == pytest.approx(PROBES[PRESET].ball_diameter / 2)   # the points' own ball
    assert f"the {PROBES[PRESET].ball_diameter:g} mm ball of the probe these points were planned with" in \
        dialog.origin.text()
    chosen = dialog.options()
    dialog.deleteLater()
    report_written = cmmsampling.export(points, str(tmp_path / "slot.dmi"), **chosen)
    assert report_written.count == 16 and "GOTO/" in (tmp_path / "slot.dmi").read_text()
    (tmp_path / "file").mkdir()
    document.export([points], str(tmp_path / "file" / "slot.dmi"))
    assert (tmp_path / "file" / "slot.dmi").read_text() == (tmp_path / "slot.dmi").read_text(), \
        "File > Export writes what the Export command's dialog starts with"

    assert points.ViewObject.Proxy.doubleClicked(points.ViewObject)
    assert wait_until(lambda: task_form() is not None and task_button(OK) is not None, 5)
    again = task_form()
    assert again.probe.currentData() == PRESET and again.n.value() == 16
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 120), again.status.text()
    repeated = [o for o in slot_doc.Objects if o.TypeId == "App::DocumentObjectGroup"][-1].Group[0]
    assert repeated is not points and repeated.Probe == points.Probe
    np.testing.assert_allclose([tuple(p) for p in repeated.Points], [tuple(p) for p in points.Points], atol=1e-9)


def test_points_sampled_without_a_probe_offer_no_probe_path(slot_doc):
    name = floor_name(slot_doc.Body.Shape)
    result = cmmsampling.sample(slot_doc.Body.getSubObject(name), 9, "halton", grid=20)
    points = cmmsampling.add_to_document(result, slot_doc, source=(slot_doc.Body, name)).Group[0]
    assert not points.Proxy.follows_probe(points) and len(shade_points(points)) == 0
    dialog = export_options.ExportOptionsDialog(points, "plain")
    assert [dialog.order.itemData(i) for i in range(dialog.order.count())] == ["as_optimised", "short_path"]
    dialog.deleteLater()
    assert PRESET in PROBES
