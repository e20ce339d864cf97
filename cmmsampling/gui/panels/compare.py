"""*Compare strategies*: every chosen strategy over a list of point counts N on the selected face.

The task panel composes a ``cmmsampling.compare(face, ...)`` call; the study and its report
(``cmmsampling.write_report``) run in a worker thread (:class:`BackgroundComparison`) polled by a
QTimer, with a progress bar of the study's steps. Cancel stops the study after the step under way
and keeps what is finished: the partial report is written and opened, and the panel says so.
Nothing is added to the document: the comparison is a report (HTML and PNG figures), opened in
FreeCAD's web view or the system's web browser. The calls are echoed in the Python console, where
``study`` holds the result.
"""
import os

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

from ...document import settings
from ...fitting.deviation import DEFAULT_GRID
from ...geometry.validation import InputError
from ...strategies.estimates import about_text
from ...strategies.sampling import STRATEGIES, self_contained
from ...study import DEFAULT_NS, DEFAULT_SEEDS, compare, study_time, write_report
from ..background import BackgroundTask
from ..echo import echo_study, face_expression, source_text
from .base import BackgroundRunPanel
from .fields import AUTO, Fields, add_checkable, checked_data, edge_offset_argument, snap_to_auto, spacing_argument

# The panel's values are stored under these names with this prefix, apart from Sample face's.
SETTINGS_PREFIX = "Compare_"
# The strategies' settings (Setting.option) this panel has a spin box for, and its own.
SETTING_BOXES = ("iterations", "population")
SPIN_BOXES = ("seeds",) + SETTING_BOXES + ("grid",)
# Probe constraints, as in Sample face: spin boxes made here, "auto" below zero.
CONSTRAINTS = {
    "edge_offset": ("Edge offset", "Distance (mm) every point keeps from the face's edges, in every "
                    "run. auto: as Sample face's (the probe ball radius plus a margin, or half the "
                    "widest clearance of a narrower face)."),
    "min_spacing": ("Minimum spacing", "Smallest distance (mm) between two points, in every run. "
                    "auto: a tenth of the even spacing sqrt(area / N), at least 0.005 mm."),
}


def setting_defaults():
    """{option: default} of the strategies' settings that have a spin box here, from the records."""
    defaults = {}
    for entry in STRATEGIES.values():
        for setting in entry.settings:
            if setting.option in SETTING_BOXES:
                defaults.setdefault(setting.option, entry.options[setting.option])
    return defaults


def panel_defaults():
    """The panel's values by name with their defaults: the study's N list and seed count, every
    strategy, their settings' defaults (the paper's swarm: population 25, 3000 iterations) and the
    60 x 60 grid."""
    return {
        "ns": ", ".join(str(n) for n in DEFAULT_NS),
        "strategies": ", ".join(STRATEGIES),
        "seeds": len(DEFAULT_SEEDS),
        **setting_defaults(),
        "grid": DEFAULT_GRID,
        "edge_offset": AUTO,
        "min_spacing": AUTO,
    }


def load_values():
    """The values stored by the last comparison, else the defaults."""
    stored = settings.load({SETTINGS_PREFIX + name: value for name, value in panel_defaults().items()})
    return {name[len(SETTINGS_PREFIX):]: value for name, value in stored.items()}


def save_values(values):
    settings.save({SETTINGS_PREFIX + name: value for name, value in values.items()})


def parse_ns(text):
    """The point counts typed in the N field: whole numbers separated by commas or spaces.

    Returns a tuple of int (compare() checks that each is at least 4); ValueError saying what to
    type otherwise."""
    words = text.replace(",", " ").split()
    try:
        return tuple(int(word) for word in words)
    except ValueError:
        raise InputError(f"The point counts N must be whole numbers separated by commas, e.g. "
                         f"25, 49, 81 (not {text.strip()!r}).") from None


def compare_arguments(values, automatic_offset):
    """The keyword arguments of ``cmmsampling.compare(face, ...)`` for the panel's values: seeds
    0 .. k-1 for the seeded strategies, each chosen strategy's settings shown here, and the probe
    constraints (automatic_offset: the face's probe edge offset, mm, for "auto")."""
    strategies = tuple(name for name in values["strategies"].split(", ") if name)
    options = {}
    for name in strategies:
        offered = [s.option for s in STRATEGIES[name].settings if s.option in SETTING_BOXES]
        if offered:
            options[name] = {option: values[option] for option in offered}
    return {"ns": parse_ns(values["ns"]), "strategies": strategies, "seeds": tuple(range(values["seeds"])),
            "options": options, "grid": values["grid"],
            "edge_offset": edge_offset_argument(values["edge_offset"], automatic_offset),
            "min_spacing": spacing_argument(values["min_spacing"])}


def default_folder(doc):
    """Where the report goes by default: ``<document's folder>/<file name>_comparison``, or
    ``~/<document name>_comparison`` for a document never saved."""
    if doc.FileName:
        stem = os.path.splitext(os.path.basename(doc.FileName))[0]
        return os.path.join(os.path.dirname(doc.FileName), f"{stem}_comparison")
    return os.path.join(os.path.expanduser("~"), f"{doc.Name}_comparison")


def open_report(path, title):
    """Show an HTML file in FreeCAD's web view, in a tab named ``title``, where FreeCAD has one
    (the Web module's GUI, FreeCAD 0.20), else in the system's web browser (FreeCAD 1.0 dropped
    the Web workbench; its Help opens the system's browser too), else, where no browser can be
    started, in a plain tab of FreeCAD (:func:`show_in_tab`). Returns True. While the web tab is
    the active one, FreeCAD's Undo and Redo do not reach the document (they act on the active
    view): the Report view says so."""
    try:
        import WebGui
    except ImportError:
        return open_in_browser(path) or show_in_tab(path, title)
    with open(path, encoding="utf-8") as page:
        html = page.read()
    base = QtCore.QUrl.fromLocalFile(os.path.dirname(os.path.abspath(path)) + os.sep).toString()
    WebGui.openBrowserHTML(html, base, title)
    FreeCAD.Console.PrintMessage("cmmsampling: Undo and Redo act on the document again once its "
                                 "3D view is the active tab (not while the report's tab is).\n")
    return True


def open_in_browser(path):
    """Ask the system to open a file in its web browser. Returns whether one was started (not
    where there is no desktop or no browser)."""
    return bool(QtGui.QDesktopServices.openUrl(QtCore.QUrl.fromLocalFile(os.path.abspath(path))))


def show_in_tab(path, title):
    """Show an HTML file in a tab of FreeCAD's main area named ``title`` (a QTextBrowser: the
    tables and figures, without the page's styles), and say in the Report view that no browser
    could be started and where the file is. Returns True."""
    view = QtGui.QTextBrowser()
    view.setObjectName("CMMSamplingReport")
    view.setOpenExternalLinks(True)
    view.setSource(QtCore.QUrl.fromLocalFile(os.path.abspath(path)))
    area = FreeCADGui.getMainWindow().findChild(QtGui.QMdiArea)
    window = area.addSubWindow(view)
    window.setWindowTitle(title)
    window.show()
    area.setActiveSubWindow(window)
    FreeCAD.Console.PrintMessage(f"cmmsampling: no web browser could be started; the report {path} is shown in "
                                 "a tab of FreeCAD.\n")
    return True


class BackgroundComparison(BackgroundTask):
    """Runs ``compare(face, progress=..., **arguments)`` and then, when at least one run finished,
    ``write_report(study, folder)`` in a daemon thread.

    The GUI thread polls ``done``/``total`` (study steps) and ``message``, ``running``, then
    ``study`` and ``report`` (path of report.html, or None) or ``error``/``details`` (the
    traceback text); ``cancel()`` makes the progress callback ask the study to stop: a swarm or
    descent stops within one iteration (its run is dropped), a bound or a blind strategy ends
    first. The thread never touches the document.
    """

    def __init__(self, face, arguments, folder):
        super().__init__("cmmsampling-compare")
        self.taken_face = face
        self.face = face.copy()
        self.arguments = dict(arguments)
        self.folder = folder
        self.done = 0
        self.total = 0
        self.message = "Starting..."
        self.study = None
        self.report = None

    def cancel(self):
        """Ask the study to stop; it ends (and the report is written) in the thread."""
        self._stop.set()

    def _progress(self, done, total, message):
        self.done, self.total, self.message = done, total, message
        return self.cancelled

    def _work(self):
        self.study = compare(self.face, progress=self._progress, **self.arguments)
        if self.study.rows:
            self.message = "Writing the report..."
            self.report = write_report(self.study, self.folder)


def study_time_text(estimate):
    """'45 runs; at least about 2 min, plus the local bounds' (and the descents that run until
    they converge) for a StudyTime."""
    extra = "the local bounds" + "".join(f" and the {STRATEGIES[name].label} runs, which go on until they "
                                         "converge" for name in estimate.open_ended)
    return f"{estimate.runs} runs; at least {about_text(estimate.seconds)}, plus {extra}"


class CompareTaskPanel(BackgroundRunPanel):
    """Task panel of *Compare strategies*. source: (obj, "FaceK")."""

    OK_TEXT = "Compare"
    OK_TIP = "Run the study; the report opens when it ends"
    CANCELLING = "Cancelling: the step under way ends or stops first; the finished runs are kept and reported."

    def __init__(self, source):
        self._set_up("compare.ui", "Compare.svg", source)
        self.face = face_expression(source)
        self.source_name = source_text(source)
        self._fill_strategies()
        self._add_constraints()
        self.fields = Fields({"ns": self.form.ns, **{name: getattr(self.form, name) for name in SPIN_BOXES},
                              **self.constraint_boxes})
        self.set_values(load_values())
        self.form.faceLabel.setText(self.source_name)
        self.form.folder.setText(default_folder(source[0].Document))
        self.form.progress.setTextVisible(False)
        self.form.browse.clicked.connect(self.browse)
        self.form.strategies.itemChanged.connect(self.update_enabled)
        self._add_study_time_line()
        self.update_enabled()

    # --- values
    def _fill_strategies(self):
        """One checkable line per strategy, by its label ('PSO (paper)'), its key ('pso') kept as
        the item's data and its description as tooltip; the list shows them all once the panel is
        shown (when the rows' height is known)."""
        strategies = self.form.strategies
        for name in self_contained():
            add_checkable(strategies, STRATEGIES[name].label, name, STRATEGIES[name].description)
        QtCore.QTimer.singleShot(0, self.fit_strategy_list)

    def _add_constraints(self):
        """Spin boxes for the probe constraints (CONSTRAINTS) below the grid, "auto" below zero."""
        layout = self.form.studyGroup.layout()
        self.constraint_boxes = {}
        for name, (text, tip) in CONSTRAINTS.items():
            box = QtGui.QDoubleSpinBox(self.form)
            box.setObjectName(name)
            box.setRange(AUTO, 1000.0)
            box.setDecimals(3)
            box.setSingleStep(0.5)
            box.setSuffix(" mm")
            box.setSpecialValueText("auto")
            box.setToolTip(tip)
            box.valueChanged.connect(lambda value, box=box: snap_to_auto(box, value))
            label = QtGui.QLabel(text, self.form)
            label.setToolTip(tip)
            layout.addRow(label, box)
            self.constraint_boxes[name] = box

    def _add_study_time_line(self):
        """A line above the progress bar with the study's estimated time, remade when a value
        changes."""
        self._add_time_line(self.form.runGroup.layout(), 0, "The runs timed on this face with "
                            "cmmsampling.time_needed; the local bound at each N comes on top")
        self.form.ns.textChanged.connect(self.estimate_timer.start)
        self.form.strategies.itemChanged.connect(self.estimate_timer.start)
        for box in [getattr(self.form, name) for name in SPIN_BOXES] + list(self.constraint_boxes.values()):
            box.valueChanged.connect(self.estimate_timer.start)
        self.estimate_timer.start()

    def study_arguments(self, values):
        """The compare() arguments for the panel's values (:func:`compare_arguments`, "auto"
        edge offset measured once on the face); ValueError for an N list that is no list."""
        automatic = self.face_edge_offset() if values["edge_offset"] < 0 else None
        return compare_arguments(values, automatic)

    def estimate_call(self):
        """cmmsampling.study.study_time on a copy of the face with the study's arguments."""
        face = self.source_face()
        arguments = self.study_arguments(self.values())
        if face is None or not arguments["strategies"]:
            return None
        return study_time, {"face": face.copy(), **arguments}

    def estimate_text(self, value):
        """The time line for a StudyTime (:func:`study_time_text`)."""
        return study_time_text(value)

    def fit_strategy_list(self):
        """Make the strategy list as tall as its rows, so that it never scrolls."""
        strategies = self.form.strategies
        strategies.setFixedHeight(strategies.sizeHintForRow(0) * strategies.count()
                                  + 2 * strategies.frameWidth())

    def items(self):
        """The strategy list's items, in STRATEGIES order."""
        return [self.form.strategies.item(i) for i in range(self.form.strategies.count())]

    def checked(self):
        """Names of the checked strategies, in STRATEGIES order."""
        return checked_data(self.form.strategies)

    def values(self):
        """The panel's values by name (see :func:`panel_defaults`)."""
        out = self.fields.values()
        return {"ns": out.pop("ns"), "strategies": ", ".join(self.checked()), **out}

    def set_values(self, values):
        """Show values by name; unknown strategy names are ignored."""
        self.fields.show(values)
        chosen = values["strategies"].split(", ")
        for item in self.items():
            item.setCheckState(QtCore.Qt.Checked if item.data(QtCore.Qt.UserRole) in chosen else QtCore.Qt.Unchecked)

    def update_enabled(self):
        """Enable the seeds when a chosen strategy is seeded and each strategy setting when a chosen
        strategy offers it; nothing (but Cancel) while a study runs."""
        idle = self.run is None
        chosen = [STRATEGIES[name] for name in self.checked() if name in STRATEGIES]
        for widget in (self.form.ns, self.form.strategies, self.form.grid, self.form.folder,
                       self.form.browse, *self.constraint_boxes.values()):
            widget.setEnabled(idle)
        self.form.seeds.setEnabled(idle and any(entry.seeded for entry in chosen))
        offered = {setting.option for entry in chosen for setting in entry.settings}
        for option in SETTING_BOXES:
            getattr(self.form, option).setEnabled(idle and option in offered)
        if self.buttons is not None:
            self.buttons.button(QtGui.QDialogButtonBox.Ok).setEnabled(idle)

    def folder(self):
        """The report folder typed, as an absolute path ('' when none is typed)."""
        text = self.form.folder.text().strip()
        return os.path.abspath(os.path.expanduser(text)) if text else ""

    def browse(self):
        """Choose the report folder in a folder dialog."""
        chosen = QtGui.QFileDialog.getExistingDirectory(
            FreeCADGui.getMainWindow(), "Report folder", self.folder() or os.path.expanduser("~"))
        if chosen:
            self.form.folder.setText(chosen)

    # --- the run
    def start(self):
        """Check the values, save them and start the study in the background."""
        values = self.values()
        face = self.source_face()
        if face is None:
            self.show_status(f"{source_text(self.source)} is not in the document any more.", error=True)
            return
        try:
            arguments = self.study_arguments(values)
        except InputError as exc:
            self.show_status(str(exc), error=True)
            return
        folder = self.folder()
        if not folder:
            self.show_status("Type or browse the folder the report is written to.", error=True)
            return
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            self.show_status(f"The report folder cannot be made: {exc}", error=True)
            return
        save_values(values)
        run = BackgroundComparison(face, arguments, folder)
        self.form.progress.setTextVisible(True)
        self.begin(run, 0, run.message)

    def show_progress(self, run):
        """The study's steps done and the one under way (not once it is cancelled: the panel
        says what cancelling does)."""
        if run.total:
            self.form.progress.setRange(0, run.total)
            self.form.progress.setValue(run.done)
        if run.running and not run.cancelled:
            self.show_status(run.message)

    def failed(self, run):
        """Show why the study or its report failed; a study that ran is kept in the console."""
        error = self.report_failure(run)
        if run.study is None:
            self.show_status(error, error=True)
            return
        alive = self.source_face() is not None
        echo_study(self.face, run, alive)
        where = ("The study is kept in the Python console as study: write it with "
                 "cmmsampling.write_report(study, folder)." if alive else
                 "Its face was deleted meanwhile, so the study is not kept.")
        self.show_status(f"The report could not be written ({error}). {where}", error=True)

    def finish(self, run):
        """Echo the study, open its report; close when complete, say what was kept when cancelled."""
        study = run.study
        echo_study(self.face, run, alive=self.source_face() is not None)
        if run.report is not None:
            FreeCAD.Console.PrintMessage(f"Strategy comparison, {len(study.rows)} runs in "
                                         f"{study.elapsed_s:.0f} s: {run.report}\n")
            shown = open_report(run.report, f"Compare strategies: {self.source_name}")
        if not study.cancelled:
            self.stop_estimates()
            FreeCADGui.Control.closeDialog()
            return
        if run.report is None:
            self.show_status(f"Cancelled after {run.done} of {run.total} steps, before any run "
                             "finished: no report was written.")
        else:
            self.show_status(f"Cancelled after {run.done} of {run.total} steps. The partial "
                             f"report ({len(study.rows)} runs) is {'open' if shown else 'written'}; "
                             "it is report.html in the report folder.")
