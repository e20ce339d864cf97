"""*Measure on CMM...*: the I++ DME server (host, port), the tool and the file for the measured
points, asked in a small dialog, and whether to touch every planned point or, on one face's
probe points, only until the verdict is decided (its tolerance, the probing's uncertainty, the
risk of a wrong verdict, the datums among the part's faces and the earlier parts of the
series). The measurement runs in the background behind a progress dialog (the point under
way, Cancel) and is echoed as ``run = cmmsampling.measure(...)`` or
``run = cmmsampling.measure_until_decided(...)`` (handed over: cmmsampling.gui.handover, so the
echo does not move the machine again). Every planned point measured ends in *Inspect measured
points...* with the file it wrote; a run until decided ends in its own inspection, made in the
background too and added to the document.

The values persist in the workbench's parameter group.
"""
import os
import re
from dataclasses import dataclass, field

import FreeCADGui
from PySide import QtGui

from ..cmm.client import DEFAULT_PORT, measure
from ..cmm.decided import RISK, measure_until_decided
from ..document import settings
from ..document.object_types import is_measured_points
from ..geometry.validation import InputError
from ..formats.exporting import along_moves, as_point_set
from . import icon
from .background import BackgroundTask, behind_progress
from .echo import prior_expression
from .panels.fields import add_inspections, checked_data
from .qt_compat import asked, browse_row

DEFAULTS = {"MeasureHost": "127.0.0.1", "MeasurePort": DEFAULT_PORT, "MeasureTool": "",
            "MeasureUntilDecided": False, "MeasureTolerance": 0.05, "MeasureUncertainty": 0.001, "MeasureRisk": RISK}


@dataclass(frozen=True)
class MeasureRequest:
    """What the dialog asks for: function, the cmmsampling function that measures ('measure' or
    'measure_until_decided'), and its keyword arguments (server, out, tool; until decided also
    tolerance, uncertainty, risk and, where chosen, datums and prior); echoed: the console text
    of the arguments that are objects (datums, prior), by name."""

    function: str
    arguments: dict
    echoed: dict = field(default_factory=dict)

    @property
    def until_decided(self):
        return self.function == "measure_until_decided"


class MeasureDialog(QtGui.QDialog):
    """Where and with what to measure the probe points ``title`` names: host, port, tool (empty:
    the first the server lists), the measured file (``path``: where it starts) and, where
    one_face, whether to measure until the verdict is decided; then also the datums among the
    faces of part (the probe points' source object, or None) and the earlier parts of the series
    among the measured-points objects earlier (document objects)."""

    def __init__(self, title, path, parent=None, one_face=True, part=None, earlier=()):
        super().__init__(parent)
        self.setObjectName("MeasureOnCMM")
        self.setWindowTitle(f"Measure on CMM: {title}")
        self.setWindowIcon(QtGui.QIcon(icon("MeasureCMM.svg")))
        stored = settings.load(DEFAULTS)
        layout = QtGui.QFormLayout(self)
        self.host = QtGui.QLineEdit(stored["MeasureHost"], self)
        self.host.setObjectName("host")
        self.host.setToolTip("The computer the CMM's I++ DME server runs on (name or address)")
        layout.addRow("I++ DME server", self.host)
        self.port = QtGui.QSpinBox(self)
        self.port.setObjectName("port")
        self.port.setRange(1, 65535)
        self.port.setValue(int(stored["MeasurePort"]))
        self.port.setToolTip(f"Its TCP port ({DEFAULT_PORT} is I++ DME's)")
        layout.addRow("Port", self.port)
        self.tool = QtGui.QLineEdit(stored["MeasureTool"], self)
        self.tool.setObjectName("tool")
        self.tool.setPlaceholderText("the first tool the CMM lists")
        self.tool.setToolTip("The probe to measure with, as the CMM names it (EnumTools)")
        layout.addRow("Tool", self.tool)
        self.path = QtGui.QLineEdit(path, self)
        self.path.setObjectName("path")
        self.path.setToolTip("The measured contact points are written here (CSV), then inspected")
        layout.addRow("Measured file", browse_row(self, self.path, "Choose the folder and name of the measured file"))
        self._add_decision_rows(layout, stored, one_face)
        self._add_frame_rows(layout, part, earlier)
        self._decision_enabled(self.until.isChecked())
        self.buttons = QtGui.QDialogButtonBox(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel, parent=self)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        layout.addRow(self.buttons)
        self.resize(520, self.sizeHint().height())

    def _add_decision_rows(self, layout, stored, one_face):
        """The choice to measure until decided and its tolerance, uncertainty and risk (enabled
        with it; the choice itself only for one face's points)."""
        self.until = QtGui.QCheckBox("Only until the verdict is decided", self)
        self.until.setObjectName("until")
        self.until.setToolTip(
            "Touch the face where the verdict is least certain, one point at a time, and stop as soon as "
            "'conforms' or 'does not conform' holds with the chance of a wrong verdict below the risk "
            "(the planned points are not used; the face's profile to the tolerance, on the datums if given)"
            if one_face else "Measuring until decided judges one face: select one face's probe points")
        self.until.setEnabled(one_face)
        self.until.setChecked(one_face and bool(stored["MeasureUntilDecided"]))
        layout.addRow("Points", self.until)
        self.tolerance = _millimetres(self, "tolerance", stored["MeasureTolerance"], 0.0001,
                                      "The face's profile tolerance t (the zone's full width)")
        layout.addRow("Profile tolerance", self.tolerance)
        self.uncertainty = _millimetres(self, "uncertainty", stored["MeasureUncertainty"], 0.0,
                                        "The probing's standard uncertainty u per point; the verdict keeps "
                                        "U = 2u from the limit (ISO 14253-1)")
        layout.addRow("Probing uncertainty u", self.uncertainty)
        self.risk = QtGui.QDoubleSpinBox(self)
        self.risk.setObjectName("risk")
        self.risk.setDecimals(3)
        self.risk.setRange(0.001, 0.49)
        self.risk.setSingleStep(0.01)
        self.risk.setValue(float(stored["MeasureRisk"]))
        self.risk.setToolTip("The chance of a wrong verdict the run accepts before it stops")
        layout.addRow("Risk of a wrong verdict", self.risk)
        self.until.toggled.connect(self._decision_enabled)

    def _add_frame_rows(self, layout, part, earlier):
        """The datums (faces of part by name, primary first) and the earlier parts (a checkable
        list of the measured-points objects earlier) of a run until decided."""
        self.part, self.earlier_objects = part, {obj.Name: obj for obj in earlier}
        self.datums = QtGui.QLineEdit(self)
        self.datums.setObjectName("datums")
        self.datums.setPlaceholderText("none: the face's form alone" if part is not None else "no part known")
        self.datums.setToolTip(
            f"The faces of {part.Label} the profile is judged on (ISO 5459: A, B, C in this order, primary first), "
            "e.g. Face5, Face3, Face1: measured first, they fix the part's place, so the profile holds location "
            "and form" if part is not None else "The probe points have no source object whose faces could be datums")
        layout.addRow("Datums", self.datums)
        self.earlier = QtGui.QListWidget(self)
        self.earlier.setObjectName("earlier")
        self.earlier.setToolTip("Inspections of earlier parts of the series on this face: the first points go where "
                                "they leave the least unknown, and the belief expects their repeated error")
        add_inspections(self.earlier, list(earlier), "no inspection in this document")
        self.earlier.setMaximumHeight(90)
        layout.addRow("Earlier parts", self.earlier)

    def _decision_enabled(self, on):
        for widget in (self.tolerance, self.uncertainty, self.risk, self.earlier):
            widget.setEnabled(on)
        self.datums.setEnabled(on and self.part is not None)

    def datum_names(self):
        """The datum faces' names typed, in order ('Face5', ...); InputError naming one the
        part does not have."""
        names = [name for name in re.split(r"[,;\s]+", self.datums.text().strip()) if name]
        if names and self.part is None:
            raise InputError("the probe points have no source object whose faces could be datums: leave Datums empty")
        for name in names:
            try:
                self.part.Shape.getElement(name)
            except Exception:
                raise InputError(f"{self.part.Label} has no face {name!r}: give its faces as Face1, Face2, ... "
                                 "primary first, or leave Datums empty") from None
        return names

    def accept(self):
        """Close with OK, unless a datum names no face of the part (said in a message box)."""
        if self.until.isChecked():
            try:
                self.datum_names()
            except InputError as exc:
                QtGui.QMessageBox.warning(self, "Measure on CMM", str(exc))
                return
        super().accept()

    def browse(self):
        """Choose the measured file to write (CSV); the extension is added where it is missing."""
        path = QtGui.QFileDialog.getSaveFileName(self, "Measured points", self.path.text(), "CSV (*.csv)")[0]
        if path:
            self.path.setText(path if path.lower().endswith(".csv") else path + ".csv")

    def request(self):
        """The MeasureRequest of the dialog's values."""
        arguments = {"server": f"{self.host.text().strip()}:{self.port.value()}", "out": self.path.text().strip(),
                     "tool": self.tool.text().strip() or None}
        if not self.until.isChecked():
            return MeasureRequest("measure", arguments)
        arguments.update(tolerance=self.tolerance.value(), uncertainty=self.uncertainty.value(), risk=self.risk.value())
        echoed = {}
        names = self.datum_names()
        if names:
            arguments["datums"] = [self.part.Shape.getElement(name) for name in names]
            shape = f"App.getDocument({self.part.Document.Name!r}).getObject({self.part.Name!r}).Shape"
            echoed["datums"] = "[" + ", ".join(f"{shape}.getElement({name!r})" for name in names) + "]"
        earlier = [self.earlier_objects[name] for name in checked_data(self.earlier)]
        if earlier:
            arguments["prior"] = [obj.Proxy.inspection(obj) for obj in earlier]
            echoed["prior"] = prior_expression(earlier)
        return MeasureRequest("measure_until_decided", arguments, echoed)

    def stored(self):
        """The values to keep for the next measurement."""
        return {"MeasureHost": self.host.text().strip(), "MeasurePort": self.port.value(),
                "MeasureTool": self.tool.text().strip(), "MeasureUntilDecided": self.until.isChecked(),
                "MeasureTolerance": self.tolerance.value(), "MeasureUncertainty": self.uncertainty.value(),
                "MeasureRisk": self.risk.value()}


def _millimetres(dialog, name, value, lowest, tip):
    """A spin box of mm (4 decimals, from lowest to 10 mm) named name, at value."""
    box = QtGui.QDoubleSpinBox(dialog)
    box.setObjectName(name)
    box.setDecimals(4)
    box.setRange(lowest, 10.0)
    box.setSingleStep(0.001)
    box.setSuffix(" mm")
    box.setValue(float(value))
    box.setToolTip(tip)
    return box


def ask_measurement(points):
    """Ask where to measure a probe-points object or a part plan's group; None when the user
    cancels, else the MeasureRequest."""
    from ..document.object_types import is_part_plan

    doc = points.Document
    folder = os.path.dirname(doc.FileName) if doc.FileName else os.path.expanduser("~")
    source = getattr(points, "Source", None)
    part = source[0] if source and getattr(source[0], "Shape", None) is not None else None
    earlier = [obj for obj in doc.Objects if is_measured_points(obj)]
    dialog = MeasureDialog(points.Label, os.path.join(folder, f"{points.Name}_measured.csv"),
                           FreeCADGui.getMainWindow(), one_face=not is_part_plan(points), part=part, earlier=earlier)
    return asked(dialog, MeasureDialog.request)


def measurement_call(points, request):
    """The echoed line: ``run = cmmsampling.measure(<points>, 'host:port', 'file'[, tool=...])``,
    or ``run = cmmsampling.measure_until_decided(<points>, 'host:port', t, u, 'file', risk=...
    [, datums=[...]][, prior=[...]][, tool=...])``."""
    arguments = request.arguments
    words = [f"App.getDocument({points.Document.Name!r}).getObject({points.Name!r})", repr(arguments["server"])]
    if request.until_decided:
        words += [repr(arguments["tolerance"]), repr(arguments["uncertainty"]), repr(arguments["out"]),
                  f"risk={arguments['risk']!r}"] + [f"{name}={text}" for name, text in request.echoed.items()]
    else:
        words.append(repr(arguments["out"]))
    if arguments["tool"] is not None:
        words.append(f"tool={arguments['tool']!r}")
    return f"run = cmmsampling.{request.function}({', '.join(words)})"


def planned_points(points):
    """The points to measure, read in the GUI thread: along the collision-free path where they
    were planned with a probe (the PointSet's travel), else as planned."""
    from ..access.probe_moves import probe_moves

    point_set = as_point_set(points)
    try:
        return along_moves(point_set, probe_moves(points))
    except (ValueError, TypeError, AttributeError):
        return point_set


class BackgroundMeasurement(BackgroundTask):
    """cmmsampling.measure of a PointSet in a daemon thread; ``message`` the point under way;
    ``cancel()`` stops it (the running move aborted)."""

    def __init__(self, point_set, arguments):
        super().__init__("cmmsampling-measurement")
        self.point_set, self.arguments = point_set, dict(arguments)
        self.message, self.run = "connecting", None

    def cancel(self):
        self._stop.set()

    def _progress(self, message):
        if message is not None:
            self.message = message
        return self.cancelled

    def _work(self):
        self.run = measure(self.point_set, progress=self._progress, **self.arguments)


class BackgroundDecision(BackgroundMeasurement):
    """cmmsampling.measure_until_decided of one face's probe points in a daemon thread, then the
    DecidedRun's inspection (its Monte Carlo U takes a while); ``cancel()`` stops either (the
    points measured kept; a cancelled inspection is left unmade)."""

    def __init__(self, points, arguments):
        super().__init__(None, arguments)
        self.points = points

    def _work(self):
        from ..inspection.judge import InspectionCancelled

        self.run = measure_until_decided(self.points, progress=self._progress, **self.arguments)
        if not self.cancelled and self.run.points:
            self.message = f"{self.run.decision or 'undecided'} after {self.run.points} points; judging them"
            try:
                self.run.judged(self._progress)
            except InspectionCancelled:
                pass


def run_with_progress(points, request):
    """Measure the points as the MeasureRequest asks in the background behind a progress dialog
    with Cancel: the MeasuredRun or DecidedRun (``cancelled`` where the user stopped it), or
    the run's exception raised here."""
    if request.until_decided:
        job = BackgroundDecision(points, request.arguments)
    else:
        job = BackgroundMeasurement(planned_points(points), request.arguments)
    behind_progress(job, "Measure on CMM", "MeasureProgress",
                    lambda: f"Measuring {points.Label} on {request.arguments['server']}: {job.message}...")
    if job.error is not None:
        raise job.error
    return job.run
