"""The workbench never loses work (issue 10), in the GUI: Cancel at any moment of a run, a fault
inside a run or while its result is added, the source face deleted during a run, copy and paste
of a result group."""
import FreeCAD
import FreeCADGui
import numpy as np
import pytest
from PySide import QtGui

from cmmsampling import document

from .helpers import (
    Hold, answer_dialog, dock_text, drawn, fill, groups, interrupt_run, open_panel, process_events,
    running_workers, short_result, task_button, wait_until, widgets,
)

OK, CANCEL = QtGui.QDialogButtonBox.Ok, QtGui.QDialogButtonBox.Cancel
SHORT_RUN = {"n": 25, "population": 8, "iterations": 20, "seed": 1, "grid": 30}
MOMENTS = {"before the first iteration": None, "in the middle": 10, "at the last iteration": 20}


class SimulatedFault(Exception):
    """Raised by the steps the tests break on purpose."""


def fault_in_the_run():
    raise SimulatedFault("simulated fault in iteration 5")


def fault_in_the_report(*args):
    raise SimulatedFault("simulated fault in the report")


def untouched(doc):
    """What a cancelled or failed run must leave as it was: objects, undo stack, no open
    transaction, the source shown."""
    return ([o.Name for o in doc.Objects], doc.UndoCount, doc.HasPendingTransaction,
            FreeCAD.getActiveTransaction(), doc.Body.ViewObject.Visibility)


@pytest.mark.parametrize("at", MOMENTS.values(), ids=list(MOMENTS))
def test_cancel_at_any_moment_leaves_the_document_as_it_was(doc, monkeypatch, at):
    hold = Hold()
    interrupt_run(monkeypatch, hold, at)
    form = open_panel(doc)
    fill(form, "pso", **SHORT_RUN)
    before, echoed = untouched(doc), len(dock_text("Python console"))
    task_button(OK).click()
    assert wait_until(hold.reached.is_set, 30), form.status.text()
    hold.release_after(0.2)
    task_button(CANCEL).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 2)
    assert wait_until(lambda: not running_workers(), 10)
    process_events(0.5)
    assert untouched(doc) == before
    assert "add_to_document" not in dock_text("Python console")[echoed:]


def test_a_worker_killed_mid_run_leaves_freecad_alive_and_says_so(doc, monkeypatch):
    """SIGKILL to the swarm's second process at iteration 10 of a PSO run from the panel: the run
    ends in FreeCAD's process with the same points as a one-process run, its note is in the
    document and in the Report view."""
    import os
    import signal

    from cmmsampling.runtime import parallel

    interrupt_run(monkeypatch, lambda: os.kill(parallel.shared_worker()[0].pid, signal.SIGKILL), at=10)
    form = open_panel(doc)
    fill(form, "pso", **SHORT_RUN)
    reported = len(dock_text("Report view"))
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 120), form.status.text()
    import __main__

    import cmmsampling

    points, run = groups(doc)[-1].Group[0], __main__.result
    alone = cmmsampling.sample(doc.Body.Shape.Faces[0], 25, "pso", population=8, iterations=20, seed=1, grid=30,
                               edge_offset=run.settings["edge_offset"], min_spacing=run.settings["min_spacing"],
                               workers=1)
    np.testing.assert_array_equal(run.uv, alone.uv)
    np.testing.assert_allclose(np.array([tuple(p) for p in points.Points]), alone.points, atol=1e-9)
    assert any("killed by signal 9" in note for note in points.Notes), points.Notes
    assert wait_until(lambda: "the second process was killed by signal 9" in dock_text("Report view")[reported:], 2)


def test_a_fault_inside_a_run_is_shown_and_changes_nothing(doc, monkeypatch):
    interrupt_run(monkeypatch, fault_in_the_run, at=5)
    form = open_panel(doc)
    fill(form, "pso", **SHORT_RUN)
    before = untouched(doc)
    reported = len(dock_text("Report view"))
    task_button(OK).click()
    message = "SimulatedFault: simulated fault in iteration 5"
    assert wait_until(lambda: message in form.status.text(), 30), form.status.text()
    assert untouched(doc) == before and not running_workers()
    assert task_button(OK).isEnabled() and form.n.isEnabled()
    assert wait_until(lambda: "simulated fault in iteration 5" in dock_text("Report view")[reported:], 2)
    assert "Traceback (most recent call last)" in dock_text("Report view")[reported:], "an unexpected fault keeps its traceback"

    monkeypatch.undo()
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 60), form.status.text()
    assert len(groups(doc)) == 1


def test_a_fault_while_adding_the_result_rolls_it_back_and_is_shown(doc, monkeypatch):
    monkeypatch.setattr(document.results, "write_deviation_report", fault_in_the_report)
    form = open_panel(doc)
    fill(form, "pso", **SHORT_RUN)
    before = untouched(doc)
    task_button(OK).click()
    message = "The result could not be added: simulated fault in the report"
    assert wait_until(lambda: message in form.status.text(), 60), form.status.text()
    assert untouched(doc) == before
    assert FreeCADGui.Control.activeDialog() and task_button(OK).isEnabled()
    task_button(CANCEL).click()


def test_the_source_deleted_during_a_run_is_reported_and_nothing_added(doc, monkeypatch):
    hold = Hold()
    interrupt_run(monkeypatch, hold, at=5)
    form = open_panel(doc)
    fill(form, "pso", **SHORT_RUN)
    task_button(OK).click()
    assert wait_until(hold.reached.is_set, 30), form.status.text()
    doc.removeObject("Body")
    doc.recompute()
    hold.released.set()
    message = "Body.Face1 is not in the document any more: pick another face and sample again."
    assert wait_until(lambda: message in form.status.text(), 30), form.status.text()
    assert [o.Name for o in doc.Objects] == [] and not doc.HasPendingTransaction
    form.status.clear()
    task_button(OK).click()
    assert form.status.text() == message and not running_workers()
    task_button(CANCEL).click()


def focus_tree():
    """Give the keyboard focus to the document tree, as a user does who selects there before
    Ctrl+C. Std_Copy first offers "Copy" to the active view when the focus lies inside it: with the
    focus left in a report spreadsheet's table by an earlier test, it copied cells and no
    dependency dialog opened (reproduced on FreeCAD 0.20)."""
    [tree] = [w for w in widgets() if w.inherits("Gui::TreeWidget") and w.isVisible()]
    tree.setFocus()
    process_events(0.1)


def focus_widget_class():
    widget = QtGui.QApplication.focusWidget()
    return widget.metaObject().className() if widget is not None else None


@pytest.fixture
def clipboard():
    """Empty the clipboard after the test: while this FreeCAD owns it, a FreeCAD started by a
    later test waits for it on every clipboard query, seconds each."""
    yield QtGui.QApplication.clipboard()
    QtGui.QApplication.clipboard().clear()


def test_copy_and_paste_of_a_group_gives_a_consistent_copy(doc, clipboard):
    group = document.add_to_document(short_result(doc), doc, source=(doc.Body, "Face1"))
    process_events(0.2)
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(group)
    assert [o.Name for o in FreeCADGui.Selection.getSelection()] == [group.Name]
    assert FreeCADGui.Command.get("Std_Copy").isActive()
    focus_tree()
    asked = answer_dialog(lambda: FreeCADGui.runCommand("Std_Copy"), "OK")
    assert "dependencies" in asked, f"no dependency dialog; focus in {focus_widget_class()}"
    FreeCADGui.Selection.clearSelection()
    names, undo = [o.Name for o in doc.Objects], doc.UndoCount
    FreeCADGui.runCommand("Std_Paste")
    process_events(0.2)
    doc.recompute()
    pasted = [o for o in doc.Objects if o.Name not in names]
    [copy] = [o for o in pasted if o.TypeId == "App::DocumentObjectGroup"]
    [body] = [o for o in pasted if o.TypeId == "Part::Feature"]
    points, surface, report = copy.Group
    assert len(pasted) == 5 and copy.Label == "Sampling Body Face1 (pso)001"
    assert points.Source == (body, ["Face1"])
    assert points.Substitute == surface and points.Report == report
    assert points.Status == "up to date" and all("Invalid" not in o.State for o in pasted)
    assert drawn(points) == 3 and drawn(surface) == 4
    original = group.Group[0]
    assert np.array_equal(points.Proxy.point_set(points).uv, original.Proxy.point_set(original).uv)
    assert report.get("max_mm") == pytest.approx(original.MaxDeviation.Value, rel=1e-9)
    assert doc.UndoCount == undo + 1
    FreeCADGui.runCommand("Std_Undo")
    process_events(0.1)
    assert [o.Name for o in doc.Objects] == names
