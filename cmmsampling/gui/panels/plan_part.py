"""*Plan part*: probe points on many faces of one part, to a tolerance or a total of points.

The task panel composes a ``cmmsampling.plan(shape, faces=[...], ...)`` call for the selected
faces (or every face of a part selected whole), or, for a part read from a QIF MBD model (File >
Open of a .qif: its MbdFile), offers the model's own tolerances as the goal:
``cmmsampling.plan(cmmsampling.read_mbd(file, shape=part.Shape), ...)`` plans each characteristic
the model states with its tolerance and datums (the model read in the worker); the plan runs in a worker thread
(:class:`BackgroundPlan`) polled by a QTimer, the faces on local processes, with a progress bar
of faces done and a line per face as it ends. Cancel stops the faces under way and keeps those
done; the panel then offers Resume, which plans the faces not run with the same values and puts
the whole plan in the cancelled one's place. The plan is written through the console API
(``cmmsampling.add_plan_to_document``: a group per face and the plan's spreadsheet, one Undo),
echoed in the Python console, where ``plan`` holds it.
"""
import os

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

from ...access.probe import PROBES
from ...document import settings
from ...document.object_types import in_document
from ...fitting.deviation import DEFAULT_GRID
from ...planning.part_plan import CANCELLED_REASON, PLAN_TIME_LIMIT_S
from ...planning.plans import plan
from ...planning.points_needed import DEFAULT_MAX_POINTS
from ...strategies.sampling import BEST_STRATEGY, STRATEGIES, self_contained
from .. import counted
from ..background import BackgroundTask
from ..echo import add_plan
from ..view_providers import redraw_plan_points
from .base import BackgroundRunPanel
from .fields import AUTO, Fields, add_choice, probe_choice, snap_to_auto

SETTINGS_PREFIX = "Plan_"
# Points per face a budget starts with: the second of the pole steps (16, 46, ...).
POINTS_PER_FACE = 46
# What the panel shows for an option whose default None means "no limit".
NO_LIMIT = {"time_limit": "until it converges"}
# The panel's own default of those options: a plan runs the strategy several times per face.
PLAN_OPTION_DEFAULTS = {"time_limit": PLAN_TIME_LIMIT_S}
# Labels of settings whose one-line help is too long for a label.
SETTING_LABELS = {"time_limit": "Time limit per run"}
# The face list's item data that marks a line of a face under way (replaced at each refresh).
WORKING = QtCore.Qt.UserRole
SPIN_BOXES = ("tolerance", "points", "n_max", "grid", "processes")
# Values that belong to the part planned, not kept for the next plan (of another part, maybe).
PART_VALUES = ("datums",)
# Pixels the Datums field takes at least: three face names show whole, the label above it.
DATUMS_WIDTH = 180


def strategy_settings():
    """{option: (Setting, default)} of every strategy's offered settings (its record's
    ``settings``), with the plan's own defaults where the core has none."""
    offered = {}
    for entry in STRATEGIES.values():
        for setting in entry.settings:
            default = PLAN_OPTION_DEFAULTS.get(setting.option, entry.options[setting.option])
            offered.setdefault(setting.option, (setting, default))
    return offered


def panel_defaults():
    """The panel's values by name with their defaults: a 0.05 mm tolerance, the best strategy,
    400 points at most per face, the 60 x 60 grid, one process per core, the faces' own edge
    offsets, no probe reach judged ('' or a name of cmmsampling.PROBES) and the strategies'
    settings."""
    return {
        "by_tolerance": True, "tolerance": 0.05, "points": 0, "strategy": BEST_STRATEGY,
        "n_max": DEFAULT_MAX_POINTS, "grid": DEFAULT_GRID, "processes": os.cpu_count() or 1, "edge_offset": AUTO,
        "probe": "", "datums": "",
        **{option: default for option, (_, default) in strategy_settings().items()},
    }


def datum_names(text, count):
    """(the datum faces' names, primary first; the problem, '' for none) of the Datums field's
    text ('Face1, Face5, Face4', commas or spaces) on a part of count faces."""
    names = [name for name in text.replace(",", " ").split() if name]
    for name in names:
        number = name[4:] if name.startswith("Face") else ""
        if not number.isdigit() or not 1 <= int(number) <= count:
            return names, (f"Datums: {name!r} is no face of the part; give its faces as Face1 to Face{count}, "
                           "primary first")
    if len(set(names)) != len(names):
        return names, "Datums: a face is given twice; give each datum once, primary first"
    return names, ""


def datum_problem(values, numbers, count):
    """What is wrong with the datums asked (values: the panel's, numbers: the faces planned of a
    part of count faces), '' for nothing: a name that is no face, one given twice, or datums that
    leave no toleranced face."""
    names, problem = datum_names(values["datums"], count)
    if not problem and names and not set(f"Face{k}" for k in numbers) - set(names):
        problem = "Datums: every face to plan is a datum; select the toleranced faces too"
    return problem


def plan_arguments(values, numbers):
    """plan()'s keyword arguments for the panel's values and the face numbers planned: the goal,
    the strategy with the settings it offers (0 for "no limit" becomes None), n_max, grid,
    processes, the edge offset ("auto": each face's own, left out) and the probe whose reach is
    judged (a preset of cmmsampling.PROBES, left out for none) and the datum faces (left out
    for none)."""
    goal = {"tolerance": values["tolerance"]} if values["by_tolerance"] else {"n_total": values["points"]}
    arguments = {"faces": list(numbers), **goal, "strategy": values["strategy"], "n_max": values["n_max"],
                 "processes": values["processes"], "grid": values["grid"]}
    if values["edge_offset"] >= 0:
        arguments["edge_offset"] = values["edge_offset"]
    if values["probe"] in PROBES:
        arguments["probe"] = PROBES[values["probe"]]
    datums = [name for name in values["datums"].replace(",", " ").split() if name]
    if datums:
        arguments["datums"] = datums
    for setting in STRATEGIES[values["strategy"]].settings:
        value = values[setting.option]
        arguments[setting.option] = None if setting.option in NO_LIMIT and not value else value
    return arguments


def model_plan_arguments(values):
    """plan()'s keyword arguments for a QIF MBD model's plan: the panel's values but the goal, the
    faces and the datums, which the model states."""
    arguments = plan_arguments({**values, "by_tolerance": True, "datums": ""}, [])
    for stated in ("faces", "tolerance"):
        arguments.pop(stated)
    return arguments


def model_file(obj):
    """The QIF MBD file a part was read from (its MbdFile, where the file is still there), else ''."""
    path = getattr(obj, "MbdFile", "") or ""
    return path if path and os.path.isfile(path) else ""


def part_text(obj, numbers):
    """'Body: 3 of 12 faces (Face1, Face4, Face7)' or 'Body: all 12 faces'."""
    count = len(obj.Shape.Faces)
    if len(numbers) == count:
        return f"{obj.Label}: all {count} faces"
    names = ", ".join(f"Face{k}" for k in numbers)
    return f"{obj.Label}: {len(numbers)} of {count} faces ({names})"


class BackgroundPlan(BackgroundTask):
    """Runs ``plan(shape, progress=..., **arguments)`` in a daemon thread (with model_file, a
    QIF MBD file: ``plan(read_mbd(model_file, shape=shape), ...)``, the model kept in ``model``).

    The GUI thread polls ``done``/``total`` (faces), ``lines`` (one per face done, see
    FacePlan.line), ``tally`` (faces done, points so far, time left, renewed about every second),
    ``working`` (a line per face under way: the N its search runs and the best so far),
    ``running``, then ``plan`` (its faces' results for the document computed, here rather than in
    the GUI thread) or ``error``/``details``; ``cancel()`` makes the progress callback stop the plan
    within a second or two (the faces under way are stopped, the faces done kept). The thread
    never touches the document.
    """

    def __init__(self, shape, arguments, model_file=""):
        super().__init__("cmmsampling-plan")
        self.shape = shape
        self.arguments = dict(arguments)
        self.model_file = model_file
        self.model = None
        self.done = 0
        self.total = 0
        self.lines = []
        self.tally = ""
        self.working = []
        self.plan = None
        self.preparing = None

    def cancel(self):
        """Ask the plan to stop (at its next progress report, within about a second)."""
        self._stop.set()

    def _progress(self, done, total, message):
        line, _, tally = message.partition("\n")
        self.tally, *self.working = tally.split("; ")
        self.done, self.total = done, total
        if line:
            self.lines.append(line)
        return self.cancelled

    def _work(self):
        source = self.shape
        if self.model_file:
            from ...formats.qif.model import read_mbd

            self.tally = f"Reading the model's tolerances from {os.path.basename(self.model_file)}..."
            source = self.model = read_mbd(self.model_file, shape=self.shape)
        made = plan(source, progress=self._progress, **self.arguments)
        self.working = []
        self.preparing = made
        made.prepare_results(self._preparing)
        self.plan = made

    def _preparing(self, done, total):
        """The tally while the faces' results and the probe's path for the document are computed
        (here, not in the GUI thread, which only writes them)."""
        self.tally = f"Preparing the document (the faces' results, the probe's path): {done} of {total}"
        return False


class PlanPartTaskPanel(BackgroundRunPanel):
    """Task panel of *Plan part*. source: (obj, [K, ...]), the part and its face numbers."""

    OK_TEXT = "Plan"
    OK_TIP = "Plan every face; the points are added when the plan ends"
    RESUME_TIP = ("Plan the faces the cancelled plan did not run, with the same values; the faces done are kept, "
                  "and the whole plan replaces the cancelled one in the document (one Undo)")
    CANCELLING = "Cancelling: the faces under way are being stopped; the faces done are kept and added."

    def __init__(self, source):
        self._set_up("plan_part.ui", "PlanPart.svg", source)
        obj, numbers = source
        self.form.partLabel.setText(part_text(obj, numbers))
        for name in self_contained():
            add_choice(self.form.strategy, name, STRATEGIES[name].label, STRATEGIES[name].description)
        self._add_setting_boxes()
        self.edge_offset = self._add_edge_offset()
        self.probe = self._add_probe_choice()
        self.datums = self._add_datums()
        self.by_model = self._add_model_goal(obj)
        self.fields = Fields({"by_tolerance": (self.form.byTolerance, self.form.byPoints),
                              "strategy": self.form.strategy,
                              **{name: getattr(self.form, name) for name in SPIN_BOXES},
                              "edge_offset": self.edge_offset, "probe": self.probe, "datums": self.datums,
                              **self.setting_boxes})
        values = load_values()
        values["points"] = values["points"] or POINTS_PER_FACE * len(numbers)
        self.set_values(values)
        if self.by_model is not None:
            self.by_model.setChecked(True)   # a model's part: its own tolerances first
        self.form.strategy.currentIndexChanged.connect(self.update_enabled)
        self.form.byTolerance.toggled.connect(self.update_enabled)
        if self.by_model is not None:
            self.by_model.toggled.connect(self.update_enabled)
        self.form.progress.setTextVisible(False)
        # (plan, group) of the cancelled plan that OK resumes, else None.
        self.resumable = None
        self.update_enabled()

    # --- values
    def _add_setting_boxes(self):
        """A spin box per strategy setting (:func:`strategy_settings`) below the fixed settings,
        enabled when the chosen strategy offers it; 0 shows "no limit" where the core's None does."""
        layout = self.form.settingsGroup.layout()
        self.setting_boxes = {}
        for option, (setting, _) in strategy_settings().items():
            box = QtGui.QSpinBox(self.form) if setting.kind is int else QtGui.QDoubleSpinBox(self.form)
            box.setObjectName(option)
            box.setRange(0 if option in NO_LIMIT else 1, 10 ** 7)
            if option in NO_LIMIT:
                box.setSpecialValueText(NO_LIMIT[option])
            if setting.kind is float:
                box.setDecimals(1)
                box.setSuffix(" s" if option == "time_limit" else "")
            box.setToolTip(f"{setting.help}; per run, and a face's search runs it several times")
            text = SETTING_LABELS.get(option, setting.help.split(" (")[0])
            label = QtGui.QLabel(text[0].upper() + text[1:], self.form)
            layout.addRow(label, box)
            self.setting_boxes[option] = box

    def _add_edge_offset(self):
        """The edge offset's spin box (mm), "auto" below zero: each face's probe edge offset."""
        box = QtGui.QDoubleSpinBox(self.form)
        box.setObjectName("edge_offset")
        box.setRange(AUTO, 1000.0)
        box.setDecimals(3)
        box.setSingleStep(0.5)
        box.setSuffix(" mm")
        box.setSpecialValueText("auto")
        box.setToolTip("Distance (mm) every point keeps from its face's edges. auto: each face's own (the "
                       "probe ball radius plus a margin, or half the widest clearance of a narrower face).")
        box.valueChanged.connect(lambda value: snap_to_auto(box, value))
        self.form.settingsGroup.layout().addRow(QtGui.QLabel("Edge offset", self.form), box)
        return box

    def _add_probe_choice(self):
        """The probe whose reach is judged: none, or a preset (cmmsampling.PROBES)."""
        choice = probe_choice(self.form, "Every face's points are placed without regard to the probe",
                              "the plan gets a collision-free path (moves and touches drawn in the document)",
                              "The probe whose reach on the whole part each face keeps to")
        self.form.settingsGroup.layout().addRow(QtGui.QLabel("Probe", self.form), choice)
        return choice

    def _add_datums(self):
        """The datum faces' field: names, primary first, as A, B, C on the drawing."""
        field = QtGui.QLineEdit(self.form)
        field.setObjectName("datums")
        field.setMinimumWidth(DATUMS_WIDTH)
        field.setPlaceholderText("none (e.g. Face1, Face5, Face4)")
        field.setToolTip("The datum faces, primary first (A, B, C on the drawing): each gets points spread to hold "
                         "the motions it fixes and is measured first; the programs set the part's frame on them and "
                         "state the profile relative to them, and Inspect aligns on them. They need not be among the "
                         "selected faces; a selected one is no longer toleranced.")
        self.form.settingsGroup.layout().addRow(QtGui.QLabel("Datums", self.form), field)
        field.textEdited.connect(self._forget_datum_problem)
        return field

    def _add_model_goal(self, obj):
        """The goal "the model's tolerances" for a part read from a QIF MBD model (its MbdFile; the
        panel checks it), else None."""
        path = model_file(obj)
        if not path:
            return None
        button = QtGui.QRadioButton("Model's tolerances", self.form)
        button.setObjectName("byModel")
        button.setToolTip(f"Plan every characteristic {os.path.basename(path)} states that this tool judges, each "
                          "with its own tolerance and datums (the datum faces measured first); the model names the "
                          "faces, so the selection and the Datums field are not used")
        label = QtGui.QLabel(os.path.basename(path), self.form)
        label.setToolTip(path)
        self.form.goalGroup.layout().addRow(button, label)
        return button

    def from_model(self):
        """True where the goal is the model's own tolerances."""
        return self.by_model is not None and self.by_model.isChecked()

    def _forget_datum_problem(self, _text):
        """Clear the status line where it names a problem of the datums the user is now editing."""
        if self.form.status.text().startswith("Datums:"):
            self.show_status("")

    def values(self):
        """The panel's values by name (see :func:`panel_defaults`)."""
        return self.fields.values()

    def set_values(self, values):
        """Show values by name; an unknown strategy or probe leaves the choice as it is."""
        self.fields.show(values)

    def update_enabled(self):
        """The goal's field by the chosen goal, each strategy setting when the chosen strategy
        offers it; nothing (but Cancel) while a plan runs, nor after a cancelled one (OK resumes
        it with its values)."""
        idle = self.run is None and self.resumable is None
        strategy = self.form.strategy.itemData(self.form.strategy.currentIndex())
        offered = {setting.option for setting in STRATEGIES[strategy].settings} if strategy in STRATEGIES else set()
        by_tolerance = self.form.byTolerance.isChecked()
        model = self.from_model()
        for widget in (self.form.byTolerance, self.form.byPoints, self.form.strategy, self.form.n_max,
                       self.form.grid, self.form.processes, self.edge_offset, self.probe, self.datums, self.by_model):
            if widget is not None:
                widget.setEnabled(idle)
        self.datums.setEnabled(idle and not model)
        self.form.tolerance.setEnabled(idle and by_tolerance)
        self.form.points.setEnabled(idle and not by_tolerance and not model)
        self.form.n_max.setEnabled(idle and (by_tolerance or model))
        for option, box in self.setting_boxes.items():
            box.setEnabled(idle and option in offered)
        if self.buttons is not None:
            ok = self.buttons.button(QtGui.QDialogButtonBox.Ok)
            ok.setEnabled(self.run is None)
            ok.setText("Resume" if self.resumable else self.OK_TEXT)
            ok.setToolTip(self.RESUME_TIP if self.resumable else self.OK_TIP)

    # --- the run
    def part_shape(self):
        """The part's shape as it is now, or None when the part was deleted or lost faces."""
        obj, numbers = self.source
        try:
            shape = obj.Shape
        except ReferenceError:
            return None
        return shape if len(shape.Faces) >= max(numbers) else None

    def start(self):
        """Save the values and start the plan in the background."""
        shape = self.part_shape()
        if shape is None:
            self.show_status(f"{self.form.partLabel.text()}: the part is not in the document any more, or "
                             "has fewer faces now.", error=True)
            return
        values = self.values()
        if self.from_model():
            self.start_from_model(shape, values)
            return
        problem = datum_problem(values, self.source[1], len(shape.Faces))
        if problem:
            self.show_status(problem, error=True)
            return
        save_values(values)
        self.form.progress.setTextVisible(True)
        faces = len(self.source[1])
        arguments = plan_arguments(values, self.source[1])
        self.form.faceLines.clear()
        if self.resumable is None:
            self.begin(BackgroundPlan(shape, arguments), faces,
                       f"Planning {counted(faces, 'face')} on {counted(values['processes'], 'process')}...")
            return
        cancelled = self.resumable[0]
        run = BackgroundPlan(shape, {**arguments, "resume": cancelled})
        run.lines = [face.line for face in cancelled.faces if face.reason != CANCELLED_REASON]
        self.begin(run, faces, f"Resuming: planning the {counted(faces - len(run.lines), 'face')} not run on "
                               f"{counted(values['processes'], 'process')}...")

    def start_from_model(self, shape, values):
        """Start the plan of the part's QIF MBD model (its characteristics, read in the worker)."""
        save_values(values)
        self.form.progress.setTextVisible(True)
        self.form.faceLines.clear()
        arguments = model_plan_arguments(values)
        path = model_file(self.source[0])
        self.begin(BackgroundPlan(shape, arguments, path), 1,
                   f"Planning the characteristics of {os.path.basename(path)} on "
                   f"{counted(values['processes'], 'process')}...")

    def show_progress(self, run):
        """A line per face done, then one per face under way (in grey: the N its search runs and
        the best so far), the count of faces done, and the plan's tally in the status line (faces
        done, points so far, time left) until Cancel is pressed; once the cancelled plan has
        stopped, that it prepares the faces done for the document."""
        self.show_lines(run.lines, [] if run.cancelled else run.working)
        if run.tally and not run.cancelled:
            self.show_status(run.tally)
        elif run.cancelled and run.preparing is not None and not self.form.status.text().startswith("Stopped"):
            self.show_status(f"Stopped: preparing the {counted(len(run.preparing.placed), 'face')} done for the "
                             "document (their results, the probe's path)...")
        if run.total:
            self.form.progress.setRange(0, run.total)
            self.form.progress.setValue(run.done)

    def show_lines(self, lines, working=()):
        """Add the face lines not shown yet to the list, then the lines of the faces under way
        (``working``, in grey, renewed at each call), the newest in view."""
        listed = self.form.faceLines
        while listed.count() > len(lines) or (listed.count() and listed.item(listed.count() - 1).data(WORKING)):
            listed.takeItem(listed.count() - 1)
        shown = listed.count()
        for line in lines[shown:]:
            item = QtGui.QListWidgetItem(line, listed)
            item.setToolTip(line)
        for line in working:
            item = QtGui.QListWidgetItem(f"{line} ...", listed)
            item.setData(WORKING, True)
            item.setForeground(QtGui.QBrush(QtGui.QColor("gray")))
            item.setToolTip(f"Under way: {line}")
        if len(lines) > shown or working:
            listed.scrollToBottom()

    def finish(self, run):
        """Add the plan to the document (echoed); close when complete, say what was kept when
        cancelled."""
        result = run.plan
        FreeCAD.Console.PrintMessage(f"cmmsampling: plan of {self.form.partLabel.text()}, {result.strategy}: "
                                     f"{counted(result.n_total, 'point')} on {counted(len(result.placed), 'face')} in "
                                     f"{result.seconds:.0f} s\n{result.table()}\n")
        if not result.placed:
            self.show_status("No face holds points" + (" yet: the plan was cancelled." if result.cancelled
                                                       else ": see the reasons above.") + " Nothing was added.",
                             error=not result.cancelled)
            return
        self.show_status(("Stopped: adding" if result.cancelled else "Adding") + f" the {counted(len(result.placed), 'face')} "
                         f"done ({counted(result.n_total, 'point')}) to the document...")
        self.form.status.repaint()
        try:
            group = add_plan(self.source[0], run, result, self.cancelled_group())
        except Exception as exc:
            self.show_status(f"The plan could not be added to the document: {exc}", error=True)
            return
        redraw_plan_points(group)
        if not result.cancelled or run.model_file:
            FreeCADGui.Control.closeDialog()
            return
        self.resumable = (result, group)
        self.update_enabled()
        left = sum(1 for face in result.faces if face.reason == CANCELLED_REASON)
        self.show_status(f"Cancelled: the {counted(len(result.placed), 'face')} done "
                         f"{'was' if len(result.placed) == 1 else 'were'} added ({counted(result.n_total, 'point')}); "
                         f"the plan's report names the faces not run. Resume plans "
                         f"{'that one' if left == 1 else f'those {left}'}.")

    def cancelled_group(self):
        """The group of the cancelled plan being resumed while it is still in the document, else None."""
        group = self.resumable[1] if self.resumable is not None else None
        return group if group is not None and in_document(group, self.source[0].Document) else None


def load_values():
    """The values stored by the last plan, else the defaults (the part's own values, its datums,
    always the defaults)."""
    defaults = panel_defaults()
    stored = settings.load({SETTINGS_PREFIX + name: value for name, value in defaults.items()
                            if name not in PART_VALUES})
    return {**defaults, **{name[len(SETTINGS_PREFIX):]: value for name, value in stored.items()}}


def save_values(values):
    """Keep the values for the next plan, but the part's own (its datums: faces of this part)."""
    settings.save({SETTINGS_PREFIX + name: value for name, value in values.items() if name not in PART_VALUES})

