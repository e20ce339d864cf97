"""*Inspect measured points...*: the measured file, the alignment, the locked degrees of freedom,
the profile tolerance, the datums and the CMM's probing uncertainty, asked in a small dialog; the inspection then runs as its echoed API
calls (``inspection = cmmsampling.inspect(...)``, ``cmmsampling.add_inspection_to_document``).

The values persist in the workbench's parameter group; the file starts in the folder of the last
one read, else beside the document.
"""
import math
import os

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

from ..document import settings
from ..formats.registry import measured_filter
from ..inspection.align import ALIGNMENTS, DEGREES_OF_FREEDOM
from ..inspection.characteristics import MbdInspection, inspect_model_file, planned_ids
from ..inspection.judge import InspectionCancelled, inspect, stated
from ..inspection.result import verdict_words
from . import icon
from .background import BackgroundTask, behind_progress
from .qt_compat import asked, browse_row

ALIGNMENT_TEXTS = {
    "min_max": ("Minimum zone (min-max, ISO 1101)", "The rigid motion that makes the largest |deviation| "
                                                    "smallest: the narrowest zone, by which ISO 1101 judges the "
                                                    "form profile of a surface without datums"),
    "best_fit": ("Best fit (least squares)",
                 "The rigid motion that makes the sum of squared deviations along the CAD normals smallest, "
                 "iterated with exact closest points: its profile is never narrower than the minimum zone's"),
    "none": ("None (points in the part's frame)", "The measured points are judged where they are: the CMM "
                                                  "measured in the part's own frame"),
}
DEFAULTS = {"InspectFile": "", "InspectAlignment": "min_max", "InspectTolerance": 0.1, "InspectLocked": "",
            "InspectZoneOffset": 0.0, "InspectDatums": "", "InspectUncertainty": 0.0}
MAX_TOLERANCE_MM = 100.0
MAX_UNCERTAINTY_MM = 1.0


class InspectDialog(QtGui.QDialog):
    """What to inspect the probe points ``title`` names with: the measured file, the alignment,
    the locked degrees of freedom and the tolerance (0: none), from the stored values; ``folder``:
    where the file dialog starts without a stored file; states: (datum faces, tolerance mm or
    None) a plan states, shown instead of the stored ones."""

    def __init__(self, title, folder, parent=None, states=((), None), model=""):
        super().__init__(parent)
        self.setObjectName("InspectMeasured")
        self.setWindowTitle(f"Inspect measured points: {title}")
        self.setWindowIcon(QtGui.QIcon(icon("Inspect.svg")))
        stored = settings.load(DEFAULTS)
        if states[0]:
            stored["InspectDatums"] = ", ".join(states[0])
        if states[1] is not None:
            stored["InspectTolerance"] = float(states[1])
        self.folder = os.path.dirname(stored["InspectFile"]) or folder
        layout = QtGui.QFormLayout(self)
        self.path = QtGui.QLineEdit(stored["InspectFile"], self)
        self.path.setObjectName("path")
        self.path.setToolTip("The CMM's measured points: DMIS output (FA(label) actuals), the CSV or XYZIJK this "
                             "workbench writes, or labelled x, y, z text (comma, semicolon or spaces). They pair "
                             "with the planned points by label.")
        layout.addRow("Measured file", browse_row(self, self.path))
        self.alignment = QtGui.QComboBox(self)
        self.alignment.setObjectName("alignment")
        for name in ALIGNMENTS:
            text, tip = ALIGNMENT_TEXTS[name]
            self.alignment.addItem(text, name)
            self.alignment.setItemData(self.alignment.count() - 1, tip, QtCore.Qt.ToolTipRole)
        self.alignment.setCurrentIndex(max(0, self.alignment.findData(stored["InspectAlignment"])))
        self.alignment.setToolTip("How the measured points are brought onto the CAD model (the part is not moved: "
                                  "the motion is applied to the points)")
        layout.addRow("Alignment", self.alignment)
        self.locked = {}
        boxes = QtGui.QHBoxLayout()
        for name in DEGREES_OF_FREEDOM:
            box = QtGui.QCheckBox(name, self)
            box.setObjectName(f"locked_{name}")
            box.setChecked(name in stored["InspectLocked"].split(","))
            motion = f"the rotation about {name[1]}" if name.startswith("r") else f"the shift along {name}"
            box.setToolTip(f"Hold {motion} fixed (e.g. a part clamped on a datum plane)")
            boxes.addWidget(box)
            self.locked[name] = box
        layout.addRow("Locked", boxes)
        self.tolerance = mm_box(self, "tolerance", (0.0, MAX_TOLERANCE_MM), stored["InspectTolerance"],
                                "Profile tolerance t of the surface (ISO 1101, form only): a zone of width t "
                                "centred on the nominal; a point passes where |deviation| <= t/2, the face where "
                                "the profile 2 max |deviation| <= t. 'none': deviations only.")
        self.tolerance.setSpecialValueText("none")
        layout.addRow("Profile tolerance", self.tolerance)
        self.zone_offset = mm_box(self, "zone_offset", (-MAX_TOLERANCE_MM, MAX_TOLERANCE_MM),
                                  stored["InspectZoneOffset"],
                                  "Where the tolerance zone's centre lies from the nominal surface (ISO 1101 UZ), + "
                                  "out of the material: 0 a zone centred on the nominal, +t/2 a unilateral zone "
                                  "outside the material, -t/2 inside.")
        layout.addRow("Zone offset (UZ)", self.zone_offset)
        self.datums = QtGui.QLineEdit(stored["InspectDatums"], self)
        self.datums.setObjectName("datums")
        self.datums.setPlaceholderText("none: the form, floated (e.g. Face1, Face5, Face4)")
        self.datums.setToolTip("The datum faces, primary first, as A, B, C on the drawing: the part is aligned on "
                               "their measured points (ISO 5459, tangent) and the profile is judged in their frame "
                               "(location and form). Plan the datum faces with the toleranced ones.")
        layout.addRow("Datums", self.datums)
        self.uncertainty = mm_box(self, "uncertainty", (0.0, MAX_UNCERTAINTY_MM), stored["InspectUncertainty"],
                                  "The CMM's probing standard uncertainty per point (an MPE_P / sqrt(3)): the "
                                  "profile's expanded uncertainty U (k = 2) by Monte Carlo, and ISO 14253-1's "
                                  "decision (conforms, does not conform, undecided). 'none': no uncertainty.")
        self.uncertainty.setSingleStep(0.001)
        self.uncertainty.setSpecialValueText("none")
        layout.addRow("Probing uncertainty u", self.uncertainty)
        self.buttons = QtGui.QDialogButtonBox(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel, parent=self)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        layout.addRow(self.buttons)
        self.path.textChanged.connect(self.check)
        self.check()
        if model:
            self.model_states(model)
        self.resize(560, self.sizeHint().height())

    def model_states(self, model):
        """A plan of a QIF MBD model (its file ``model``) states each characteristic's tolerance,
        datums and zone: those fields are off and say so; the file and u are asked."""
        why = (f"{os.path.basename(model)} states each characteristic's tolerance, datums and zone: each is judged "
               "with its own (Inspect measured points of a model's plan)")
        for widget in (self.alignment, *self.locked.values(), self.tolerance, self.zone_offset, self.datums):
            widget.setEnabled(False)
            widget.setToolTip(why)
        self.datums.setText("")
        self.datums.setPlaceholderText(f"each characteristic's own, from {os.path.basename(model)}")
        self.tolerance.setValue(0.0)
        self.tolerance.setSpecialValueText("each characteristic's own")

    def browse(self):
        """Pick the measured file."""
        path = QtGui.QFileDialog.getOpenFileName(self, "Measured points", self.path.text() or self.folder,
                                                 measured_filter())[0]
        if path:
            self.path.setText(path)

    def check(self):
        """OK only with a file that exists."""
        found = os.path.isfile(self.path.text())
        self.buttons.button(QtGui.QDialogButtonBox.Ok).setEnabled(found)

    def arguments(self):
        """{"measured": path, "alignment": ..., "locked": tuple, "tolerance": mm or None,
        "zone_offset": mm, "datums": face names, "uncertainty": mm or None}: keyword arguments
        of cmmsampling.inspect."""
        return {"measured": self.path.text(), "alignment": self.alignment.currentData(),
                "locked": tuple(name for name, box in self.locked.items() if box.isChecked()),
                "tolerance": self.tolerance.value() or None, "zone_offset": self.zone_offset.value(),
                "datums": tuple(name.strip() for name in self.datums.text().split(",") if name.strip()),
                "uncertainty": self.uncertainty.value() or None}

    def stored(self):
        """The values to keep for the next inspection."""
        chosen = self.arguments()
        return {"InspectFile": chosen["measured"], "InspectAlignment": chosen["alignment"],
                "InspectTolerance": self.tolerance.value(), "InspectLocked": ",".join(chosen["locked"]),
                "InspectZoneOffset": chosen["zone_offset"], "InspectDatums": ", ".join(chosen["datums"]),
                "InspectUncertainty": self.uncertainty.value()}


def mm_box(parent, name, limits, value, tip):
    """A spin box of mm (4 decimals, steps of 0.01 mm) named name, within limits (low, high)."""
    box = QtGui.QDoubleSpinBox(parent)
    box.setObjectName(name)
    box.setRange(*limits)
    box.setDecimals(4)
    box.setSingleStep(0.01)
    box.setSuffix(" mm")
    box.setValue(value)
    box.setToolTip(tip)
    return box


def ask_inspection(points):
    """Ask what to inspect a probe-points object or a part plan's group with (a plan's datums and
    tolerance shown as it states them); None when the user cancels, else the keyword arguments
    of cmmsampling.inspect (see InspectDialog.arguments; for a QIF MBD model's plan, the file and
    u only: the model states the rest)."""
    doc = points.Document
    folder = os.path.dirname(doc.FileName) if doc.FileName else os.path.expanduser("~")
    groups = [o.Label for o in points.InList if o.isDerivedFrom("App::DocumentObjectGroup")]
    model = getattr(points, "MbdFile", "")
    dialog = InspectDialog((groups or [points.Label])[0], folder, FreeCADGui.getMainWindow(),
                           ((), None) if model else stated(points), model)
    chosen = asked(dialog, InspectDialog.arguments)
    if not model or chosen is None:
        return chosen
    return {"measured": chosen["measured"],
            **({"uncertainty": chosen["uncertainty"]} if chosen["uncertainty"] is not None else {})}


def inspection_call(points, arguments):
    """The echoed lines of an inspection: ``inspection = cmmsampling.inspect(<points>, <file>,
    ...)`` (the defaults left out) and ``group = cmmsampling.add_inspection_to_document(...)``."""
    doc = f"App.getDocument({points.Document.Name!r})"
    source = f"{doc}.getObject({points.Name!r})"
    words = [source, repr(arguments["measured"])]
    if arguments.get("alignment", "min_max") != "min_max":
        words.append(f"alignment={arguments['alignment']!r}")
    if arguments.get("locked"):
        words.append(f"locked={arguments['locked']!r}")
    if arguments.get("tolerance") is not None:
        words.append(f"tolerance={arguments['tolerance']!r}")
    if arguments.get("zone_offset"):
        words.append(f"zone_offset={arguments['zone_offset']!r}")
    if arguments.get("datums"):
        words.append(f"datums={tuple(arguments['datums'])!r}")
    if arguments.get("uncertainty") is not None:
        words.append(f"uncertainty={arguments['uncertainty']!r}")
    return [f"inspection = cmmsampling.inspect({', '.join(words)})",
            f"group = cmmsampling.add_inspection_to_document(inspection, {doc}, source={source})"]


def report_inspection(inspection):
    """The inspection's summary and its alignment in the Report view, its profile, verdict and the
    motions its points do not hold in the status bar (a model's characteristics judged: the
    first-article table in the Report view, its last line in the status bar)."""
    if isinstance(inspection, MbdInspection):
        table = inspection.table()
        for line in table.splitlines() + [f"not judged: {line}" for line in inspection.not_judged()]:
            FreeCAD.Console.PrintMessage(f"cmmsampling: {line}\n")
        FreeCADGui.getMainWindow().statusBar().showMessage(f"First article: {table.splitlines()[-1]}", 20000)
        return
    for line in inspection.summary().splitlines():
        FreeCAD.Console.PrintMessage(f"cmmsampling: {line}\n")
    FreeCAD.Console.PrintMessage(f"cmmsampling: alignment (measured -> CAD, applied to the points; the part is "
                                 f"not moved): {placement_text(inspection.placement)}\n")
    verdict = verdict_words(inspection)
    free = f"; motions the points do not hold: {', '.join(inspection.free_motions)}" if inspection.free_motions else ""
    FreeCADGui.getMainWindow().statusBar().showMessage(
        f"Inspection of {len(inspection.labels)} measured points: profile {inspection.profile:.4f} mm{verdict}{free}",
        20000)


def placement_text(placement):
    """A placement in words: 'shift (x, y, z) mm, turned <angle> deg about (i, j, k)'."""
    shift, rotation = placement.Base, placement.Rotation
    axis = rotation.Axis
    return (f"shift ({shift.x:.4f}, {shift.y:.4f}, {shift.z:.4f}) mm, turned {math.degrees(rotation.Angle):.4f} "
            f"deg about ({axis.x:.4f}, {axis.y:.4f}, {axis.z:.4f})")


class BackgroundInspection(BackgroundTask):
    """cmmsampling.inspect of what was planned (a Planned, read from the document by the GUI
    thread) with the dialog's arguments, in a daemon thread (model: (file, characteristic ids) of
    a QIF MBD model's plan, each characteristic judged); ``message`` the phase under way,
    ``steps`` the alignment's steps so far; ``cancel()`` stops it at its next phase or step."""

    def __init__(self, planned, arguments, model=None):
        super().__init__("cmmsampling-inspection")
        self.planned, self.arguments, self.model = planned, dict(arguments), model
        self.message, self.steps, self.inspection = "starting", 0, None

    def cancel(self):
        self._stop.set()

    def _progress(self, message):
        if message is None:
            self.steps += 1
        else:
            self.message = message
        return self.cancelled

    def _work(self):
        if self.model is not None:
            path, ids = self.model
            self.inspection = inspect_model_file(path, ids, self.planned, progress=self._progress, **self.arguments)
            return
        self.inspection = inspect(self.planned, progress=self._progress, **self.arguments)


def run_with_progress(points, arguments):
    """Inspect the points' measurement in the background behind a progress dialog with Cancel:
    the Inspection, None when the user cancelled (nothing judged), or the run's exception raised
    here."""
    model = getattr(points, "MbdFile", "")
    stated_model = (model, planned_ids(points)) if model else None
    run = BackgroundInspection(points.Proxy.planned(points), arguments, stated_model)
    cancelled = behind_progress(run, "Inspect measured points", "InspectionProgress", lambda: (
        f"Inspecting the measured points of {points.Label}: {run.message}"
        + (f", step {run.steps}" if run.steps else "") + "..."))
    if cancelled or isinstance(run.error, InspectionCancelled):
        return None
    if run.error is not None:
        raise run.error
    return run.inspection


def show_busy(points):
    """Say in the status bar which probe points' measurement is being inspected, before the work
    holds the GUI."""
    FreeCADGui.getMainWindow().statusBar().showMessage(f"Inspecting the measured points of {points.Label}...")
    QtGui.QApplication.processEvents()
