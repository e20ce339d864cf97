"""The *Sample face* task panel: face, strategy, N, probe constraints, swarm, fit and grid
settings; a background run.

The run is ``cmmsampling.sample(...)`` in a worker thread (:class:`BackgroundSampling`), polled by
a QTimer; Cancel stops it and leaves the document untouched. The result is written by the GUI
thread through the console API (``cmmsampling.add_to_document``), echoed in the Python
console.
"""
import json
import time
from dataclasses import asdict

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

from ...access.probe import PROBES
from ...fitting.deviation import DEFAULT_GRID
from ...fitting.substitute import DEFAULT_DEGREE, default_pole_count
from ...document import settings
from ...document.object_types import is_measured_points, source_face
from ...runtime import memory
from ...strategies import estimates, sampling
from ...strategies.settings import BEST_STARTS, resolve_fit_poles
from .. import echo
from ..background import BackgroundSampling
from ..selection import SelectionError, selected_face
from .base import ERROR_STYLE, BackgroundRunPanel
from .fields import (
    AUTO, Fields, add_choice, add_inspections, checked_data, detached, edge_offset_argument, probe_choice, snap_to_auto,
    spacing_argument,
)

CANCEL_WAIT_S = 1.0
# Steps after the first one seen before the progress line gives the time left from their pace.
PACE_STEPS = 20
EXPERT_GROUPS = ("psoGroup", "optimalGroup", "fitGroup", "gridGroup")
COMMON = ("n", "seed", "edge_offset", "min_spacing", "probe", "fit_degree", "auto_poles", "fit_poles_u",
          "fit_poles_v", "grid")
OPTION_GROUPS = ("psoGroup", "optimalGroup")
# Panel stand-ins for options whose default None means automatic or unlimited.
STAND_INS = {"time_limit": 0.0, "max_evaluations": 0}
# The panel's own defaults where the core's would leave a run unbounded: the optimal strategy
# stops after this many seconds (its best so far kept), so the run's time is known before it starts.
PANEL_OPTION_DEFAULTS = {"time_limit": 60.0}
# Steps of the progress bar of a run bounded by its time limit only.
TIME_STEPS = 1000
AUTOMATIC = ("edge_offset", "min_spacing")
PRIOR_LIST_HEIGHT = 110
PRIOR_TIP = ("The inspections of earlier parts of the same series on this face (their measured points, each in the "
             "part's frame): part_error places the points where, given them, the next part's error is least known")


def option_defaults():
    """The panel's defaults of the strategies' options by name: the core's (the paper's values
    for the swarm), with PANEL_OPTION_DEFAULTS or else STAND_INS where the core's default is None."""
    defaults = {}
    for strategy in sampling.STRATEGIES.values():
        for name, value in strategy.options.items():
            value = PANEL_OPTION_DEFAULTS.get(name, STAND_INS.get(name)) if value is None else value
            if isinstance(value, (bool, int, float, str)):
                defaults[name] = value
    return defaults


def panel_defaults():
    """Every value of the panel with its default: strategy, N, seed, probe constraints (both
    automatic: the face's probe edge offset and the default spacing; no probe reach judged, or
    a preset of cmmsampling.PROBES by name), options, fit, grid."""
    return {
        "strategy": sampling.DEFAULT_STRATEGY, "n": 81, "seed": 0, "edge_offset": AUTO,
        "min_spacing": AUTO, "probe": "", **option_defaults(),
        "fit_degree": DEFAULT_DEGREE, "auto_poles": True,
        "fit_poles_u": default_pole_count(81), "fit_poles_v": default_pole_count(81),
        "grid": DEFAULT_GRID,
    }


def option_argument(name, values):
    """The value of strategy option ``name`` for sample(), from the panel's values: the limits
    shown as 0 ("no limit") become None."""
    if name in STAND_INS:
        return values[name] or None
    return values[name]


def progress_total(arguments):
    """(what a progress step is, how many there will be or 0 when unknown) for a run, from its
    strategy's record."""
    entry = sampling.STRATEGIES[arguments["strategy"]]
    return entry.progress_unit.capitalize(), entry.progress_steps(arguments) or 0


class FacePicker:
    """Selection observer: calls ``on_pick()`` after each selection in the 3D view."""

    def __init__(self, on_pick):
        self.on_pick = on_pick

    def addSelection(self, doc, obj, sub, point):
        QtCore.QTimer.singleShot(0, self.on_pick)


class SampleFaceTaskPanel(BackgroundRunPanel):
    """Task panel of *Sample face*. source: (obj, "FaceK") to start with. When the run ends,
    :meth:`finish` closes it."""

    OK_TEXT = "Sample"
    OK_TIP = "Run the strategy; the results are added when it ends"

    def __init__(self, source):
        self._set_up("sample_face.ui", "SampleFace.svg", source)
        self.source_text = echo.source_text(source)
        self.step = ""
        self.time_limit = None
        self.started_at = 0.0
        self.picker = None
        self.run_face = None
        self.run_arguments = None
        self._fill_strategies()
        self._set_up_automatic_values()
        self._add_probe_choice()
        self._add_prior_choice()
        self._collapse_expert_settings()
        self.fields = Fields({name: self.widget(name) for name in panel_defaults() if self.widget(name) is not None})
        self.set_values(settings.load(panel_defaults()))
        self.form.strategy.currentIndexChanged.connect(self.update_enabled)
        self.form.auto_poles.toggled.connect(self.update_enabled)
        self.form.pickFace.toggled.connect(self.pick_face)
        self.memory_fits = True
        self._add_memory_line()
        self._add_sample_time_line()
        self.show_source()
        self.update_enabled()

    # --- FreeCAD task dialog interface
    def reject(self):
        """Cancel: stop a running swarm (within CANCEL_WAIT_S), change nothing, close."""
        self.timer.stop()
        self.stop_estimates()
        if self.run is not None:
            self.run.cancel(CANCEL_WAIT_S)
            self.run = None
        self.pick_face(False)
        return True

    # --- values
    def _fill_strategies(self):
        """The strategy list and the starts of a descent ("best" and the blind strategies): each
        entry shows the strategy's label and holds its name, with its description as tooltip."""
        best = ", ".join(sampling.STRATEGIES[name].label for name in BEST_STARTS)
        add_choice(self.form.start, "best", "best start", f"the best of {best} for this face")
        for name, strategy in sampling.STRATEGIES.items():
            add_choice(self.form.strategy, name, strategy.label, strategy.description)
            if not strategy.optimiser and not strategy.requires:
                add_choice(self.form.start, name, strategy.label, strategy.description)

    def _set_up_automatic_values(self):
        """Edge offset and minimum spacing below zero show "auto"; a line under the edge offset
        says what "auto" is on the chosen face."""
        for name in AUTOMATIC:
            widget = self.widget(name)
            widget.setMinimum(AUTO)
            widget.setSpecialValueText("auto")
            widget.valueChanged.connect(lambda value, widget=widget: snap_to_auto(widget, value))
        self.edgeOffsetInfo = QtGui.QLabel(self.form)
        self.edgeOffsetInfo.setObjectName("edgeOffsetInfo")
        self.edgeOffsetInfo.setWordWrap(True)
        layout = self.form.constraintsGroup.layout()
        layout.insertRow(layout.getWidgetPosition(self.form.edge_offset)[0] + 1, self.edgeOffsetInfo)
        self.form.edge_offset.valueChanged.connect(self.show_edge_offset)

    def _add_probe_choice(self):
        """The probe whose reach on the face's part is judged (``form.probe``): none, or a preset
        of cmmsampling.PROBES."""
        choice = probe_choice(self.form, "The points are placed without regard to the probe",
                              "the regions it cannot reach are shaded and the collision-free path is drawn",
                              "The probe whose reach on the whole part (the selected face's object) the points keep to")
        self.form.probe = choice
        self.form.constraintsGroup.layout().addRow(QtGui.QLabel("Probe", self.form), choice)

    def _add_prior_choice(self):
        """The earlier parts of a series a part_error run learns from (``form.priorParts``): the
        measured points of the document's inspections, each checkable; enabled for a strategy
        that requires a prior."""
        self.form.priorGroup = QtGui.QGroupBox("Earlier parts of the series", self.form)
        self.form.priorGroup.setObjectName("priorGroup")
        self.form.priorGroup.setToolTip(PRIOR_TIP)
        layout = QtGui.QVBoxLayout(self.form.priorGroup)
        self.form.priorParts = QtGui.QListWidget(self.form.priorGroup)
        self.form.priorParts.setObjectName("priorParts")
        self.form.priorParts.setToolTip(PRIOR_TIP)
        objects = self.source[0].Document.Objects if self.source is not None else []
        add_inspections(self.form.priorParts, [obj for obj in objects if is_measured_points(obj)],
                        "no inspection in this document: inspect earlier parts first")
        self.form.priorParts.setMaximumHeight(PRIOR_LIST_HEIGHT)
        layout.addWidget(self.form.priorParts)
        main = self.form.layout()
        main.insertWidget(main.indexOf(self.form.constraintsGroup) + 1, self.form.priorGroup)

    def prior_objects(self):
        """The measured-points objects checked in the earlier parts' list, in its order."""
        doc = self.source[0].Document
        return [doc.getObject(name) for name in checked_data(self.form.priorParts)]

    def _collapse_expert_settings(self):
        """Put the strategies' options, the fit and the grid in an "Expert settings" section
        below the common ones, closed until its button is pressed."""
        layout = self.form.layout()
        self.expertSettings = QtGui.QWidget(self.form)
        self.expertSettings.setObjectName("expertSettings")
        inner = QtGui.QVBoxLayout(self.expertSettings)
        inner.setContentsMargins(0, 0, 0, 0)
        for name in EXPERT_GROUPS:
            group = self.widget(name)
            layout.removeWidget(group)
            inner.addWidget(group)
        self.showExpert = QtGui.QToolButton(self.form)
        self.showExpert.setObjectName("showExpert")
        self.showExpert.setText("Expert settings")
        self.showExpert.setCheckable(True)
        self.showExpert.setToolButtonStyle(QtCore.Qt.ToolButtonTextBesideIcon)
        self.showExpert.setArrowType(QtCore.Qt.RightArrow)
        self.showExpert.setToolTip("The strategies' own options, the substitute's fit and the "
                                   "evaluation grid; their defaults suit most faces")
        self.showExpert.toggled.connect(self.show_expert)
        layout.addWidget(self.showExpert)
        layout.addWidget(self.expertSettings)
        layout.addStretch(1)
        self.show_expert(False)

    def show_expert(self, shown):
        """Open or close the expert settings."""
        self.expertSettings.setVisible(shown)
        self.showExpert.setArrowType(QtCore.Qt.DownArrow if shown else QtCore.Qt.RightArrow)

    def widget(self, name):
        """The form's widget for a value name, or None."""
        return getattr(self.form, name, None)

    def values(self):
        """Every value of the panel by name (see :func:`panel_defaults`)."""
        return self.fields.values()

    def set_values(self, values):
        """Show values by name; unknown names and choices are ignored."""
        self.fields.show(values)

    def sample_arguments(self):
        """The keyword arguments of ``cmmsampling.sample(face, ...)`` for the panel's values; with
        a probe, part= is the shape of the face's object."""
        values = self.values()
        strategy = sampling.STRATEGIES[values["strategy"]]
        arguments = {"n": values["n"], "strategy": strategy.name, "seed": values["seed"],
                     "fit_degree": values["fit_degree"], "grid": values["grid"]}
        if not values["auto_poles"]:
            arguments["fit_poles"] = (values["fit_poles_u"], values["fit_poles_v"])
        arguments["edge_offset"] = edge_offset_argument(values["edge_offset"], self.face_edge_offset())
        arguments["min_spacing"] = spacing_argument(values["min_spacing"])
        arguments.update({name: option_argument(name, values) for name in strategy.options if name in values})
        if values["probe"] in PROBES and self.source_face() is not None:
            arguments["part"] = self.source[0].Shape
            arguments["probe"] = PROBES[values["probe"]]
        if "prior" in strategy.requires:
            arguments["prior"] = [obj.Proxy.inspection(obj) for obj in self.prior_objects()]
        return arguments

    def _add_memory_line(self):
        """A line under N with the run's estimated memory, kept up to date with the values."""
        self.memoryInfo = QtGui.QLabel(self.form)
        self.memoryInfo.setObjectName("memoryInfo")
        self.memoryInfo.setWordWrap(True)
        self.memoryInfo.setToolTip("Estimated peak memory of the run (cmmsampling.memory_needed) against "
                                   "the memory this machine has free; a run that would not fit is refused")
        layout = self.form.samplingGroup.layout()
        layout.insertRow(layout.getWidgetPosition(self.form.n)[0] + 1, self.memoryInfo)
        for name in ("n", "population", "fit_degree", "fit_poles_u", "fit_poles_v", "grid"):
            self.widget(name).valueChanged.connect(self.update_memory)
        self.form.strategy.currentIndexChanged.connect(self.update_memory)
        self.form.auto_poles.toggled.connect(self.update_memory)
        self.update_memory()

    def _add_sample_time_line(self):
        """The run's time estimate under the memory line, remade when a value it depends on changes."""
        layout = self.form.samplingGroup.layout()
        self._add_time_line(layout, layout.getWidgetPosition(self.memoryInfo)[0] + 1,
                            "Estimated duration of the run (cmmsampling.time_needed): the strategy's "
                            "objective timed on this face, times its iterations")
        for name in ("n", "population", "iterations", "fit_degree", "fit_poles_u", "fit_poles_v", "grid",
                     "edge_offset", "min_spacing", "time_limit", "max_evaluations"):
            self.widget(name).valueChanged.connect(self.estimate_timer.start)
        self.form.strategy.currentIndexChanged.connect(self.estimate_timer.start)
        self.form.probe.currentIndexChanged.connect(self.estimate_timer.start)
        self.form.auto_poles.toggled.connect(self.estimate_timer.start)
        self.estimate_timer.start()

    def memory_arguments(self):
        """The arguments of :func:`cmmsampling.memory_needed` for the panel's values."""
        arguments = self.sample_arguments()
        strategy = sampling.STRATEGIES[arguments["strategy"]]
        kept = ("n", "strategy", "fit_degree", "fit_poles", "grid", *strategy.options)
        return {name: value for name, value in arguments.items() if name in kept}

    def update_memory(self, *_):
        """Show the run's estimated memory; one that would not fit is said in red and Sample is
        disabled until N (or the population, the poles, the grid) is lowered. Values the run
        would refuse anyway (e.g. w2 > w1) leave the line empty: Sample says what is wrong."""
        try:
            needed = estimates.memory_needed(**self.memory_arguments())
        except (ValueError, TypeError):
            self.memory_fits = True
            self.memoryInfo.setText("")
            self.update_enabled()
            return
        free = memory.free_bytes()
        self.memory_fits = memory.fits(needed, free)
        of_free = f" of {memory.gib(free)} free" if free is not None else ""
        if self.memory_fits:
            self.memoryInfo.setText(f"Memory: about {memory.gib(needed)}{of_free}")
            self.memoryInfo.setStyleSheet("")
        else:
            self.memoryInfo.setText(f"Memory: about {memory.gib(needed)}, more than this machine can "
                                    f"spare ({memory.gib(free)} free): lower N")
            self.memoryInfo.setStyleSheet(ERROR_STYLE)
        self.update_enabled()

    def estimate_call(self):
        """cmmsampling.time_needed on a copy of the chosen face with the run's arguments."""
        face = self.source_face()
        if face is None:
            return None
        arguments = {k: v for k, v in self.sample_arguments().items() if k != "seed"}
        return estimates.time_needed, {"face": face.copy(), **detached(arguments)}

    def estimate_text(self, seconds):
        """'Time: about 12 s', 'Time: under a second', or that the descent has no known end."""
        if seconds is None:
            return "Time: until the descent converges (set a time limit to bound it)"
        return f"Time: {estimates.about_text(seconds)}"

    def show_edge_offset(self, *_):
        """Say under the edge offset what "auto" is on the chosen face."""
        if self.form.edge_offset.value() >= 0:
            self.edgeOffsetInfo.setText("")
            return
        offset = self.face_edge_offset()
        if offset >= sampling.PROBE_EDGE_OFFSET_MM:
            why = "a probe ball's radius plus a margin"
        else:
            why = "the face is too narrow for more: half its widest clearance"
        self.edgeOffsetInfo.setText(f"auto: {offset:g} mm on this face ({why})")

    def update_enabled(self):
        """Enable the options the chosen strategy takes (and their groups) and the pole counts
        unless automatic; nothing while a run is on."""
        strategy = sampling.STRATEGIES[self.form.strategy.currentData()]
        self.form.strategyInfo.setText(strategy.description)
        running = self.run is not None
        taken = [self.widget(name) for name in strategy.options if self.widget(name) is not None]
        for name in option_defaults():
            widget = self.widget(name)
            if widget is not None:
                widget.setEnabled(widget in taken and not running)
        for name in OPTION_GROUPS:
            group = self.widget(name)
            group.setEnabled(any(group.isAncestorOf(widget) for widget in taken))
        for name in COMMON:
            self.widget(name).setEnabled(not running)
        manual = not self.form.auto_poles.isChecked() and not running
        self.form.fit_poles_u.setEnabled(manual)
        self.form.fit_poles_v.setEnabled(manual)
        self.form.strategy.setEnabled(not running)
        self.form.priorGroup.setEnabled("prior" in strategy.requires and not running)
        self.form.pickFace.setEnabled(not running)
        if self.buttons is not None:
            self.buttons.button(QtGui.QDialogButtonBox.Ok).setEnabled(not running and self.memory_fits)

    # --- face
    def show_source(self):
        self.form.faceLabel.setText(self.source_text)
        self.form.faceLabel.setStyleSheet("")
        self.show_edge_offset()

    def source_gone(self):
        """Say that the chosen face is gone and what to do."""
        self.show_status(f"{self.source_text} is not in the document any more: pick another face "
                         "and sample again.", error=True)

    def pick_face(self, on):
        """Start (on=True) or stop waiting for a face clicked in the 3D view."""
        if on and self.picker is None:
            self.picker = FacePicker(self.picked)
            FreeCADGui.Selection.clearSelection()
            FreeCADGui.Selection.addObserver(self.picker)
            self.form.faceLabel.setText("Click a face in the 3D view...")
        elif not on and self.picker is not None:
            FreeCADGui.Selection.removeObserver(self.picker)
            self.picker = None
            self.show_source()
        if self.form.pickFace.isChecked() != on:
            self.form.pickFace.setChecked(on)

    def picked(self):
        """Take the selected face, or say why the selection is not one."""
        if self.picker is None:
            return
        try:
            self.source = selected_face(FreeCADGui.Selection.getSelectionEx())
            self.source_text = echo.source_text(self.source)
            self.automatic_offset = None
            self.estimate_timer.start()
        except SelectionError as exc:
            self.form.faceLabel.setText(str(exc))
            self.form.faceLabel.setStyleSheet(ERROR_STYLE)
            FreeCADGui.Selection.clearSelection()
            return
        self.pick_face(False)

    # --- the run
    def start(self):
        """Start ``cmmsampling.sample`` in the background (the values are saved for the next use
        once it has succeeded)."""
        face = self.source_face()
        if face is None:
            self.source_gone()
            return
        if "prior" in sampling.STRATEGIES[self.form.strategy.currentData()].requires and not self.prior_objects():
            self.show_status("Check at least one earlier part in 'Earlier parts of the series': part_error learns "
                             "where the next part's error is least known from their inspections.", error=True)
            return
        arguments = self.sample_arguments()
        self.run_face = face
        self.paced_from = None
        self.step, total = progress_total(arguments)
        self.time_limit = arguments.get("time_limit") if not total else None
        self.started_at = time.perf_counter()
        if self.time_limit:
            total = TIME_STEPS
        self.run_arguments = arguments
        self.begin(BackgroundSampling(face.copy(), detached(arguments)), total,
                   f"Running {sampling.STRATEGIES[arguments['strategy']].label} with N = {arguments['n']}...")

    def show_progress(self, run):
        """The swarm's or descent's step, its best maximum deviation so far and the time left at
        the pace of the steps so far (the estimate before the run cannot know how busy the
        machine will be)."""
        if self.time_limit:
            self.show_timed_progress(run)
            return
        total = self.form.progress.maximum()
        if total:
            self.form.progress.setValue(min(run.iteration, total))
        if run.iteration:
            self.show_status(f"{self.step} {run.iteration}{f' of {total}' if total else ''}: "
                             f"best maximum deviation {run.best_mm:.4f} mm{self.time_left(run.iteration, total)}")

    def show_timed_progress(self, run):
        """A run bounded by its time limit only (the optimal strategy's steps are not known in
        advance): the bar fills with the time spent of the limit, the status gives the step, the
        best so far and the time left of the limit (then that the result is being judged)."""
        spent = time.perf_counter() - self.started_at
        self.form.progress.setValue(min(TIME_STEPS, round(TIME_STEPS * spent / self.time_limit)))
        if not run.iteration:
            return
        left = self.time_limit - spent
        when = f", {estimates.time_left_text(left)}" if left > 0 else "; judging it"
        self.show_status(f"{self.step} {run.iteration}: best {run.best_mm:.4f} mm{when}")

    def time_left(self, iteration, total):
        """', about 40 s left' from the pace since the first step seen, or '' (no total, or too
        early to say)."""
        now = time.perf_counter()
        if self.paced_from is None:
            self.paced_from = (now, iteration)
        start, first = self.paced_from
        if not total or iteration - first < PACE_STEPS:
            return ""
        return f", {estimates.time_left_text((now - start) / (iteration - first) * (total - iteration))}"

    def failed(self, run):
        self.form.progress.setRange(0, 1)
        self.form.progress.setValue(0)
        super().failed(run)

    def finish(self, run):
        """Add the result to the document (through the echoed console API) and close; on failure
        (e.g. the face was deleted meanwhile) say why and stay open."""
        self.form.progress.setRange(0, 1)
        self.form.progress.setValue(1)
        if self.source_face() is None:
            self.source_gone()
            return
        try:
            prior = {"prior": echo.prior_expression(self.prior_objects())} if "prior" in self.run_arguments else {}
            group = echo.add_result(self.source, self.run_face, self.run_arguments, run.result, **prior)
        except Exception as exc:  # shown in the panel; the console has the traceback
            self.show_status(f"The result could not be added: {exc}", error=True)
            return
        settings.save(self.values())
        echo.report_run(self.source_text, run.result)
        self.stop_estimates()
        FreeCADGui.Control.closeDialog()
        fit_view_to(group)

def fit_view_to(group):
    """Fit the active 3D view to a result's probe points (not the whole part, nor the
    substitute's shape, which spans the face's whole parameter range)."""
    view = FreeCADGui.ActiveDocument.ActiveView if FreeCADGui.ActiveDocument else None
    if view is None or not hasattr(view, "fitAll"):
        return
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(group.Group[0])
    FreeCADGui.SendMsgToActiveView("ViewSelection")
    FreeCADGui.Selection.clearSelection()


def run_values(parameters):
    """The panel's values that repeat a finished run, from its probe points' Parameters (a dict
    from their JSON): strategy, N, seed, the strategy's options, the edge offset and spacing the
    run used (mm), the probe (a preset's name, '' for none or another probe), the fit and the
    grid (pairs with equal halves as one number)."""
    values = {}
    for name in panel_defaults():
        value = parameters.get(name)
        if name in STAND_INS and name in parameters and value is None:
            values[name] = STAND_INS[name]
        elif isinstance(value, list) and len(set(value)) == 1:
            values[name] = value[0]
        elif value is not None and not isinstance(value, list):
            values[name] = value
    probe = parameters.get("probe")
    values["probe"] = next((name for name, preset in PROBES.items() if asdict(preset) == probe), "")
    poles = parameters.get("fit_poles")
    if isinstance(poles, list) and len(poles) == 2 and "n" in parameters:
        degree = tuple(parameters.get("fit_degree", (DEFAULT_DEGREE, DEFAULT_DEGREE)))
        values["auto_poles"] = poles == list(resolve_fit_poles(None, parameters["n"], degree))
        values["fit_poles_u"], values["fit_poles_v"] = poles
    return values


def reopen(points):
    """Open Sample face on probe points' source face with the values of their run (what a
    double click on the points does); returns the panel, or None with the reason in the Report
    view when their face is gone or another task panel is open."""
    face, why = source_face(points)
    if face is None or FreeCADGui.Control.activeDialog():
        reason = f"{why}; select a face and use Sample face" if face is None else "close the open task panel first"
        FreeCAD.Console.PrintWarning(f"Cannot open {points.Label} again: {reason}.\n")
        return None
    obj, names = points.Source
    panel = SampleFaceTaskPanel((obj, names[0]))
    panel.set_values(run_values(json.loads(points.Parameters or "{}")))
    FreeCADGui.Control.showDialog(panel)
    return panel
