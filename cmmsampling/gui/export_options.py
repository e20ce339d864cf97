"""The options every export format honours, asked in a small dialog before probe points are written.

The frame of the coordinates (the document's global frame, or a local coordinate system of the
document: the part's measurement frame), the probe radius (0: contact points on the face; r > 0:
probe-ball centres p + r n, stated in the file) and the point order (as optimised, a short probe
path, or the collision-free probe path of points planned with a probe). The dialog opens on the
options File > Export writes with (cmmsampling.document.export_defaults.starting_options), so that
OK gives the same file; :func:`ask_export_options` returns the chosen ones as keyword arguments of
``cmmsampling.export``, :func:`show_export_report` tells the user what was written. The values
persist in the workbench's parameter group; the dialog says where its starting values come from.
"""
import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

from ..document.export_defaults import frame_objects, frame_setting, own_probe, starting_options
from . import icon
from .qt_compat import asked

GLOBAL = "Global (document)"
# The orders offered for probe points in the document; "probe_path" only for points sampled with
# the part, whose probe reaches every one.
ORDER_TEXTS = {"as_optimised": "As optimised",
               "short_path": "Short probe path (nearest neighbour + 2-opt)",
               "probe_path": "Collision-free probe path (moves around the part)"}
MAX_RADIUS_MM = 100.0
RADIUS_DECIMALS = 3
STATUS_MS = 20000


def frame_tip(obj):
    """A frame's type, origin (mm) and axes in global coordinates, for its tooltip."""
    placement = obj.getGlobalPlacement()
    rotation = placement.Rotation
    axes = ", ".join(f"{name} ({v.x:.4g}, {v.y:.4g}, {v.z:.4g})" for name, v in zip(
        "xyz", (rotation.multVec(FreeCAD.Vector(*axis)) for axis in ((1, 0, 0), (0, 1, 0), (0, 0, 1)))))
    origin = placement.Base
    return (f"{obj.Label} ({obj.TypeId}): origin ({origin.x:.4g}, {origin.y:.4g}, {origin.z:.4g}) mm, "
            f"axes {axes} in the document's global frame")


def show_export_report(report):
    """Tell the user what an export wrote (an ExportReport, in words: the file, the frame, the
    probe path and what the short path saved): in the Report view and the status bar."""
    say(str(report))


def say(line):
    """Tell the user what a command did, in one line: in the Report view and the status bar."""
    FreeCAD.Console.PrintMessage(line + "\n")
    FreeCADGui.getMainWindow().statusBar().showMessage(line, STATUS_MS)


class ExportOptionsDialog(QtGui.QDialog):
    """The export options for a probe-points object or a part plan's group, starting from the
    options File > Export writes with (cmmsampling.document.export_defaults.starting_options).
    title: what is exported, for the window title. The collision-free probe path is offered
    where the points were sampled with the part and the probe reaches them all."""

    def __init__(self, points, title, parent=None):
        super().__init__(parent)
        self.setObjectName("ExportOptions")
        self.setWindowTitle(f"Export options: {title}")
        self.setWindowIcon(QtGui.QIcon(icon("Export.svg")))
        self.doc = doc = points.Document
        start, probe = starting_options(points), own_probe(points)
        layout = QtGui.QFormLayout(self)
        self.frame = QtGui.QComboBox(self)
        self.frame.setObjectName("frame")
        self.frame.addItem(GLOBAL, None)
        self.frame.setItemData(0, "Coordinates in the document's global frame: the face's "
                                  "placement applied.", QtCore.Qt.ToolTipRole)
        for obj in frame_objects(doc):
            self.frame.addItem(obj.Label, obj.Name)
            self.frame.setItemData(self.frame.count() - 1, frame_tip(obj), QtCore.Qt.ToolTipRole)
            if obj == start["frame"]:
                self.frame.setCurrentIndex(self.frame.count() - 1)
        self.frame.setToolTip(
            "The coordinate system the points and approach vectors are written in: the document's "
            "global frame, or a coordinate system of the document (a datum coordinate system or a "
            "placement: the part's measurement frame). Its origin and axes are stated in the file.")
        layout.addRow("Coordinates", self.frame)
        self.probe_radius = QtGui.QDoubleSpinBox(self)
        self.probe_radius.setObjectName("probe_radius")
        self.probe_radius.setRange(0.0, MAX_RADIUS_MM)
        self.probe_radius.setDecimals(RADIUS_DECIMALS)
        self.probe_radius.setSuffix(" mm")
        self.probe_radius.setSpecialValueText("0 mm: contact points")
        self.probe_radius.setValue(start["probe_radius"])
        self.probe_radius.setToolTip(
            "Probe-ball radius r: above 0 a CSV or XYZ file holds ball centres p + r n (n the outward "
            "approach vector; CSV says so in its header, an XYZ file has none: keep the radius with "
            "it), a DMIS program keeps the contact points (its FEAT/PTMEAS are surface points, the CMM "
            "takes the radius off) and states r. 0: the contact points on the face.")
        layout.addRow("Probe radius", self.probe_radius)
        self.order = QtGui.QComboBox(self)
        self.order.setObjectName("order")
        for name, text in ORDER_TEXTS.items():
            if name != "probe_path" or start["order"] == "probe_path":
                self.order.addItem(text, name)
        self.order.setCurrentIndex(self.order.findData(start["order"]))
        self.order.setToolTip(
            "As optimised: the order of the sampling result (P1, P2, ...). Short probe path: the "
            "points reordered along a short open path in 3D (nearest neighbour, then 2-opt), never "
            "longer than the original; the saving is reported after the export. Collision-free "
            "probe path (points sampled with the part): each point approached along the probe "
            "axis its run chose, and moves that would hit the part go over a clearance plane; a "
            "DMIS file gets the sensors and the GOTO moves.")
        layout.addRow("Point order", self.order)
        self.origin = QtGui.QLabel(self.origin_text(probe, start["order"] == "probe_path"), self)
        self.origin.setObjectName("origin")
        self.origin.setWordWrap(True)
        self.origin.setStyleSheet("color: gray")
        layout.addRow(self.origin)
        buttons = QtGui.QDialogButtonBox(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel,
                                         parent=self)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout.addRow(buttons)

    def origin_text(self, probe, probe_path):
        """Where the starting values come from, in one line under the fields: probe, the probe
        settings (dict) the points were planned with or None; probe_path: starting along it."""
        frame = ("the frame of this document's last export" if self.frame.currentIndex() > 0
                 else "the document's global frame")
        radius = (f"the {probe['ball_diameter']:g} mm ball of the probe these points were planned with"
                  if probe else "the radius of the last export")
        order = "the probe's collision-free path" if probe_path else "the order of the last export"
        return f"Starting from {frame}, {radius} and {order}: what File > Export writes."

    def options(self):
        """{"frame": the frame's document object or None (global), "probe_radius": mm,
        "order": one of ORDER_TEXTS}: keyword arguments of cmmsampling.export."""
        name = self.frame.currentData()
        return {"frame": None if name is None else self.doc.getObject(name),
                "probe_radius": self.probe_radius.value(), "order": self.order.currentData()}

    def stored(self):
        """The values to keep for the next export."""
        return {"ExportFrame": frame_setting(self.doc, self.frame.currentData()),
                "ExportProbeRadius": self.probe_radius.value(), "ExportOrder": self.order.currentData()}


def ask_export_options(points):
    """Ask the export options for a probe-points object or a part plan's group; None when the
    user cancels.

    Returns {"frame": a coordinate system's document object or None, "probe_radius": mm, "order":
    one of ORDER_TEXTS ("probe_path" offered only for points with a probe path)}, keyword
    arguments of cmmsampling.export; see cmmsampling.document.export_defaults.export_keywords for
    their console text."""
    groups = [o.Label for o in points.InList if o.isDerivedFrom("App::DocumentObjectGroup")]
    dialog = ExportOptionsDialog(points, (groups or [points.Label])[0], FreeCADGui.getMainWindow())
    return asked(dialog, ExportOptionsDialog.options)

