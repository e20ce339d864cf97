"""*Measure on CMM...* in the GUI: the probe points measured over I++ DME on the simulated server
(127.0.0.1) behind a progress dialog, the echoed call that replays it without moving the machine
again, and the Inspect dialog it ends in, with the measured file; Cancel keeps the points
measured and ends the session."""
import os

import FreeCADGui
import numpy as np
import pytest

import cmmsampling
from cmmsampling import document
from cmmsampling.document.object_types import is_measured_points
from cmmsampling.gui import commands, inspect_dialog, measure_dialog

from PySide import QtCore, QtGui

from .helpers import document_with, dock_text, handle_dialog, main_window, process_events, wait_until

MISPLACED = {"rz": 0.5, "x": 0.8}


@pytest.fixture
def points(doc):
    result = cmmsampling.sample(doc.Body.Shape.Faces[0], 16, "halton", occ_check=False)
    return document.add_to_document(result, doc, source=(doc.Body, "Face1")).Group[0]


def measure_with(points, choose, after=None, timeout_s=30):
    """Select points, run Measure on CMM, answer its dialog with choose(dialog) and, where it ends
    in the Inspect dialog, that one with after(dialog)."""
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(points)

    def measure():
        handle_dialog(measure_dialog.MeasureDialog, lambda: FreeCADGui.runCommand(commands.MeasureOnCMM.NAME),
                      choose, timeout_s)

    if after is None:
        return measure()
    return handle_dialog(inspect_dialog.InspectDialog, measure, after, timeout_s)


def test_measure_on_cmm_measures_echoes_and_ends_in_the_inspection(points, tmp_path, artifacts):
    doc = points.Document
    out = str(tmp_path / "measured.csv")
    seen = {}
    with cmmsampling.SimulatedCMM.measuring(points, form_error=0.01, misplacement=MISPLACED, seed=3) as cmm:
        port = int(cmm.address.rsplit(":", 1)[1])

        def choose(dialog):
            seen["title"] = dialog.windowTitle()
            dialog.host.setText("127.0.0.1")
            dialog.port.setValue(port)
            browse = dialog.findChild(QtGui.QPushButton, "browse")

            def pick(chooser):
                chooser.findChild(QtGui.QLineEdit, "fileNameEdit").setText(out[:-len(".csv")])   # as typed
                chooser.accept()

            handle_dialog(QtGui.QFileDialog, browse.click, pick)
            assert dialog.path.text() == out, "Browse... chose the file, its extension added"
            dialog.grab().save(os.path.join(artifacts, "measure_dialog.png"))
            dialog.accept()

        def inspect_it(dialog):
            seen["inspect file"] = dialog.path.text()
            dialog.tolerance.setValue(0.05)
            dialog.accept()

        console = dock_text("Python console")
        measure_with(points, choose, inspect_it)
        served = cmm.connections
    assert seen["title"] == f"Measure on CMM: {points.Label}" and seen["inspect file"] == out
    assert served == 1, "the echoed call did not measure a second time"
    echoed = dock_text("Python console")[len(console):]
    assert (f"run = cmmsampling.measure(App.getDocument({doc.Name!r}).getObject({points.Name!r}), "
            f"'127.0.0.1:{port}', {out!r})") in echoed
    assert f"inspection = cmmsampling.inspect(App.getDocument({doc.Name!r}).getObject({points.Name!r}), {out!r}, " \
           "tolerance=0.05)" in echoed
    assert wait_until(lambda: "Measured 16 of 16 points over I++ DME at 127.0.0.1:" in dock_text("Report view"), 2)
    [measured] = [o for o in doc.Objects if is_measured_points(o)]
    assert measured.Verdict == "PASS" and len(measured.Labels) == 16
    assert measured.Profile.Value <= 0.02 + 1e-5, "a 0.01 mm form error at most"
    FreeCADGui.SendMsgToActiveView("ViewFit")
    process_events(0.3)
    FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(artifacts, "measured_live.png"), 1000, 750, "White")


def test_cancel_keeps_the_points_measured_and_asks_nothing_more(points, tmp_path, artifacts):
    out, seen = str(tmp_path / "measured.csv"), []
    with cmmsampling.SimulatedCMM.measuring(points, move_s=0.1) as cmm:
        port = int(cmm.address.rsplit(":", 1)[1])

        def choose(dialog):
            dialog.port.setValue(port)
            dialog.path.setText(out)
            dialog.accept()

        def cancel(progress):
            wait_until(lambda: sum("PtMeas(" in c for c in cmm.commands) >= 3, 10)
            seen.append((progress.windowTitle(), progress.labelText()))
            progress.grab().save(os.path.join(artifacts, "measure_progress.png"))
            progress.cancel()

        handle_dialog(QtGui.QProgressDialog, lambda: measure_with(points, choose), cancel, 30)
        received = list(cmm.commands)
    assert received[-2].endswith("ClearAllErrors()") and received[-1].endswith("EndSession()"), received[-6:]
    back = cmmsampling.read_points(out)
    assert seen[0][0] == "Measure on CMM" and seen[0][1].startswith(f"Measuring {points.Label} on 127.0.0.1:")
    assert 2 <= len(back) <= 4 and back.labels == [f"P{k}" for k in range(1, len(back) + 1)]
    assert "Not measured (cancelled)" in main_window().statusBar().currentMessage()
    assert not [o for o in points.Document.Objects if is_measured_points(o)], "a cancelled run is not inspected"
    assert np.isfinite(back.points).all()


def test_measure_until_decided_stops_on_the_verdict_and_adds_its_inspection(points, tmp_path, artifacts):
    doc = points.Document
    out = str(tmp_path / "decided.csv")
    seen = {}
    with cmmsampling.SimulatedCMM.measuring(points, form_error=0.004, misplacement=MISPLACED, seed=5) as cmm:
        port = int(cmm.address.rsplit(":", 1)[1])

        def choose(dialog):
            dialog.port.setValue(port)
            dialog.path.setText(out)
            seen["enabled before"] = dialog.tolerance.isEnabled()
            dialog.until.setChecked(True)
            seen["enabled after"] = dialog.tolerance.isEnabled() and dialog.risk.isEnabled()
            dialog.tolerance.setValue(0.05)
            dialog.uncertainty.setValue(0.0005)
            dialog.risk.setValue(0.05)
            dialog.grab().save(os.path.join(artifacts, "measure_until_decided_dialog.png"))
            dialog.accept()

        console = dock_text("Python console")
        measure_with(points, choose, timeout_s=240)
        served, touched = cmm.connections, sum("PtMeas(" in command for command in cmm.commands)
    assert seen == {"enabled before": False, "enabled after": True}
    assert served == 1, "the echoed call did not measure a second time"
    echoed = dock_text("Python console")[len(console):]
    assert (f"run = cmmsampling.measure_until_decided(App.getDocument({doc.Name!r}).getObject({points.Name!r}), "
            f"'127.0.0.1:{port}', 0.05, 0.0005, {out!r}, risk=0.05)") in echoed
    assert "inspection = run.inspection" in echoed
    back = cmmsampling.read_points(out)
    assert len(back) == touched and 12 <= len(back) < 40, "every touch in the file, far fewer than the candidates"
    assert wait_until(lambda: f"conforms after {len(back)} points" in dock_text("Report view"), 2)
    [measured] = [o for o in doc.Objects if is_measured_points(o)]
    assert len(measured.Labels) == len(back) and measured.Profile.Value <= 0.05
    assert "conforms" in main_window().statusBar().currentMessage() or measured.Verdict == "PASS"
    FreeCADGui.SendMsgToActiveView("ViewFit")
    process_events(0.3)
    FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(artifacts, "measured_until_decided.png"), 1000, 750,
                                                   "White")


@pytest.fixture
def block(workbench):
    import Part

    yield from document_with("GuiBlock", {"Block": Part.makeBox(60, 40, 20)})


def test_measure_until_decided_on_datums_with_an_earlier_part(block, tmp_path, artifacts):
    """A block's top 0.03 mm high, judged on datums Face5 | Face3 | Face1 (bottom, front, left)
    typed in the dialog, with an earlier part's inspection checked: the datum points come first,
    the echo names the datums and the earlier part (the run handed over, not measured again), and
    the inspection added fails; a face the block does not have is refused in one line."""
    from cmmsampling.cmm.server import SimulatedCMM, VirtualPart
    from cmmsampling.geometry.validation import InputError
    from cmmsampling.inspection.simulate import Misplacement

    doc, part = block, block.Block
    names = {tuple(np.round(face.normalAt(0.5, 0.5), 6)): f"Face{k}" for k, face in enumerate(part.Shape.Faces, 1)}
    top, frame = names[(0.0, 0.0, 1.0)], [names[(0.0, 0.0, -1.0)], names[(0.0, -1.0, 0.0)], names[(-1.0, 0.0, 0.0)]]
    result = cmmsampling.sample(part.Shape.getElement(top), 16, "halton", occ_check=False)
    points = document.add_to_document(result, doc, source=(part, top)).Group[0]
    cmmsampling.simulate_measurement(result, tmp_path / "earlier.csv", form_error=0.004, noise=0.0005, seed=1)
    cmmsampling.add_inspection_to_document(cmmsampling.inspect(points, tmp_path / "earlier.csv"), doc, source=points)
    [earlier] = [o for o in doc.Objects if is_measured_points(o)]
    out = str(tmp_path / "decided.csv")

    def form(touched):
        high = touched[:, 2] > 20.0 - 1e-6
        return np.where(high, 0.03 + 0.005 * np.sin(touched[:, 0] / 8.0) * np.cos(touched[:, 1] / 6.0), 0.0)

    placed = Misplacement(x=0.3, y=-0.2, rz=0.1).matrix(np.array([30.0, 20.0, 10.0]))
    seen = {}
    with SimulatedCMM(VirtualPart(form, placed, 0.0005, np.random.default_rng(2))) as cmm:
        port = int(cmm.address.rsplit(":", 1)[1])

        def choose(dialog):
            dialog.port.setValue(port)
            dialog.path.setText(out)
            dialog.until.setChecked(True)
            dialog.tolerance.setValue(0.05)
            dialog.uncertainty.setValue(0.0005)
            dialog.datums.setText("Face99")
            with pytest.raises(InputError, match="Block has no face 'Face99'"):
                dialog.datum_names()
            dialog.datums.setText(", ".join(frame))
            seen["earlier"] = [dialog.earlier.item(row).text() for row in range(dialog.earlier.count())]
            dialog.earlier.item(0).setCheckState(QtCore.Qt.Checked)
            dialog.grab().save(os.path.join(artifacts, "measure_until_decided_datums_dialog.png"))
            dialog.accept()

        console = dock_text("Python console")
        measure_with(points, choose, timeout_s=240)
        served = cmm.connections
    assert seen["earlier"] == [f"{earlier.getParentGroup().Label}: {earlier.Label} (16 points)"]
    assert served == 1, "the echoed call did not measure a second time"
    echoed = dock_text("Python console")[len(console):]
    shape = f"App.getDocument({doc.Name!r}).getObject('Block').Shape"
    assert "datums=[" + ", ".join(f"{shape}.getElement({name!r})" for name in frame) + "]" in echoed
    assert f"prior=[App.getDocument({doc.Name!r}).getObject({earlier.Name!r}).Proxy.inspection(" in echoed
    labels = cmmsampling.read_points(out).labels
    assert labels[:14] == [f"D{label}{k}" for label, count in (("A", 6), ("B", 4), ("C", 4))
                           for k in range(1, count + 1)], "the datum points first"
    assert wait_until(lambda: "does not conform after" in dock_text("Report view"), 2)
    [decided] = [o for o in doc.Objects if is_measured_points(o) and o is not earlier]
    assert decided.Verdict == "FAIL" and decided.Profile.Value > 0.06
    FreeCADGui.SendMsgToActiveView("ViewFit")
    process_events(0.3)
    FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(artifacts, "measured_until_decided_datums.png"),
                                                   1000, 750, "White")
