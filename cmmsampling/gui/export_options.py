"""The options every export format honours, asked in a small dialog before probe points are written.

The frame of the coordinates (the document's global frame, or a local coordinate system of the
document: the part's measurement frame), the probe radius (0: contact points on the face; r > 0:
probe-ball centres p + r n, stated in the file) and the point order (as optimised, or a short probe
path). :func:`ask_export_options` returns them as keyword arguments of ``cmmsampling.export``,
which :func:`export_keywords` turns into the echoed call's text; :func:`show_export_report`
tells the user what was written. The values persist in the workbench's parameter group: the
frame for the document it belongs to only, the probe radius where the points do not bring their
own probe; the dialog says where its starting values come from.
"""
import json

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

from . import icon, settings
from .qt_compat import run_modal

GLOBAL = "Global (document)"
# Document objects that are coordinate systems; types unknown to this FreeCAD are never matched.
FRAME_TYPES = ("PartDesign::CoordinateSystem", "Part::LocalCoordinateSystem", "App::Placement")
# The orders offered for probe points in the document; "probe_path" only for points sampled with
# the part, whose probe reaches every one.
ORDER_TEXTS = {"as_optimised": "As optimised",
               "short_path": "Short probe path (nearest neighbour + 2-opt)",
               "probe_path": "Collision-free probe path (moves around the part)"}
DEFAULTS = {"ExportFrame": "", "ExportProbeRadius": 0.0, "ExportOrder": "short_path"}
MAX_RADIUS_MM = 100.0
RADIUS_DECIMALS = 3
STATUS_MS = 20000


def frame_objects(doc):
    """The document's coordinate systems (FRAME_TYPES), in document order."""
    return [obj for obj in doc.Objects if any(obj.isDerivedFrom(kind) for kind in FRAME_TYPES)]


def frame_expression(obj):
    """The console expression of a document object, e.g. "App.getDocument('D').getObject('LCS')"."""
    return f"App.getDocument({obj.Document.Name!r}).getObject({obj.Name!r})"


def frame_tip(obj):
    """A frame's type, origin (mm) and axes in global coordinates, for its tooltip."""
    placement = obj.getGlobalPlacement()
    rotation = placement.Rotation
    axes = ", ".join(f"{name} ({v.x:.4g}, {v.y:.4g}, {v.z:.4g})" for name, v in zip(
        "xyz", (rotation.multVec(FreeCAD.Vector(*axis)) for axis in ((1, 0, 0), (0, 1, 0), (0, 0, 1)))))
    origin = placement.Base
    return (f"{obj.Label} ({obj.TypeId}): origin ({origin.x:.4g}, {origin.y:.4g}, {origin.z:.4g}) mm, "
            f"axes {axes} in the document's global frame")


def frame_setting(doc, name):
    """The stored form of a frame: '<document's file or name>|<object name>' ('' for global)."""
    return f"{doc.FileName or doc.Name}|{name}" if name else ""


def own_probe(points):
    """The probe settings (dict of cmmsampling.Probe's fields) probe points were sampled with (for
    a part plan's group: its first face's), or None."""
    from ..document.object_types import is_part_plan, plan_probe_points

    members = plan_probe_points(points) if is_part_plan(points) else [points]
    text = getattr(members[0], "Probe", "") if members else ""
    return json.loads(text) if text else None


def export_keywords(options):
    """The options of :func:`ask_export_options` as keyword text for the echoed export call, e.g.
    ", frame=App.getDocument('D').getObject('LCS'), probe_radius=1.5, order='short_path'";
    the defaults of cmmsampling.export (global frame, contact points, as optimised) are left out."""
    words = []
    if options["frame"] is not None:
        words.append(f"frame={frame_expression(options['frame'])}")
    if options["probe_radius"] > 0:
        words.append(f"probe_radius={options['probe_radius']!r}")
    if options["order"] != "as_optimised":
        words.append(f"order={options['order']!r}")
    return "".join(f", {word}" for word in words)


def show_export_report(report):
    """Tell the user what an export wrote (an ExportReport, in words: the file, the frame, the
    probe path and what the short path saved): in the Report view and the status bar."""
    say(str(report))


def say(line):
    """Tell the user what a command did, in one line: in the Report view and the status bar."""
    FreeCAD.Console.PrintMessage(line + "\n")
    FreeCADGui.getMainWindow().statusBar().showMessage(line, STATUS_MS)


class ExportOptionsDialog(QtGui.QDialog):
    """The export options for probe points of a document, starting from the stored values.
    title: what is exported, for the window title; probe_path: offer the collision-free probe
    path (the points were sampled with the part and the probe reaches them all); probe: the probe
    settings (dict) the points were sampled with, whose ball radius the dialog starts with."""

    def __init__(self, doc, title, parent=None, probe_path=False, probe=None):
        super().__init__(parent)
        self.setObjectName("ExportOptions")
        self.setWindowTitle(f"Export options: {title}")
        self.setWindowIcon(QtGui.QIcon(icon("Export.svg")))
        self.doc = doc
        stored = settings.load(DEFAULTS)
        layout = QtGui.QFormLayout(self)
        self.frame = QtGui.QComboBox(self)
        self.frame.setObjectName("frame")
        self.frame.addItem(GLOBAL, None)
        self.frame.setItemData(0, "Coordinates in the document's global frame: the face's "
                                  "placement applied.", QtCore.Qt.ToolTipRole)
        for obj in frame_objects(doc):
            self.frame.addItem(obj.Label, obj.Name)
            self.frame.setItemData(self.frame.count() - 1, frame_tip(obj), QtCore.Qt.ToolTipRole)
            if frame_setting(doc, obj.Name) == stored["ExportFrame"]:
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
        self.probe_radius.setValue(probe["ball_diameter"] / 2 if probe else stored["ExportProbeRadius"])
        self.probe_radius.setToolTip(
            "Probe-ball radius r: above 0 a CSV or XYZ file holds ball centres p + r n (n the outward "
            "approach vector; CSV says so in its header, an XYZ file has none: keep the radius with "
            "it), a DMIS program keeps the contact points (its FEAT/PTMEAS are surface points, the CMM "
            "takes the radius off) and states r. 0: the contact points on the face.")
        layout.addRow("Probe radius", self.probe_radius)
        self.order = QtGui.QComboBox(self)
        self.order.setObjectName("order")
        for name, text in ORDER_TEXTS.items():
            if name != "probe_path" or probe_path:
                self.order.addItem(text, name)
        found = self.order.findData(stored["ExportOrder"])
        self.order.setCurrentIndex(found if found >= 0 else self.order.findData("short_path"))
        self.order.setToolTip(
            "As optimised: the order of the sampling result (P1, P2, ...). Short probe path: the "
            "points reordered along a short open path in 3D (nearest neighbour, then 2-opt), never "
            "longer than the original; the saving is reported after the export. Collision-free "
            "probe path (points sampled with the part): each point approached along the probe "
            "axis its run chose, and moves that would hit the part go over a clearance plane; a "
            "DMIS file gets the sensors and the GOTO moves.")
        layout.addRow("Point order", self.order)
        self.origin = QtGui.QLabel(self.origin_text(probe), self)
        self.origin.setObjectName("origin")
        self.origin.setWordWrap(True)
        self.origin.setStyleSheet("color: gray")
        layout.addRow(self.origin)
        buttons = QtGui.QDialogButtonBox(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel,
                                         parent=self)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout.addRow(buttons)

    def origin_text(self, probe):
        """Where the starting values come from, in one line under the fields."""
        frame = ("the frame of this document's last export" if self.frame.currentIndex() > 0
                 else "the document's global frame")
        radius = (f"the {probe['ball_diameter']:g} mm ball of the probe these points were planned with"
                  if probe else "the radius of the last export")
        return f"Starting from {frame} and {radius}."

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
    one of ORDER_TEXTS ("probe_path" offered only for points with a probe path, see
    :func:`has_probe_path`)}, keyword arguments of cmmsampling.export; see :func:`export_keywords`
    for their console text."""
    groups = [o.Label for o in points.InList if o.isDerivedFrom("App::DocumentObjectGroup")]
    dialog = ExportOptionsDialog(points.Document, (groups or [points.Label])[0], FreeCADGui.getMainWindow(),
                                 probe_path=has_probe_path(points), probe=own_probe(points))
    try:
        if run_modal(dialog) != QtGui.QDialog.Accepted:
            return None
        settings.save(dialog.stored())
        return dialog.options()
    finally:
        dialog.deleteLater()


def has_probe_path(points):
    """True when a probe-points object was sampled with the part, its probe reaches every point
    and the part is still there (for a part plan's group: every face's points): its export may
    follow the collision-free probe path."""
    return points.Proxy.follows_probe(points)