"""The workbench's commands. Each is active only when it can act; otherwise its status tip and
tooltip say why. What they change in the document goes through the console API, echoed in the
Python console (``Gui.doCommand``)."""
import __main__
import importlib
import os
import re

import FreeCAD
import FreeCADGui
from FreeCAD import Qt
from PySide import QtCore, QtGui

from .. import document
from ..document import settings
from ..document.export_defaults import export_call
from ..document.object_types import is_part_plan, source_face
from . import icon
from .export_options import ask_export_options, say, show_export_report
from .selection import SelectionError, selected_face, selected_part_faces

# The workbench's setting that keeps the folder the last export wrote to (where the next export
# of an unsaved document starts).
EXPORT_FOLDER = "ExportFolder"


def show_reason(name, reason, tip):
    """Put ``reason`` (or, when None, the normal ``tip``) in the command's status tip and tooltip."""
    text = tip if reason is None else reason
    for action in FreeCADGui.Command.get(name).getAction():
        if action.statusTip() != text:
            action.setStatusTip(text)
            action.setToolTip(text)


def warn(title, text):
    """A message box on the main window."""
    QtGui.QMessageBox.warning(FreeCADGui.getMainWindow(), title, text)


class GuardedCommand:
    """A command that acts only when :meth:`reason` is None: while it cannot act, its status tip
    and tooltip say why, and activating it anyway shows that in a message box titled TITLE.
    Subclasses give NAME, TITLE, MENU, ICON, TIP, :meth:`reason` and :meth:`act`."""

    NAME = TITLE = MENU = ICON = TIP = ""

    def GetResources(self):
        return {"Pixmap": icon(self.ICON), "MenuText": self.MENU, "ToolTip": self.TIP}

    def reason(self):
        """Why the command cannot act now, or None."""
        raise NotImplementedError

    def act(self):
        """What the command does once :meth:`reason` is None."""
        raise NotImplementedError

    def IsActive(self):
        reason = self.reason()
        show_reason(self.NAME, reason, self.TIP)
        return reason is None

    def Activated(self):
        reason = self.reason()
        if reason is not None:
            warn(self.TITLE, reason)
            return
        self.act()


class PanelCommand(GuardedCommand):
    """A command that opens a task panel for what is selected in an open document: subclasses
    give :meth:`selected` (the selection -> the panel's source, or SelectionError saying what to
    select) and PANEL, (module of cmmsampling.gui.panels, class) of the panel."""

    PANEL = ("", "")

    def selected(self, selection):
        """The panel's source for a selection (Gui.Selection.getSelectionEx())."""
        raise NotImplementedError

    def panel(self, source):
        """The task panel for a source: PANEL's class, imported when first opened."""
        module, name = self.PANEL
        return getattr(importlib.import_module(f".panels.{module}", __package__), name)(source)

    def reason(self):
        """Why the command cannot act now, or None."""
        if FreeCAD.ActiveDocument is None:
            return "Open a document with a part first."
        if FreeCADGui.Control.activeDialog():
            return "Close the open task panel first."
        try:
            self.selected(FreeCADGui.Selection.getSelectionEx())
        except SelectionError as exc:
            return str(exc)
        return None

    def act(self):
        FreeCADGui.Control.showDialog(self.panel(self.selected(FreeCADGui.Selection.getSelectionEx())))


class FaceCommand(PanelCommand):
    """A command that opens a task panel for the one selected face, (obj, "FaceK")."""

    def selected(self, selection):
        return selected_face(selection)


class SampleFace(FaceCommand):
    """*Sample face...*: open the task panel for the one selected face."""

    NAME = "CMMSampling_SampleFace"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_SampleFace", "Sample face")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_SampleFace", "Sample face...")
    ICON = "SampleFace.svg"
    PANEL = ("sample_face", "SampleFaceTaskPanel")
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_SampleFace",
        "Place CMM probe points on the selected face with a sampling strategy, fit the "
        "substitute surface and report its deviation (mm)")


class Reevaluate(GuardedCommand):
    """*Re-evaluate*: measure the selected probe points again on their (changed) source face."""

    NAME = "CMMSampling_Reevaluate"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_Reevaluate", "Re-evaluate")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_Reevaluate", "Re-evaluate")
    ICON = "Reevaluate.svg"
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_Reevaluate",
        "Project the selected probe points (same u, v) onto their source face as it is now, "
        "refit the substitute surface and update the deviation, without a new optimisation")

    def reason(self):
        """Why the command cannot act now, or None."""
        points = selected_probe_points()
        if not points:
            return "Select probe points or their Sampling group to re-evaluate them."
        problems = []
        for obj in points:
            face, why = source_face(obj)
            if face is None:
                problems.append(f"{obj.Label} cannot be re-evaluated: {why}.")
        return " ".join(problems) if len(problems) == len(points) else None

    def act(self):
        FreeCADGui.doCommand("import cmmsampling.document")
        for points in selected_probe_points():
            if source_face(points)[0] is None:
                continue
            before = points.MaxDeviation.Value
            try:
                FreeCADGui.doCommand(
                    f"cmmsampling.document.reevaluate(App.getDocument({points.Document.Name!r})"
                    f".getObject({points.Name!r}))")
            except Exception as exc:
                warn("Re-evaluate", f"{points.Label}: {exc}")
                continue
            say(f"Re-evaluated {points.SourceName or points.Label}: maximum deviation "
                f"{points.MaxDeviation.Value:.4f} mm (was {before:.4f} mm), {points.Status}.")


class ExportProbePoints(GuardedCommand):
    """*Export probe points...*: write the selected probe points for the CMM (DMIS, XYZ or CSV)."""

    NAME = "CMMSampling_Export"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_Export", "Export probe points")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_Export", "Export probe points...")
    ICON = "Export.svg"
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_Export",
        "Write the selected probe points with their approach vectors for the CMM: "
        "DMIS input program, PC-DMIS XYZIJK text or CSV")

    def reason(self):
        """Why the command cannot act now, or None."""
        return one_source_reason("to export", "select one (or their part plan's group) to export")

    def act(self):
        [points] = selected_export_sources()
        path = choose_export_path(points)
        if not path:
            return
        options = ask_export_options(points)
        if options is None:
            return
        report = run_echoed_export(points, path, options)
        if report is not None:
            show_export_report(report)


class InspectMeasured(GuardedCommand):
    """*Inspect measured points...*: read the CMM's measured points of the selected probe points
    (or part plan), align them to the CAD model, judge them against a profile tolerance and add
    the coloured points and the inspection report to the document."""

    NAME = "CMMSampling_Inspect"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_Inspect", "Inspect measured points")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_Inspect", "Inspect measured points...")
    ICON = "Inspect.svg"
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_Inspect",
        "Read the points the CMM measured for the selected probe points (or part plan), align them to the "
        "CAD model (best fit, min-max or none), judge their deviations (mm) against a profile tolerance "
        "and colour them on the part, with an inspection report")

    def reason(self):
        """Why the command cannot act now, or None."""
        return one_source_reason("that were measured", "select the one that was measured")

    def act(self):
        from .handover import handed
        from .inspect_dialog import ask_inspection, inspection_call, report_inspection, run_with_progress, show_busy

        [points] = selected_export_sources()
        arguments = ask_inspection(points)
        if arguments is None:
            return
        judge, add = inspection_call(points, arguments)
        before = getattr(__main__, "inspection", None), getattr(__main__, "group", None)
        show_busy(points)
        try:
            made = run_with_progress(points, arguments)
            if made is None:
                FreeCADGui.getMainWindow().statusBar().showMessage(
                    "Inspection cancelled: nothing was judged or added", 20000)
                return
            FreeCADGui.doCommand("import cmmsampling")
            QtGui.QApplication.setOverrideCursor(QtCore.Qt.WaitCursor)
            with handed("inspect", points, arguments, made):
                FreeCADGui.doCommand(judge)
            inspection = getattr(__main__, "inspection", None)
            if inspection is before[0]:
                raise RuntimeError("The measured points were not inspected: the Report view says why.")
            FreeCADGui.doCommand(add)
            if getattr(__main__, "group", None) is before[1]:
                raise RuntimeError("The inspection was not added to the document: the Report view says why.")
        except Exception as exc:
            FreeCADGui.getMainWindow().statusBar().showMessage(
                f"Not inspected: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", 20000)
            warn(self.TITLE, str(exc))
            return
        finally:
            QtGui.QApplication.restoreOverrideCursor()
        report_inspection(inspection)


class MeasureOnCMM(GuardedCommand):
    """*Measure on CMM...*: measure the selected probe points (or part plan) on a CMM over I++
    DME, then inspect what it measured."""

    NAME = "CMMSampling_Measure"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_Measure", "Measure on CMM")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_Measure", "Measure on CMM...")
    ICON = "MeasureCMM.svg"
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_Measure",
        "Measure the selected probe points (or part plan) on a CMM through its I++ DME server: along the "
        "collision-free path where the points were planned with a probe; the contact points go to a file, "
        "which Inspect measured points then judges")

    def reason(self):
        """Why the command cannot act now, or None."""
        return one_source_reason("to measure", "select the one to measure")

    def act(self):
        from ..cmm.client import MeasurementStopped
        from .handover import handed
        from .measure_dialog import ask_measurement, measurement_call, run_with_progress

        [points] = selected_export_sources()
        request = ask_measurement(points)
        if request is None:
            return
        status = FreeCADGui.getMainWindow().statusBar()
        try:
            run = run_with_progress(points, request)
        except MeasurementStopped as exc:
            status.showMessage(f"Measurement stopped: {str(exc).splitlines()[0]}", 20000)
            warn(self.TITLE, str(exc))
            return
        except Exception as exc:
            status.showMessage(f"Not measured: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", 20000)
            warn(self.TITLE, str(exc))
            return
        FreeCADGui.doCommand("import cmmsampling")
        with handed(request.function, points, request.arguments, run):
            FreeCADGui.doCommand(measurement_call(points, request))
        FreeCAD.Console.PrintMessage(f"cmmsampling: {run}\n")
        status.showMessage(str(run), 20000)
        measured = run.run if request.until_decided else run
        if not measured.labels or measured.cancelled:
            return
        settings.save({"InspectFile": measured.path})
        if request.until_decided:
            add_decided_inspection(points, run)
        else:
            FreeCADGui.runCommand(InspectMeasured.NAME)


def add_decided_inspection(points, run):
    """Add the inspection a run until decided made in the background (DecidedRun.inspection) to
    the document, echoed, and report it; nothing where it was not made (cancelled, or too few
    points)."""
    from .inspect_dialog import report_inspection

    if not run.made or run.inspection is None:
        return
    doc = f"App.getDocument({points.Document.Name!r})"
    FreeCADGui.doCommand("inspection = run.inspection")
    FreeCADGui.doCommand(f"group = cmmsampling.add_inspection_to_document(inspection, {doc}, "
                         f"source={doc}.getObject({points.Name!r}))")
    report_inspection(run.inspection)


class CompareStrategies(FaceCommand):
    """*Compare strategies...*: open the comparison panel for the one selected face."""

    NAME = "CMMSampling_Compare"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_Compare", "Compare strategies")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_Compare", "Compare strategies...")
    ICON = "Compare.svg"
    PANEL = ("compare", "CompareTaskPanel")
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_Compare",
        "Run the sampling strategies over a list of point counts N on the selected face and "
        "write an HTML report: maximum deviation (mm) against N with the local bound, "
        "the paper's figures and tables")


class PlanPart(PanelCommand):
    """*Plan part...*: open the plan panel for the selected faces, or every face of a selected part."""

    NAME = "CMMSampling_PlanPart"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_PlanPart", "Plan part")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_PlanPart", "Plan part...")
    ICON = "PlanPart.svg"
    PANEL = ("plan_part", "PlanPartTaskPanel")
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_PlanPart",
        "Place probe points on several faces of a part (the selected faces, or all faces of a part "
        "selected in the tree): the fewest points that meet a tolerance on each face, or a total of "
        "points shared out; one group per face and a plan report")

    def selected(self, selection):
        return selected_part_faces(selection)


def run_echoed_export(points, path, options):
    """Write the file by running the echoed call ``report = cmmsampling.export(...)`` in the
    Python console (so that a macro replays it); returns its ExportReport, or None when it
    failed (the reason in a message box, and in the Report view where FreeCAD prints it)."""
    before = getattr(__main__, "report", None)
    FreeCADGui.doCommand("import cmmsampling")
    try:
        FreeCADGui.doCommand(export_call(points, path, options))
    except Exception as exc:
        warn("Export probe points", str(exc))
        return None
    report = getattr(__main__, "report", None)
    if report is before:
        warn("Export probe points", "The file was not written: the Report view says why.")
        return None
    return report


def export_filters():
    """File dialog filters, one per export format: [(filter text, extensions)]."""
    from ..formats.pointfiles import FORMATS

    return [(f"{record.description} ({record.patterns})", list(record.extensions)) for record in FORMATS.values()]


def default_export_name(points):
    """A file name (without extension) for probe points: their source and strategy with
    characters other than letters, digits, '-' and '_' replaced, e.g. 'Body_Face1_pso'."""
    words = [getattr(points, "SourceName", "") or points.Label, getattr(points, "Strategy", "")]
    return re.sub(r"[^A-Za-z0-9_-]+", "_", "_".join(w for w in words if w)).strip("_") or "probe_points"


def default_export_folder(doc):
    """Where an export starts: beside the saved document, else the folder the last export wrote
    to, else the folder FreeCAD's own file dialogs used last, else the home folder."""
    if doc.FileName:
        return os.path.dirname(doc.FileName)
    ours = settings.load({EXPORT_FOLDER: ""})[EXPORT_FOLDER]
    theirs = FreeCAD.ParamGet("User parameter:BaseApp/Preferences/General").GetString("FileOpenSavePath", "")
    return next((folder for folder in (ours, theirs) if folder and os.path.isdir(folder)), os.path.expanduser("~"))


def unused_path(stem, extension):
    """stem + extension, or where that file exists already (an earlier export) the first of
    stem_2, stem_3 ... that does not, so that a new export does not start on the last one's file."""
    path, count = stem + extension, 1
    while os.path.exists(path):
        count += 1
        path = f"{stem}_{count}{extension}"
    return path


def choose_export_path(points):
    """Ask for the file to write, starting with :func:`default_export_name` in
    :func:`default_export_folder` (numbered where that file exists); '' when the user cancels.
    Without a known extension, the one of the chosen format is added."""
    filters = export_filters()
    start = unused_path(os.path.join(default_export_folder(points.Document), default_export_name(points)),
                        filters[0][1][0])
    path, chosen = QtGui.QFileDialog.getSaveFileName(
        FreeCADGui.getMainWindow(), "Export probe points", start, ";;".join(text for text, _ in filters))
    if not path:
        return ""
    known = [e for _, extensions in filters for e in extensions]
    if os.path.splitext(path)[1].lower() not in known:
        path += next((extensions[0] for text, extensions in filters if text == chosen), filters[0][1][0])
    settings.save({EXPORT_FOLDER: os.path.dirname(path)})
    return path


def selected_probe_points():
    """Probe-points objects among the selected objects and inside selected groups."""
    return document.probe_points_in(FreeCADGui.Selection.getSelection())


def one_source_reason(purpose, choose):
    """Why :func:`selected_export_sources` is not one set of points, or None: 'Select the probe
    points (...) <purpose>.' when there is none, '<K> sets ...: <choose>.' when there are more."""
    points = selected_export_sources()
    if not points:
        return f"Select the probe points (or their Sampling group, or a part plan's group) {purpose}."
    if len(points) > 1:
        return f"{len(points)} sets of probe points are selected: {choose}."
    return None


def selected_export_sources():
    """What Export writes: the part plans' groups selected (each one program of all its faces),
    else :func:`selected_probe_points`."""
    plans = [obj for obj in FreeCADGui.Selection.getSelection() if is_part_plan(obj)]
    return plans or selected_probe_points()


class OpenComparisonReport(GuardedCommand):
    """*Open comparison report...*: show a report Compare strategies wrote, again."""

    NAME = "CMMSampling_OpenReport"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_OpenReport", "Open comparison report")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_OpenReport", "Open comparison report...")
    ICON = "Compare.svg"
    TIP = Qt.QT_TRANSLATE_NOOP(
        "CMMSampling_OpenReport",
        "Open an HTML report that Compare strategies wrote: in FreeCAD's web view, else in the "
        "system's browser, else in a tab of FreeCAD")

    def reason(self):
        return None

    def act(self):
        from .panels.compare import default_folder, open_report

        doc = FreeCAD.ActiveDocument
        folder = default_folder(doc) if doc is not None else os.path.expanduser("~")
        path = QtGui.QFileDialog.getOpenFileName(
            FreeCADGui.getMainWindow(), self.TITLE, os.path.join(folder, "report.html"), "HTML report (*.html)")[0]
        if path:
            open_report(path, f"Compare strategies: {os.path.basename(os.path.dirname(path))}")


class UserGuide(GuardedCommand):
    """*User guide*: the workbench's guide (docs/user-guide.md of the installed add-on) in a tab
    of FreeCAD, its Markdown shown as formatted text."""

    NAME = "CMMSampling_UserGuide"
    TITLE = Qt.QT_TRANSLATE_NOOP("CMMSampling_UserGuide", "User guide")
    MENU = Qt.QT_TRANSLATE_NOOP("CMMSampling_UserGuide", "User guide")
    ICON = "Workbench.svg"
    TIP = Qt.QT_TRANSLATE_NOOP("CMMSampling_UserGuide",
                               "How to sample a face, plan a part, measure on a CMM and inspect the points")

    def reason(self):
        if not os.path.isfile(user_guide_path()):
            return f"The user guide is not installed with the workbench (looked for {user_guide_path()})."
        return None

    def act(self):
        show_user_guide()


def user_guide_path():
    """docs/user-guide.md beside the cmmsampling package (the add-on's folder)."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return os.path.join(os.path.dirname(package), "docs", "user-guide.md")


def show_user_guide():
    """Show the user guide in a tab of FreeCAD's main area (a QTextBrowser reading its Markdown,
    links to the web opened in the system's browser) and return that browser."""
    path = user_guide_path()
    view = QtGui.QTextBrowser()
    view.setObjectName("CMMSamplingUserGuide")
    view.setOpenExternalLinks(True)
    view.setSearchPaths([os.path.dirname(path)])
    with open(path, encoding="utf-8") as guide:
        view.setMarkdown(guide.read())
    area = FreeCADGui.getMainWindow().findChild(QtGui.QMdiArea)
    window = area.addSubWindow(view)
    window.setWindowTitle("CMM Sampling: user guide")
    window.show()
    area.setActiveSubWindow(window)
    return view


COMMANDS = (SampleFace, ExportProbePoints, Reevaluate, CompareStrategies, PlanPart, MeasureOnCMM, InspectMeasured)
MENU_ONLY = (OpenComparisonReport, UserGuide)


def register():
    """Add the commands to FreeCAD (once); returns (the toolbar's names, the menu's names)."""
    for command in COMMANDS + MENU_ONLY:
        if command.NAME not in FreeCADGui.listCommands():
            FreeCADGui.addCommand(command.NAME, command())
    toolbar = [command.NAME for command in COMMANDS]
    return toolbar, toolbar + [command.NAME for command in MENU_ONLY]
