"""Compare strategies (task panel, background study, report, cancel) and the export options dialog
(frame, probe radius, order) in the real FreeCAD GUI."""
import __main__
import gc
import importlib.util
import os
import threading
import weakref

import FreeCAD
import FreeCADGui
import numpy as np
import Part
import pytest
from PySide import QtCore, QtGui

import cmmsampling
from cmmsampling import document
from cmmsampling.document import export_defaults, settings
from cmmsampling.gui.panels import compare as compare_panel
from cmmsampling.gui import commands, export_options
from cmmsampling.geometry.probe_path import path_length
from cmmsampling.study import html as report_html

from support.toy_strategy import TOY

from .helpers import (
    Hold, child, dock_text, handle_dialog, main_window, open_panel, process_events, task_button, task_form,
    wait_until, widgets,
)

OK, CANCEL = QtGui.QDialogButtonBox.Ok, QtGui.QDialogButtonBox.Cancel
# A comparison small enough for a shared two-core machine: 2 N x 2 strategies, 6 steps.
TINY = {"ns": "16, 25", "strategies": "uniform_parametric, pso", "seeds": 1, "iterations": 20,
        "population": 6, "grid": 20, "edge_offset": -0.5, "min_spacing": 2.0}
TINY_CALL = ("cmmsampling.compare(face, ns=(16, 25), strategies=('uniform_parametric', 'pso'), "
             "seeds=(0,), options={'pso': {'iterations': 20, 'population': 6}}, grid=20, edge_offset=1.5, "
             "min_spacing=2.0)")


@pytest.fixture
def command(workbench):
    """The Compare strategies command, with a toolbar button (whose status tip says why it is
    inactive): registered and put on a toolbar of its own here until the workbench does both."""
    commands.register()
    name = commands.CompareStrategies.NAME
    if not FreeCADGui.Command.get(name).getAction():
        workbench.appendToolbar("CMM Sampling comparison", [name])
        workbench.reloadActive()
    return name


@pytest.fixture
def opened(monkeypatch):
    """The reports the panel opens (paths), instead of opening them."""
    paths = []

    def record(path, title):
        paths.append(path)
        return True

    monkeypatch.setattr(compare_panel, "open_report", record)
    return paths


class UrlRecorder(QtCore.QObject):
    """A URL handler for QDesktopServices: keeps the local paths it is asked to open."""

    def __init__(self):
        super().__init__()
        self.paths = []

    @QtCore.Slot(QtCore.QUrl)
    def record(self, url):
        self.paths.append(url.toLocalFile())


@pytest.fixture
def browser():
    """The files the workbench asks the system to open in its browser (Qt's handler of file URLs
    takes them instead of the browser)."""
    recorder = UrlRecorder()
    QtGui.QDesktopServices.setUrlHandler("file", recorder, "record")
    yield recorder.paths
    QtGui.QDesktopServices.unsetUrlHandler("file")


def hold_study_at(monkeypatch, step):
    """Make the panel's next study stop in its worker thread when ``step`` steps are done (after
    the panel has seen that), until the returned Hold is released."""
    hold = Hold(limit_s=30.0)
    run = compare_panel.compare

    def held(face, progress=None, **arguments):
        def watched(done, total, message):
            if done == step and not hold.reached.is_set():
                progress(done, total, message)
                hold()
            return progress(done, total, message)

        hold.study = run(face, progress=watched, **arguments)
        return hold.study

    monkeypatch.setattr(compare_panel, "compare", held)
    return hold


def compare_form():
    """The Compare strategies panel's form while it is open, else None (looked up as
    :func:`helpers.task_form` does, not with the main window's findChild)."""
    return next((w for w in widgets() if w.objectName() == "CompareStrategies"), None)


def start_held_study(doc, monkeypatch, folder):
    """Open Compare strategies on the tiny study writing to ``folder``, press OK and wait until
    the study is held after 3 steps. Returns (hold, form)."""
    hold = hold_study_at(monkeypatch, 3)
    form = open_compare(doc)
    fill(form, folder=folder, **TINY)
    task_button(OK).click()
    assert wait_until(hold.reached.is_set, 60), form.status.text()
    return hold, form


def open_compare(doc, face="Face1"):
    """Select the Body's face, run Compare strategies, return the panel's form."""
    assert wait_until(lambda: compare_form() is None, 5), "the last panel's form is still there"
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(doc.Body, face)
    FreeCADGui.runCommand(commands.CompareStrategies.NAME)
    assert wait_until(lambda: compare_form() is not None, 5), commands.CompareStrategies().reason()
    return compare_form()


def items(form):
    return [form.strategies.item(i) for i in range(form.strategies.count())]


def checked(form):
    return [item.data(QtCore.Qt.UserRole) for item in items(form) if item.checkState() == QtCore.Qt.Checked]


def fill(form, folder=None, **values):
    """Type the N list, check the named strategies, set the spin boxes and the folder."""
    if "ns" in values:
        form.ns.setText(values.pop("ns"))
    if "strategies" in values:
        chosen = values.pop("strategies").split(", ")
        for item in items(form):
            item.setCheckState(QtCore.Qt.Checked if item.data(QtCore.Qt.UserRole) in chosen else QtCore.Qt.Unchecked)
    for name, value in values.items():
        (getattr(form, name, None) or child(form, name)).setValue(value)
    if folder is not None:
        form.folder.setText(folder)


def test_compare_is_active_for_one_face_and_says_why_otherwise(doc, command):
    action = FreeCADGui.Command.get(command)
    assert not action.isActive()
    assert action.getAction()[0].statusTip().startswith("Nothing is selected")
    box = doc.addObject("Part::Feature", "Box")
    box.Shape = Part.makeBox(10, 10, 10, FreeCAD.Vector(150, 0, 0))
    doc.recompute()
    FreeCADGui.Selection.addSelection(box)
    assert not action.isActive()
    assert "Box has 6 faces: click the one to sample" in action.getAction()[0].statusTip()
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(doc.Body, "Face1")
    assert action.isActive()
    assert action.getAction()[0].statusTip() == commands.CompareStrategies.TIP
    assert os.path.isfile(action.getInfo()["pixmap"])


def test_a_closed_panel_leaves_no_panel_and_no_thread_behind(doc, command, opened, tmp_path, monkeypatch):
    panels = []

    class Recorded(compare_panel.CompareTaskPanel):
        def __init__(self, source):
            super().__init__(source)
            panels.append(weakref.ref(self))

    monkeypatch.setattr(compare_panel, "CompareTaskPanel", Recorded)
    form = open_compare(doc)
    fill(form, folder=str(tmp_path), **TINY)
    task_button(OK).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 60), form.status.text()
    open_compare(doc)
    task_button(CANCEL).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 2)
    del form
    process_events(0.3)
    gc.collect()
    assert len(panels) == 2 and [panel() for panel in panels] == [None, None]
    assert not [t for t in threading.enumerate() if t.name == "cmmsampling-compare" and t.is_alive()]


def test_panel_defaults_are_the_papers_study_and_options_follow_the_strategies(doc, command, tmp_path,
                                                                              artifacts):
    form = open_compare(doc)
    process_events(0.2)
    form.grab().save(os.path.join(artifacts, "compare_form.png"))
    assert form.faceLabel.text() == "Body.Face1"
    assert form.ns.text() == "25, 36, 49, 64, 81, 100, 121, 144"
    assert checked(form) == list(cmmsampling.self_contained())
    assert [item.text() for item in items(form)][-2:] == ["PSO (paper)", "optimal (this project)"]   # no keys
    assert [form.seeds.value(), form.iterations.value(), form.population.value(), form.grid.value()] == [
        5, 3000, 25, 60]
    assert child(form, "edge_offset").text() == "auto" and child(form, "min_spacing").text() == "auto"
    assert form.folder.text() == os.path.join(os.path.expanduser("~"), f"{doc.Name}_comparison")
    assert all(item.toolTip() for item in items(form))
    assert form.seeds.isEnabled() and form.iterations.isEnabled()
    fill(form, strategies="uniform_parametric, optimal")
    assert not form.seeds.isEnabled() and not form.iterations.isEnabled() and not form.population.isEnabled()
    assert task_button(OK).text() == "Compare"
    task_button(CANCEL).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 2)
    doc.saveAs(str(tmp_path / "bracket.FCStd"))
    assert compare_panel.default_folder(doc) == str(tmp_path / "bracket_comparison")


@pytest.fixture
def toy():
    """The toy strategy (tests/support/toy_strategy.py, one module and one record) registered for one test."""
    cmmsampling.register_strategy(TOY)
    yield TOY
    cmmsampling.unregister_strategy(TOY.name)


def test_a_registered_strategy_is_in_both_panels_lists(doc, command, toy):
    form = open_panel(doc)
    assert [form.strategy.itemData(i) for i in range(form.strategy.count())][-1] == "mirrored_halton"
    form.strategy.setCurrentIndex(form.strategy.count() - 1)
    assert form.strategyInfo.text() == TOY.description and not form.psoGroup.isEnabled()
    task_button(CANCEL).click()
    assert wait_until(lambda: task_form() is None, 5)
    form = open_compare(doc)
    assert checked(form)[-1] == "mirrored_halton" and items(form)[-1].toolTip() == TOY.description
    fill(form, strategies="uniform_parametric, mirrored_halton")
    assert form.seeds.isEnabled() and not form.iterations.isEnabled()
    task_button(CANCEL).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 2)


def test_tiny_comparison_runs_in_the_background_and_opens_its_report(doc, command, opened, tmp_path,
                                                                     artifacts, monkeypatch):
    folder = str(tmp_path / "comparison")
    names, undo = [o.Name for o in doc.Objects], doc.UndoCount
    written, write_figures = [], report_html.write_figures
    monkeypatch.setattr(report_html, "write_figures",
                        lambda study, where: written.append(where) or write_figures(study, where))
    hold, form = start_held_study(doc, monkeypatch, folder)
    assert wait_until(lambda: form.progress.value() == 3, 2), form.status.text()
    assert form.progress.maximum() == 6 and form.progress.text() == "3 / 6 steps"
    assert form.status.text() == "N = 25: uniform parametric (seed 0)"
    assert not task_button(OK).isEnabled() and not form.ns.isEnabled() and not form.strategies.isEnabled()
    main_window().grab().save(os.path.join(artifacts, "compare_running.png"))
    form.grab().save(os.path.join(artifacts, "compare_running_form.png"))
    hold.released.set()

    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 120), form.status.text()
    report = os.path.join(folder, "report.html")
    assert opened == [report]
    for name in ("report.html", "max_vs_n.png", "substitutes.png", "deviation_maps.png"):
        assert os.path.getsize(os.path.join(folder, name)) > 1000, name
    study = __main__.study
    assert study is hold.study, "the echoed compare() call computed the study again"
    assert not study.cancelled and len(study.rows) == 4 and sorted(study.bounds) == [16, 25]
    console = dock_text("Python console")
    assert f"study = {TINY_CALL}  # ran in the task panel" in console
    assert f"report = cmmsampling.write_report(study, {folder!r})\n" in console + "\n"
    assert __main__.report == report and written == [folder], "the echoed write_report() wrote it again"
    assert f"face = App.getDocument({doc.Name!r}).getObject('Body').getSubObject('Face1')" in console
    assert [o.Name for o in doc.Objects] == names and doc.UndoCount == undo
    assert compare_panel.load_values() == TINY


def test_cancel_midway_keeps_the_finished_runs_in_a_partial_report(doc, command, opened, tmp_path,
                                                                   artifacts, monkeypatch):
    folder = str(tmp_path / "partial")
    hold, form = start_held_study(doc, monkeypatch, folder)
    task_button(CANCEL).click()
    assert FreeCADGui.Control.activeDialog() and form.status.text().startswith("Cancelling")
    hold.released.set()

    assert wait_until(lambda: task_button(OK).isEnabled(), 60), form.status.text()
    assert FreeCADGui.Control.activeDialog()
    report = os.path.join(folder, "report.html")
    assert form.status.text() == ("Cancelled after 3 of 6 steps. The partial report (2 runs) is open; "
                                  "it is report.html in the report folder.")
    assert opened == [report]
    with open(report, encoding="utf-8") as page:
        assert "The study was cancelled: only the runs completed are shown." in page.read()
    assert wait_until(lambda: "Strategy comparison, 2 runs in " in dock_text("Report view"), 2)
    assert report in dock_text("Report view")
    form.grab().save(os.path.join(artifacts, "compare_cancelled_form.png"))
    study = __main__.study
    assert study is hold.study and study.cancelled and [(r.strategy, r.n) for r in study.rows] == [
        ("uniform_parametric", 16), ("pso", 16)]
    assert f"study = {TINY_CALL}  # ran in the task panel, cancelled after 2 runs (a replay runs it " \
        "whole)" in dock_text("Python console")
    task_button(CANCEL).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 2)


def test_a_face_deleted_during_the_study_is_still_reported(doc, command, opened, tmp_path, monkeypatch):
    __main__.__dict__.pop("study", None)
    hold, form = start_held_study(doc, monkeypatch, str(tmp_path))
    doc.removeObject("Body")
    doc.recompute()
    hold.released.set()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 60), form.status.text()
    assert opened == [os.path.join(str(tmp_path), "report.html")] and "study" not in __main__.__dict__
    console = dock_text("Python console")
    assert f"# face = App.getDocument({doc.Name!r}).getObject('Body').getSubObject('Face1')  # deleted " \
        "since" in console
    assert f"# study = {TINY_CALL}  # ran in the task panel" in console


def test_bad_settings_are_refused_with_what_to_change(doc, command, opened, tmp_path):
    form = open_compare(doc)
    fill(form, folder=str(tmp_path / "report"), **dict(TINY, ns="16, twenty"))
    task_button(OK).click()
    assert form.status.text().startswith("The point counts N must be whole numbers")
    assert task_button(OK).isEnabled() and form.ns.isEnabled() and not os.path.exists(tmp_path / "report")
    (tmp_path / "a file").write_text("")
    fill(form, ns="16, 25", folder=str(tmp_path / "a file" / "report"))
    task_button(OK).click()
    assert form.status.text().startswith("The report folder cannot be made: ")
    fill(form, ns="3, 16", folder=str(tmp_path / "report"))
    task_button(OK).click()
    assert wait_until(lambda: form.status.text().startswith("Not run: "), 10), form.status.text()
    assert "n must be at least 4, got 3" in form.status.text() and task_button(OK).isEnabled()
    assert opened == [] and os.listdir(tmp_path / "report") == []
    task_button(CANCEL).click()


def test_a_report_that_cannot_be_written_keeps_the_study_in_the_console(doc, command, opened, tmp_path,
                                                                       monkeypatch):
    def refuse(study, folder):
        raise PermissionError(f"cannot write into {folder}")

    monkeypatch.setattr(compare_panel, "write_report", refuse)
    __main__.__dict__.pop("study", None)
    form = open_compare(doc)
    fill(form, folder=str(tmp_path), **TINY)
    task_button(OK).click()
    assert wait_until(lambda: "could not be written" in form.status.text(), 60), form.status.text()
    assert form.status.text().startswith(
        f"The report could not be written (PermissionError: cannot write into {tmp_path}). The "
        "study is kept in the Python console as study")
    assert len(__main__.study.rows) == 4 and opened == [] and FreeCADGui.Control.activeDialog()
    task_button(CANCEL).click()


def browser_views():
    area = main_window().findChild(QtGui.QMdiArea)
    return [w for w in area.subWindowList() if w.widget().metaObject().className() == "WebGui::BrowserView"]


def report_page(folder):
    page = folder / "report.html"
    page.write_text("<html><head><title>Report</title></head><body>Table 1</body></html>")
    return str(page)


def test_the_report_opens_in_freecads_web_view_else_in_the_system_browser(workbench, tmp_path, browser):
    """FreeCAD 0.20 has a web view (the Web module's GUI); FreeCAD 1.0 and 1.1 have none."""
    page = report_page(tmp_path)
    if importlib.util.find_spec("WebGui") is None:
        assert compare_panel.open_report(page, "Compare strategies: Body.Face1") and browser == [page]
        return
    before = browser_views()
    assert compare_panel.open_report(page, "Compare strategies: Body.Face1")
    assert wait_until(lambda: len(browser_views()) == len(before) + 1, 10) and browser == []
    opened_view = next(w for w in browser_views() if w not in before)
    assert opened_view.windowTitle().startswith("Compare strategies: Body.Face1"), opened_view.windowTitle()
    opened_view.close()
    process_events(0.2)


def test_the_system_browser_gets_the_report(workbench, tmp_path, browser):
    page = report_page(tmp_path)
    assert compare_panel.open_in_browser(page) and browser == [page]


def test_without_a_browser_the_report_opens_in_a_tab_of_freecad(workbench, tmp_path, monkeypatch):
    """No program to open web pages on the PATH (as in a bare system): Qt finds no launcher."""
    page = report_page(tmp_path)
    monkeypatch.setenv("PATH", str(tmp_path))
    for name in ("BROWSER", "DEFAULT_BROWSER"):
        monkeypatch.delenv(name, raising=False)
    before = dock_text("Report view")
    assert not compare_panel.open_in_browser(page)
    area = main_window().findChild(QtGui.QMdiArea)
    windows = area.subWindowList()
    if importlib.util.find_spec("WebGui") is None:   # FreeCAD 1.0 and 1.1: the whole way
        assert compare_panel.open_report(page, "Compare strategies: Body.Face1")
    else:
        assert compare_panel.show_in_tab(page, "Compare strategies: Body.Face1")
    [tab] = [w for w in area.subWindowList() if w not in windows]
    assert tab.windowTitle() == "Compare strategies: Body.Face1" and "Table 1" in tab.widget().toPlainText()
    assert wait_until(lambda: f"no web browser could be started; the report {page} is shown in a tab" in
                      dock_text("Report view")[len(before):], 2)
    tab.close()


def test_open_comparison_report_shows_a_report_again(workbench, tmp_path, monkeypatch):
    """From the menu, where FreeCAD 1.0 without a browser could not show a report once closed."""
    page = report_page(tmp_path)
    asked, shown = [], []
    monkeypatch.setattr(QtGui.QFileDialog, "getOpenFileName",
                        lambda parent, title, start, filters: asked.append((title, start, filters)) or (page, filters))
    monkeypatch.setattr(compare_panel, "open_report", lambda path, title: shown.append((path, title)) or True)
    menus = [m for m in main_window().findChildren(QtGui.QMenu) if m.title() == "CMM Sampling"]
    assert any("Open comparison report..." in [a.text() for a in m.actions()] for m in menus)
    FreeCADGui.runCommand(commands.OpenComparisonReport.NAME)
    assert asked and asked[0][2] == "HTML report (*.html)" and asked[0][1].endswith("report.html")
    assert shown == [(page, f"Compare strategies: {tmp_path.name}")]


def run_dialog(action, handle, timeout_s=10):
    """Run action(), which opens the export options dialog modally, answered by handle(dialog)."""
    return handle_dialog(export_options.ExportOptionsDialog, action, handle, timeout_s)


def probe_points(doc):
    """Probe points of a Halton set (25 points, in no short order) on the Body's face."""
    result = cmmsampling.sample(doc.Body.Shape.Faces[0], 25, "halton")
    return document.add_to_document(result, doc, source=(doc.Body, "Face1")).Group[0]


def coordinate_systems(doc):
    """A datum coordinate system inside a moved PartDesign body, and a placement object."""
    body = doc.addObject("PartDesign::Body", "PartBody")
    body.Placement = FreeCAD.Placement(FreeCAD.Vector(10, -20, 5), FreeCAD.Rotation(30, 0, 0))
    lcs = body.newObject("PartDesign::CoordinateSystem", "LCS")
    lcs.Label = "Measurement frame"
    lcs.Placement = FreeCAD.Placement(FreeCAD.Vector(50, 40, 3),
                                      FreeCAD.Rotation(FreeCAD.Vector(1, 1, 0), 40))
    doc.addObject("App::Placement", "Fixture")
    doc.recompute()
    return lcs


def test_export_options_write_ball_centres_in_a_local_frame_along_a_short_path(doc, tmp_path, artifacts):
    points = probe_points(doc)
    lcs = coordinate_systems(doc)
    seen = {}

    def choose(dialog):
        seen["title"] = dialog.windowTitle()
        seen["frames"] = [dialog.frame.itemText(i) for i in range(dialog.frame.count())]
        seen["tip"] = dialog.frame.itemData(1, QtCore.Qt.ToolTipRole)
        dialog.frame.setCurrentIndex(dialog.frame.findText("Measurement frame"))
        dialog.probe_radius.setValue(1.5)
        dialog.order.setCurrentIndex(dialog.order.findData("short_path"))
        dialog.grab().save(os.path.join(artifacts, "export_options.png"))
        dialog.accept()

    options = run_dialog(lambda: export_options.ask_export_options(points), choose)
    assert seen["title"] == "Export options: Sampling Body Face1 (halton)"
    assert seen["frames"] == ["Global (document)", "Measurement frame", "Fixture"]
    assert "PartDesign::CoordinateSystem" in seen["tip"] and "origin (" in seen["tip"]
    assert options == {"frame": lcs, "probe_radius": 1.5, "order": "short_path"}

    target = str(tmp_path / "points.csv")
    call = export_defaults.export_call(points, target, options)
    assert call.endswith(f", frame=App.getDocument({doc.Name!r}).getObject('LCS'), probe_radius=1.5, "
                         "order='short_path')")
    FreeCADGui.doCommand("import cmmsampling")
    FreeCADGui.doCommand(call)
    report = __main__.report
    export_options.show_export_report(report)
    line = main_window().statusBar().currentMessage()
    assert line.startswith(f"Wrote 25 points to {target} (CSV, local frame, ball centres, probe radius 1.5 mm).")
    assert f"({report.length_before:.1f} mm in the optimised order: " in line and report.saving > 0

    written = cmmsampling.read_points(target)
    source = points.Proxy.point_set(points)
    placement = lcs.getGlobalPlacement()
    assert not placement.isIdentity() and placement != lcs.Placement
    inverse = placement.inverse()
    rotation = inverse.Rotation
    where = {label: i for i, label in enumerate(source.labels)}
    order = [where[label] for label in written.labels]
    assert sorted(order) == list(range(25)) and order != list(range(25))
    centres = source.points[order] + 1.5 * source.normals[order]
    expected = np.array([tuple(inverse.multVec(FreeCAD.Vector(*p))) for p in centres])
    normals = np.array([tuple(rotation.multVec(FreeCAD.Vector(*n))) for n in source.normals[order]])
    assert np.abs(written.points - expected).max() < 1e-6
    assert np.abs(written.normals - normals).max() < 1e-8
    assert written.metadata["frame"] == "local" and written.metadata["frame_name"] == "Measurement frame"
    assert written.metadata["probe_radius_mm"] == 1.5 and written.metadata["order"] == "short_path"
    assert abs(path_length(written.points) - report.length_after) < 1e-5


def test_export_options_persist_and_cancel_returns_none(doc):
    points = probe_points(doc)
    coordinate_systems(doc)
    assert export_defaults.export_keywords(
        {"frame": None, "probe_radius": 0.0, "order": "as_optimised"}) == ""
    settings.save({"ExportFrame": "Elsewhere.FCStd|LCS", "ExportProbeRadius": 2.0, "ExportOrder": "short_path"})
    seen = []

    def look(dialog):
        seen.append((dialog.frame.currentText(), dialog.probe_radius.value(), dialog.order.currentData(),
                     dialog.origin.text()))
        dialog.reject()

    assert run_dialog(lambda: export_options.ask_export_options(points), look) is None
    assert seen[-1][:3] == ("Global (document)", 2.0, "short_path"), "another document's frame is not reused"
    settings.save({"ExportFrame": export_defaults.frame_setting(doc, "LCS")})
    assert run_dialog(lambda: export_options.ask_export_options(points), look) is None
    assert seen[-1] == ("Measurement frame", 2.0, "short_path", "Starting from the frame of this document's last "
                        "export, the radius of the last export and the order of the last export: what File > "
                        "Export writes.")
    seen.clear()
    doc.removeObject("LCS")
    doc.recompute()

    def defaults(dialog):
        seen.append((dialog.frame.currentText(), dialog.probe_radius.text()))
        dialog.probe_radius.setValue(0.0)
        dialog.accept()

    options = run_dialog(lambda: export_options.ask_export_options(points), defaults)
    assert seen[0] == ("Global (document)", "2.000 mm")
    assert options == {"frame": None, "probe_radius": 0.0, "order": "short_path"}
    assert settings.load(export_defaults.DEFAULTS) == {
        "ExportFrame": "", "ExportProbeRadius": 0.0, "ExportOrder": "short_path"}


def test_the_panel_estimates_the_studys_time(doc, command):
    form = open_compare(doc)
    line = child(form, "timeInfo")
    # the estimate times each strategy once per N in a background thread: seconds on a quiet machine,
    # a minute beside other test suites on 2 cores
    assert wait_until(lambda: "runs; at least about" in line.text(), 120), line.text()
    assert line.text().startswith("104 runs;") and "optimal (this project) runs, which go on" in line.text()
    fill(form, **TINY)
    assert wait_until(lambda: line.text().startswith("4 runs; at least about "), 120), line.text()
    assert line.text().endswith("plus the local bounds")
    task_button(CANCEL).click()
    assert wait_until(lambda: not FreeCADGui.Control.activeDialog(), 2)
