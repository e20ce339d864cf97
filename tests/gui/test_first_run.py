"""The first run on a part, as a new user makes it: the defaults sample a 2 mm strip, points keep
the spacing, the part stays visible and the view fits the result, a planar face finishes at once
with its note shown, and the console echo replays in a fresh document to the same points."""
import json
import os
import time

import FreeCAD
import FreeCADGui
import numpy as np
import Part
import pytest
from support.faces import TESTDATA, strip_face

import cmmsampling

from PySide import QtCore, QtGui

from .helpers import (
    child, dock_text, fill, groups, labels_on_screen, overlapping_labels, process_events, task_button, task_form,
    wait_until, zoomed,
)
from .helpers import open_panel as open_body_panel

OK = QtGui.QDialogButtonBox.Ok
VENTILATOR = os.path.join(TESTDATA, "Ventilator.stp")
BLADE_FACE = "Face61"


def part_document(name, shape):
    """A new active document holding ``shape`` as Part::Feature 'Body', seen isometric and fitted."""
    doc = FreeCAD.newDocument(name)
    body = doc.addObject("Part::Feature", "Body")
    body.Shape = shape
    doc.recompute()
    FreeCADGui.ActiveDocument.ActiveView.viewIsometric()
    FreeCADGui.SendMsgToActiveView("ViewFit")
    return doc


@pytest.fixture
def part(workbench, request):
    """A document with a part: a 2 mm strip beside a 400 mm plate (built here) or the
    Ventilator (when the shared test files are there); (document, the strip's face name)."""
    if request.param == "built":
        strip = strip_face()
        plate = Part.makePlane(400, 300, FreeCAD.Vector(-150, 10, -20))
        doc = part_document("FirstRun", Part.Compound([plate, strip]))
        face = "Face2"
    else:
        if not os.path.isfile(VENTILATOR):
            pytest.skip("the shared test files are not here")
        doc = part_document("FirstRun", Part.read(VENTILATOR))
        face = BLADE_FACE
    yield doc, face
    if FreeCADGui.Control.activeDialog():
        FreeCADGui.Control.closeDialog()
    FreeCADGui.Selection.clearSelection()
    FreeCAD.closeDocument(doc.Name)
    process_events(0.1)


def run_panel(doc, face, strategy, **values):
    """Open Sample face on the Body's face, set the strategy and values, press Sample and wait
    until the panel closes; returns the new result's group."""
    form = open_body_panel(doc, face)
    fill(form, strategy, **values)
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 120), form.status.text()
    return groups(doc)[-1]


def screen_box(view, shape):
    """(width, height) of the view in px and the screen rectangle (x0, y0, x1, y1) of the
    corners of ``shape``'s bounding box."""
    box = shape.BoundBox
    corners = [FreeCAD.Vector(x, y, z) for x in (box.XMin, box.XMax) for y in (box.YMin, box.YMax)
               for z in (box.ZMin, box.ZMax)]
    screen = np.array([tuple(view.getPointOnScreen(c)) for c in corners], dtype=float)
    return view.getSize(), (*screen.min(axis=0), *screen.max(axis=0))


@pytest.mark.parametrize("part", ["built", "Ventilator"], indirect=True)
def test_the_defaults_sample_a_2_mm_strip_and_the_part_stays_in_view(part, artifacts):
    doc, face_name = part
    form = open_body_panel(doc, face_name)
    assert form.edge_offset.text() == "auto"
    assert "too narrow" in child(form, "edgeOffsetInfo").text(), child(form, "edgeOffsetInfo").text()
    child(form, "showExpert").click()
    fill(form, "pso", iterations=40)
    beats = []
    heart = QtCore.QTimer()
    heart.timeout.connect(lambda: beats.append(time.perf_counter()))
    heart.start(50)
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 180), form.status.text()
    process_events(0.2)
    heart.stop()
    print(f"{face_name}: the GUI's longest freeze while the run went on and its result was added: "
          f"{np.diff(beats).max():.2f} s")
    group = groups(doc)[-1]
    points, surface = group.Group[:2]
    parameters = json.loads(points.Parameters)
    face = doc.Body.getSubObject(face_name)
    offset = cmmsampling.probe_edge_offset(face)
    assert 0 < offset < 1.5 and parameters["edge_offset"] == offset
    xyz = np.array([tuple(p) for p in points.Points])
    edges = Part.Compound(face.Edges)
    assert min(edges.distToShape(Part.Vertex(*p))[0] for p in xyz) >= offset - 1e-6
    gaps = np.linalg.norm(xyz[:, None] - xyz[None], axis=-1) + np.diag(np.full(len(xyz), np.inf))
    assert gaps.min() >= parameters["min_spacing"] - 1e-9 > 0
    assert doc.Body.ViewObject.Visibility and points.ViewObject.Visibility
    process_events(0.3)
    view = FreeCADGui.ActiveDocument.ActiveView
    (width, height), (x0, y0, x1, y1) = screen_box(view, points.Shape)
    assert 0 <= x0 and x1 <= width and 0 <= y0 and y1 <= height
    assert max((x1 - x0) / width, (y1 - y0) / height) > 0.25, (width, height, x0, y0, x1, y1)
    view.saveImage(os.path.join(artifacts, f"first_run_strip_{len(doc.Body.Shape.Faces)}_faces.png"),
                   width, height, "White")


@pytest.mark.parametrize("part", ["built"], indirect=True)
def test_labels_do_not_collide_and_one_result_is_shown(part, artifacts):
    doc, face_name = part
    first = run_panel(doc, face_name, "halton", n=81)
    second = run_panel(doc, face_name, "hammersley", n=81)
    assert not first.Group[0].ViewObject.Visibility and not first.Group[1].ViewObject.Visibility
    points = second.Group[0]
    proxy = points.ViewObject.Proxy
    tips = dict(zip(points.Labels, np.array([tuple(p) for p in points.Points]) + points.ViewObject.ApproachLength.Value
                    * np.array([tuple(n) for n in points.Normals])))
    counts = {}
    for factor in (0.25, 0.5, 1, 2, 4, 8):
        zoomed(factor, points)
        found = labels_on_screen("P")
        counts[factor] = len(found)
        assert overlapping_labels(found, points.ViewObject.LabelSize) == [], f"labels overlap at zoom {factor}"
        if factor == 1:
            FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(artifacts, "first_run_labels.png"),
                                                           1200, 900, "White")
        drawn = {text for text, _ in found}
        levels = [k for k, shown in enumerate(proxy.levels) if {points.Labels[i] for i in shown} == drawn]
        assert levels or not drawn, "the view draws one of the levels"
        if len(found) > 1:
            kept = np.array([tips[text] for text in drawn])
            gaps = np.linalg.norm(kept[:, None] - kept[None], axis=-1) + np.diag(np.full(len(kept), np.inf))
            assert gaps.min() >= proxy.ladder[levels[-1]] - 1e-9
    print(f"labels drawn of 81 by zoom: {counts}")
    assert list(counts.values()) == sorted(counts.values()) and counts[0.25] < counts[1] < counts[8], \
        "zooming in shows more labels, zooming out fewer"
    assert len(proxy.levels[0]) == 81, "LabelSpacing 0: every label once the view zooms in far enough"
    points.ViewObject.LabelSpacing = 10.0
    zoomed(8, points)
    found = labels_on_screen("P")
    kept = np.array([tips[text] for text, _ in found])
    gaps = np.linalg.norm(kept[:, None] - kept[None], axis=-1) + np.diag(np.full(len(kept), np.inf))
    assert len(found) < counts[8] and gaps.min() >= 10.0, "LabelSpacing: none closer however far the view zooms in"
    points.ViewObject.LabelSpacing = 0.0
    zoomed(1)


def test_a_planar_face_finishes_at_once_with_its_note_shown(workbench, artifacts):
    doc = part_document("Planar", Part.makeBox(40, 30, 10))
    try:
        before = dock_text("Report view")
        group = run_panel(doc, "Face6", "pso")
        points, surface = group.Group[:2]
        assert points.Notes[0].startswith("pso was not run"), points.Notes
        line = "cmmsampling: Body.Face6, PSO (paper), N = 81: maximum deviation"
        assert wait_until(lambda: line in dock_text("Report view")[len(before):], 2)
        report = dock_text("Report view")[len(before):]
        assert "note: pso was not run: the uniform parametric layout already fits this face exactly" in report
        assert f"{line} 0 mm, mean 0 mm" in report   # not '5.711e-13 mm'
        texts = []
        _collect_texts(surface.ViewObject.Proxy.coloured, texts)
        assert texts[-2:] == ["0.0001000 mm", "Deviation, Body.Face6"], texts   # in mm; no max to mark
        FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(artifacts, "first_run_planar.png"),
                                                       1000, 750, "White")
    finally:
        FreeCAD.closeDocument(doc.Name)


def _collect_texts(node, out):
    """The strings of every SoText2 below node, depth first."""
    if node.getTypeId().getName() == "Text2":
        out.append(node.string.getValues()[0])
    for index in range(node.getNumChildren() if hasattr(node, "getNumChildren") else 0):
        _collect_texts(node.getChild(index), out)


def test_the_echo_replays_in_a_fresh_document_to_the_same_points(workbench):
    doc = part_document("Echo", cmmsampling.reference_face())
    group = run_panel(doc, "Face1", "pso", n=25, population=8, iterations=20, seed=4)
    made = np.array([tuple(p) for p in group.Group[0].Points])
    console = dock_text("Python console")
    echo = [line.removeprefix(">>> ") for line in console[console.rindex("import cmmsampling"):].splitlines()[:4]]
    assert echo[2].startswith("result = cmmsampling.sample(face, n=25, strategy='pso'"), echo
    name = doc.Name
    assert echo[3].startswith(f"group = cmmsampling.add_to_document(result, App.getDocument('{name}')")
    FreeCAD.closeDocument(name)
    fresh = part_document(name, cmmsampling.reference_face())
    try:
        assert fresh.Name == name and not groups(fresh)
        namespace = {"App": FreeCAD}
        exec("\n".join(echo), namespace)
        replayed = np.array([tuple(p) for p in namespace["group"].Group[0].Points])
        np.testing.assert_allclose(replayed, made, atol=1e-9)
        assert namespace["result"].evaluations > 0
        if os.cpu_count() > 1:
            assert namespace["result"].settings["processes"] == 2, "the swarm's second process took part"
    finally:
        FreeCAD.closeDocument(fresh.Name)
    assert task_form() is None


def test_a_double_click_on_probe_points_reopens_their_run(workbench, artifacts):
    doc = part_document("Again", cmmsampling.reference_face())
    try:
        group = run_panel(doc, "Face1", "halton", n=36, seed=3, edge_offset=2.0, min_spacing=1.0, grid=40)
        points = group.Group[0]
        assert points.ViewObject.Proxy.doubleClicked(points.ViewObject)
        assert wait_until(lambda: task_form() is not None and task_button(OK) is not None, 5)
        form = task_form()
        assert form.faceLabel.text() == "Body.Face1"
        assert (form.strategy.currentData(), form.n.value(), form.seed.value()) == ("halton", 36, 3)
        assert (form.edge_offset.value(), form.min_spacing.value(), form.grid.value()) == (2.0, 1.0, 40)
        assert form.auto_poles.isChecked()
        FreeCADGui.getMainWindow().grab().save(os.path.join(artifacts, "sample_again.png"))
        task_button(OK).click()
        assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 120), form.status.text()
        again = groups(doc)[-1].Group[0]
        assert again is not points
        np.testing.assert_allclose([tuple(p) for p in again.Points], [tuple(p) for p in points.Points], atol=1e-9)
        menu = QtGui.QMenu()
        points.ViewObject.Proxy.setupContextMenu(points.ViewObject, menu)
        [action] = [a for a in menu.actions() if a.text() == "Sample again..."]
        action.trigger()
        assert wait_until(lambda: task_form() is not None, 5) and task_form().n.value() == 36
        FreeCADGui.Control.closeDialog()
        assert wait_until(lambda: task_form() is None, 5)
        doc.removeObject(points.Source[0].Name)
        doc.recompute()
        assert not points.ViewObject.Proxy.doubleClicked(points.ViewObject)
        assert wait_until(lambda: "Cannot open Probe points again: its source face" in dock_text("Report view"), 5)
        assert task_form() is None
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_a_runs_default_poles_reopen_as_auto_for_its_own_degree(workbench):
    from cmmsampling.gui.panels.sample_face import run_values

    assert run_values({"n": 81, "fit_degree": [7, 7], "fit_poles": [8, 8]})["auto_poles"]
    assert not run_values({"n": 81, "fit_degree": [7, 7], "fit_poles": [9, 9]})["auto_poles"]
    values = run_values({"strategy": "optimal", "n": 49, "fit_degree": [3, 3], "fit_poles": [5, 5], "grid": [40, 50],
                         "time_limit": None})
    assert values["auto_poles"] and values["time_limit"] == 0.0 and "grid" not in values
