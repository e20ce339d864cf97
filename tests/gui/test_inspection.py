"""*Inspect measured points...* on a Ventilator blade: the points a virtual CMM measured on a
misplaced part with a form error come back, are aligned and judged against a tolerance, coloured
by band on the part, with the inspection report, in one Undo, echoed as the API calls."""
import importlib
import os

import FreeCAD
import FreeCADGui
import numpy as np
import Part
import pytest
from support.faces import TESTDATA

import cmmsampling
from cmmsampling.document.object_types import is_measured_points
from cmmsampling.fitting.deviation import mm_text
from cmmsampling.formats.qif.schema import schema_errors
from cmmsampling.gui import colormap, commands, inspect_dialog, inspection_view
from cmmsampling.inspection.result import tolerance_bands

from pivy import coin
from PySide import QtGui

from .helpers import (dock_text, document_with, handle_dialog, labels_on_screen, main_window, modal_message,
                      overlapping_labels, process_events, texts, wait_until)

BLADE = "Face176"
MISPLACED = {"rx": 0.5, "ry": -0.4, "rz": 0.8, "x": 1.2, "y": -1.5, "z": 0.6}


@pytest.fixture
def blade_points(workbench):
    """A document with the Ventilator and 36 Halton probe points on a blade (skipped without the
    shared test data); (document, the probe points)."""
    path = os.path.join(TESTDATA, "Ventilator.stp")
    if not os.path.isfile(path):
        pytest.skip("the shared test data (Ventilator.stp) is not here")
    for doc in document_with("Inspection", {"Ventilator": Part.read(path)}):
        result = cmmsampling.sample(doc.Ventilator.getSubObject(BLADE), 36, "halton", occ_check=False)
        group = cmmsampling.add_to_document(result, doc, source=(doc.Ventilator, BLADE))
        yield doc, group.Group[0]


def inspect_with(points, handle, timeout_s=20):
    """Select points, run the command and answer its dialog with handle(dialog), which must close it."""
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(points)
    handle_dialog(inspect_dialog.InspectDialog, lambda: FreeCADGui.runCommand(commands.InspectMeasured.NAME),
                  handle, timeout_s)


def test_inspect_measured_points_on_a_ventilator_blade(blade_points, tmp_path, artifacts):
    doc, points = blade_points
    measured = str(tmp_path / "blade.dmi")
    cmmsampling.simulate_measurement(points, measured, form_error=0.03, misplacement=MISPLACED, seed=4)
    seen = {}

    def choose(dialog):
        seen["title"] = dialog.windowTitle()
        seen["ok before"] = dialog.buttons.button(QtGui.QDialogButtonBox.Ok).isEnabled()
        dialog.path.setText(measured)
        dialog.tolerance.setValue(0.013)
        dialog.alignment.setCurrentIndex(dialog.alignment.findData("min_max"))
        dialog.grab().save(os.path.join(artifacts, "inspect_dialog.png"))
        dialog.accept()

    before, undo = len(doc.Objects), doc.UndoCount
    console = dock_text("Python console")
    inspect_with(points, choose)
    assert seen["title"] == f"Inspect measured points: Sampling Ventilator {BLADE} (halton)"
    assert not seen["ok before"], "OK waits for a file"
    [group] = [obj for obj in doc.Objects if obj.Label.startswith("Inspection ") and hasattr(obj, "Group")]
    measured_points, report = group.Group
    assert is_measured_points(measured_points) and report.TypeId == "Spreadsheet::Sheet"
    assert doc.UndoCount == undo + 1 and len(doc.Objects) == before + 3

    expected = cmmsampling.inspect(points, measured, tolerance=0.013)
    deviations = np.array(measured_points.Deviation)
    assert np.abs(deviations - expected.deviations).max() < 1e-9
    assert list(measured_points.Bands) == tolerance_bands(deviations, 0.013).tolist()
    assert len(set(measured_points.Bands)) >= 3, "the picture shows points in, near and out of the zone"
    assert group.Label == f"Inspection Probe points ({measured_points.Verdict})"
    assert measured_points.Verdict == ("PASS" if expected.passed else "FAIL")
    assert report.get("profile_mm") == pytest.approx(expected.profile)
    assert report.get("verdict") == measured_points.Verdict and report.get("n") == 36
    echoed = dock_text("Python console")[len(console):]
    assert (f"inspection = cmmsampling.inspect(App.getDocument({doc.Name!r}).getObject({points.Name!r}), "
            f"{measured!r}, tolerance=0.013)") in echoed
    assert "group = cmmsampling.add_inspection_to_document(inspection, " in echoed
    assert "profile" in main_window().statusBar().currentMessage()
    assert "motions the points do not hold: slide along" in main_window().statusBar().currentMessage(), \
        "the 2 mm blade holds its slide weakly"
    assert wait_until(lambda: "cmmsampling: alignment (measured -> CAD, applied to the points; the part is not "
                              "moved): shift (" in dock_text("Report view"), 2)
    assert not points.Visibility and measured_points.Visibility, "the inspection is shown alone"

    proxy = measured_points.ViewObject.Proxy
    assert isinstance(proxy, inspection_view.ViewProviderMeasuredPoints)
    assert proxy.annotation.getNumChildren() == 3, "legend, dots over it and labels"
    assert texts(proxy.annotation.getChild(0))[-2:] == [measured_points.Verdict,
                                                        f"profile {mm_text(expected.profile)}, tolerance 0.013 mm"]
    view = FreeCADGui.ActiveDocument.ActiveView
    view.setViewDirection(tuple(-points.Proxy.point_set(points).normals.mean(axis=0)))
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(doc.Ventilator, BLADE)
    FreeCADGui.SendMsgToActiveView("ViewSelection")
    FreeCADGui.Selection.clearSelection()
    process_events(0.5)
    FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(artifacts, "inspection_ventilator_blade.png"),
                                                   1200, 900, "White")
    drawn_labels = [(text, at) for text, at in labels_on_screen() if text in set(measured_points.Labels)]
    print(f"Ventilator {BLADE}: {expected.summary()}; {len(drawn_labels)} of the 36 labels drawn")
    assert 0 < len(drawn_labels) <= 36 and overlapping_labels(drawn_labels, 12) == [], \
        "the measured points' labels keep apart"

    exporter = importlib.import_module(FreeCAD.getExportType("qif")[0])
    results = str(tmp_path / "blade_results.qif")
    exporter.export([group], results)   # what File > Export runs after its file dialog
    text = open(results).read()
    assert schema_errors(text) == [] and "<InspectionStatusEnum>" + measured_points.Verdict in text
    back = cmmsampling.read_points(results)
    assert back.labels == expected.labels and np.abs(back.deviation - deviations).max() < 1e-12
    assert wait_until(lambda: f"Wrote the results of 36 measured points to {results}" in dock_text("Report view"), 2)

    doc.undo()
    assert len(doc.Objects) == before and points.Visibility


def test_a_bad_measured_file_is_named_and_adds_nothing(blade_points, tmp_path):
    doc, points = blade_points
    bad = tmp_path / "bad.txt"
    bad.write_text("P1; 1,5; 2,0; 3,0\n")
    before = len(doc.Objects)

    def choose(dialog):
        dialog.path.setText(str(bad))
        dialog.accept()

    said = modal_message(lambda: inspect_with(points, choose))
    assert "decimal comma" in said, said
    assert len(doc.Objects) == before
    shown = main_window().statusBar().currentMessage()
    assert shown.startswith("Not inspected: ") and "decimal comma" in shown, "the status bar said Inspecting... on"


def test_the_inspection_shows_its_progress_and_cancel_adds_nothing(blade_points, tmp_path, artifacts):
    """The inspection runs behind a progress dialog (it held the GUI 47-64 s for 20,000 points,
    with no progress or Cancel); Cancel there judges and adds nothing, and FreeCAD goes on."""
    doc, points = blade_points
    measured = str(tmp_path / "blade.dmi")
    cmmsampling.simulate_measurement(points, measured, form_error=0.01, misplacement=MISPLACED, seed=3)
    before, undo, seen = [o.Name for o in doc.Objects], doc.UndoCount, []

    def choose(dialog):
        dialog.path.setText(measured)
        dialog.accept()

    def cancel(progress):
        seen.append((progress.windowTitle(), progress.labelText()))
        progress.grab().save(os.path.join(artifacts, "inspection_progress.png"))
        progress.cancel()

    handle_dialog(QtGui.QProgressDialog, lambda: inspect_with(points, choose), cancel)
    assert seen and seen[0][0] == "Inspect measured points" and seen[0][1].startswith(
        f"Inspecting the measured points of {points.Label}")
    assert [o.Name for o in doc.Objects] == before and doc.UndoCount == undo
    assert main_window().statusBar().currentMessage() == "Inspection cancelled: nothing was judged or added"
    inspect_with(points, choose)
    assert any(o.Label.startswith("Inspection ") for o in doc.Objects), "it runs again after a Cancel"


def test_without_a_tolerance_the_points_take_the_deviation_colours(blade_points, tmp_path):
    doc, points = blade_points
    measured = tmp_path / "blade.csv"
    cmmsampling.simulate_measurement(points, measured, form_error=0.03, seed=2)
    inspection = cmmsampling.inspect(points, measured, alignment="none")
    group = cmmsampling.add_inspection_to_document(inspection, doc, source=points)
    measured_points = group.Group[0]
    assert measured_points.Verdict == "no tolerance" and group.Label == "Inspection Probe points (no tolerance)"
    assert set(measured_points.Bands) == {0}
    measured_points.ViewObject.ShowLabels = False
    assert measured_points.ViewObject.Proxy.annotation.getNumChildren() == 2, "legend and dots"

    again = cmmsampling.add_inspection_to_document(inspection, doc, source=points).Group[0]
    assert again.ViewObject.ShowLegend and not measured_points.ViewObject.ShowLegend, "the newest's legend alone"
    substitute = points.Substitute.ViewObject
    assert substitute.Visibility is False or substitute.ShowLegend
    deviation = next(substitute.Proxy.coloured.getChild(k) for k in range(substitute.Proxy.coloured.getNumChildren())
                     if isinstance(substitute.Proxy.coloured.getChild(k), coin.SoAnnotation))
    left, right = legend_span(deviation), legend_span(again.ViewObject.Proxy.annotation.getChild(0))
    assert left[0] < -0.9 and right[1] == pytest.approx(colormap.RIGHT_EDGE) and left[1] < right[0], \
        "a substitute's legend at the left, an inspection's at the right: apart"
    measured_points.ViewObject.ShowLegend = True
    assert not again.ViewObject.ShowLegend, "switching one on hides the other"


def legend_span(overlay):
    """The x range (view units) of a colormap overlay's rectangles (swatches, text boxes), its
    translation applied."""
    group, shift, xs = overlay.getChild(0), 0.0, []
    for k in range(group.getNumChildren()):
        node = group.getChild(k)
        if isinstance(node, coin.SoTranslation):
            shift = node.translation.getValue()[0]
        elif isinstance(node, coin.SoSeparator) and isinstance(node.getChild(1), coin.SoCoordinate3):
            xs += [point[0] + shift for point in node.getChild(1).point.getValues()]
    return min(xs), max(xs)


def test_the_command_says_what_to_select_and_echoes_every_choice(blade_points):
    doc, points = blade_points
    FreeCADGui.Selection.clearSelection()
    assert "Select the probe points" in commands.InspectMeasured().reason()
    FreeCADGui.Selection.addSelection(points)
    assert commands.InspectMeasured().reason() is None
    judge, add = inspect_dialog.inspection_call(points, {"measured": "/data/m.dmi", "alignment": "best_fit",
                                                         "locked": ("z",), "tolerance": None, "zone_offset": 0.005})
    source = f"App.getDocument({doc.Name!r}).getObject({points.Name!r})"
    assert judge == (f"inspection = cmmsampling.inspect({source}, '/data/m.dmi', alignment='best_fit', "
                     "locked=('z',), zone_offset=0.005)")
    assert add == f"group = cmmsampling.add_inspection_to_document(inspection, App.getDocument({doc.Name!r}), " \
                  f"source={source})"


@pytest.fixture
def block_plan(workbench):
    """A document with the datum block and a plan of its top and its three datum faces (16 points
    each); (document, the plan's group)."""
    from cmmsampling.geometry.blocks import datum_block

    for doc in document_with("DatumBlock", {"Block": datum_block()}):
        plan = cmmsampling.plan(doc.Block.Shape, n_total=64, strategy="uniform_parametric", faces=[3, 1, 5, 4],
                                processes=1)
        yield doc, cmmsampling.add_plan_to_document(plan, doc, doc.Block)


def test_a_profile_relative_to_datums_shows_its_uncertainty_and_decision(block_plan, tmp_path, artifacts):
    doc, group = block_plan
    measured = str(tmp_path / "block.dmi")
    cmmsampling.simulate_measurement(group, measured, form_error=0.02, noise=0.001, seed=7, misplacement=MISPLACED)

    def choose(dialog):
        dialog.path.setText(measured)
        dialog.tolerance.setValue(0.05)
        dialog.datums.setText("Face1, Face5, Face4")
        dialog.uncertainty.setValue(0.001)
        dialog.grab().save(os.path.join(artifacts, "inspect_dialog_datums.png"))
        dialog.accept()

    console = dock_text("Python console")
    inspect_with(group, choose, timeout_s=60)
    expected = cmmsampling.inspect(group, measured, tolerance=0.05, datums=("Face1", "Face5", "Face4"),
                                   uncertainty=0.001)
    echoed = dock_text("Python console")[len(console):]
    assert "tolerance=0.05, datums=('Face1', 'Face5', 'Face4'), uncertainty=0.001)" in echoed
    [inspected] = [obj for obj in doc.Objects if obj.Label.startswith("Inspection ") and hasattr(obj, "Group")]
    measured_points, report = inspected.Group
    assert measured_points.Decision == expected.decision and report.get("decision") == expected.decision
    assert measured_points.Uncertainty.Value == pytest.approx(expected.profile_uncertainty)
    assert f"tolerance 0.05 mm: {expected.decision} by ISO 14253-1 (U " in main_window().statusBar().currentMessage()
    assert inspected.Label.endswith(f"({expected.decision})"), "the decision first, in the tree too"
    legend = texts(measured_points.ViewObject.Proxy.annotation.getChild(0))[-3:]
    assert legend == [f"{expected.decision} (ISO 14253-1, U {mm_text(expected.profile_uncertainty)})",
                      f"profile {mm_text(expected.profile)}, tolerance 0.05 mm",
                      f"the profile alone: {measured_points.Verdict}"], legend
    view = FreeCADGui.ActiveDocument.ActiveView
    view.viewIsometric()
    FreeCADGui.SendMsgToActiveView("ViewFit")
    process_events(0.5)
    view.saveImage(os.path.join(artifacts, "inspection_datum_block.png"), 1200, 900, "White")
    print(f"datum block: {expected.summary()}")
