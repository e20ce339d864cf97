"""*Measure on CMM...*: the I++ DME server (host, port), the tool and the file for the measured
points, asked in a small dialog; the measurement runs in the background behind a progress
dialog (the point under way, Cancel), is echoed as ``run = cmmsampling.measure(...)`` (handed
over: cmmsampling.gui.handover, so the echo does not move the machine again) and ends in *Inspect measured points...* with
the file it wrote.

The values persist in the workbench's parameter group.
"""
import os

import FreeCADGui
from PySide import QtGui

from ..cmm.client import DEFAULT_PORT, measure
from ..document import settings
from ..formats.exporting import along_moves, as_point_set
from . import icon
from .background import BackgroundTask, behind_progress
from .qt_compat import asked, browse_row

DEFAULTS = {"MeasureHost": "127.0.0.1", "MeasurePort": DEFAULT_PORT, "MeasureTool": ""}


class MeasureDialog(QtGui.QDialog):
    """Where and with what to measure the probe points ``title`` names: host, port, tool (empty:
    the first the server lists) and the measured file (``path``: where it starts)."""

    def __init__(self, title, path, parent=None):
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
        self.buttons = QtGui.QDialogButtonBox(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel, parent=self)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        layout.addRow(self.buttons)
        self.resize(520, self.sizeHint().height())

    def browse(self):
        """Choose the measured file to write (CSV); the extension is added where it is missing."""
        path = QtGui.QFileDialog.getSaveFileName(self, "Measured points", self.path.text(), "CSV (*.csv)")[0]
        if path:
            self.path.setText(path if path.lower().endswith(".csv") else path + ".csv")

    def arguments(self):
        """{"server": 'host:port', "out": path, "tool": name or None}: keyword arguments of
        cmmsampling.measure."""
        return {"server": f"{self.host.text().strip()}:{self.port.value()}", "out": self.path.text().strip(),
                "tool": self.tool.text().strip() or None}

    def stored(self):
        """The values to keep for the next measurement."""
        return {"MeasureHost": self.host.text().strip(), "MeasurePort": self.port.value(),
                "MeasureTool": self.tool.text().strip()}


def ask_measurement(points):
    """Ask where to measure a probe-points object or a part plan's group; None when the user
    cancels, else the keyword arguments of cmmsampling.measure (MeasureDialog.arguments)."""
    doc = points.Document
    folder = os.path.dirname(doc.FileName) if doc.FileName else os.path.expanduser("~")
    dialog = MeasureDialog(points.Label, os.path.join(folder, f"{points.Name}_measured.csv"),
                           FreeCADGui.getMainWindow())
    return asked(dialog, MeasureDialog.arguments)


def measurement_call(points, arguments):
    """The echoed line: ``run = cmmsampling.measure(<points>, 'host:port', 'file'[, tool=...])``."""
    source = f"App.getDocument({points.Document.Name!r}).getObject({points.Name!r})"
    words = [source, repr(arguments["server"]), repr(arguments["out"])]
    if arguments["tool"] is not None:
        words.append(f"tool={arguments['tool']!r}")
    return f"run = cmmsampling.measure({', '.join(words)})"


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


def run_with_progress(points, arguments):
    """Measure the points in the background behind a progress dialog with Cancel: the
    MeasuredRun (``cancelled`` where the user stopped it), or the run's exception raised here."""
    job = BackgroundMeasurement(planned_points(points), arguments)
    behind_progress(job, "Measure on CMM", "MeasureProgress",
                    lambda: f"Measuring {points.Label} on {arguments['server']}: {job.message}...")
    if job.error is not None:
        raise job.error
    return job.run
