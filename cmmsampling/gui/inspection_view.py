"""The view of an inspection's measured points: each point a dot coloured by its band in the
tolerance zone (or, without a tolerance, by |deviation| on the deviation colours), its label, and
a legend in mm.

Attached by cmmsampling.document.inspections when ``FreeCAD.GuiUp``; it only draws what the
measured-points object holds.
"""
import numpy as np
from pivy import coin
from PySide import QtCore

from ..document.object_types import is_measured_points
from ..fitting.deviation import mm_text
from ..inspection.result import band_limits
from . import colormap, icon, labels
from .view_providers import LABEL_COLOUR, Annotated, hide_other_legends

# Band colours, -2 .. 2: out below, near below, in, near above, out above.
BAND_COLOURS = ((0.0, 0.2, 1.0), (0.0, 0.8, 1.0), (0.0, 0.75, 0.0), (1.0, 0.7, 0.0), (1.0, 0.0, 0.0))
MANY_LABELS = 60


class ViewProviderMeasuredPoints(Annotated):
    """Draws the measured points as dots over the part, coloured by their band in the tolerance
    zone (out below, near below, in, near above, out above, with their limits in mm in the
    legend) or, without a tolerance, by |deviation| from 0 to the largest (mm); their labels when
    ShowLabels (off from MANY_LABELS points). The legend sits at the view's right edge, apart from
    a substitute's at the left, and the dots are drawn over it; one inspection's legend shows at
    a time (the newest's, or the one switched on with ShowLegend)."""

    def __init__(self, vobj):
        vobj.addProperty("App::PropertyBool", "ShowLabels", "Measured points", "Show the point labels")
        vobj.addProperty("App::PropertyBool", "ShowLegend", "Measured points", "Show the colour legend (mm)")
        vobj.ShowLabels = len(vobj.Object.Labels) < MANY_LABELS
        vobj.ShowLegend = True
        vobj.PointSize = 4
        vobj.Proxy = self
        hide_other_legends(vobj.Object, is_measured_points)

    def updateData(self, obj, prop):
        if prop in ("Points", "Bands", "Deviation", "Tolerance", "ZoneOffset", "Profile", "Verdict", "Uncertainty",
                    "Decision") and \
                obj.ViewObject is not None:
            self.redraw(obj.ViewObject)

    def onChanged(self, vobj, prop):
        if prop == "Visibility":
            self.follow_visibility(vobj)
        elif prop in ("ShowLabels", "ShowLegend"):
            if prop == "ShowLegend" and vobj.ShowLegend and not vobj.Object.Document.Restoring:
                hide_other_legends(vobj.Object, is_measured_points)
            self.redraw(vobj)

    def redraw(self, vobj):
        """Rebuild the dots, labels and legend from the object's Points, Deviation and Bands."""
        if not hasattr(self, "annotation") or not hasattr(vobj, "ShowLegend"):
            return
        self.annotation.removeAllChildren()
        obj = vobj.Object
        points = np.array([tuple(p) for p in obj.Points], dtype=float).reshape(-1, 3)
        deviations = np.array(obj.Deviation, dtype=float)
        if len(points) == 0 or len(deviations) != len(points):
            return
        tolerance = float(obj.Tolerance.Value)
        if tolerance > 0:
            rgb = np.array(BAND_COLOURS)[np.array(obj.Bands, dtype=int) + 2]
            legend = colormap.band_legend(band_rows(tolerance, float(obj.ZoneOffset.Value)), legend_lines(obj),
                                          right=True)
        else:
            largest = colormap.shown_maximum(np.abs(deviations).max())
            rgb = colormap.colours(np.abs(deviations), largest)
            legend = colormap.legend(largest, f"|Deviation| of {obj.Label}", right=True)
        if vobj.ShowLegend:
            self.annotation.addChild(legend)
        self.annotation.addChild(dots(points, rgb))
        if vobj.ShowLabels:
            self.annotation.addChild(labels.decluttered(list(obj.Labels), points, 12, LABEL_COLOUR)[0])

    def getIcon(self):
        return icon("Inspect.svg")


def legend_lines(obj):
    """The title of a judged inspection's legend, the decision first: [ISO 14253-1's decision
    with U, the profile and tolerance, the profile's own verdict] where an uncertainty was given,
    else [the verdict, the profile and tolerance]. obj: measured points."""
    offset = float(obj.ZoneOffset.Value)
    zone = f" (offset {offset:+g} mm)" if offset else ""
    profile = f"profile {mm_text(obj.Profile.Value)}, tolerance {float(obj.Tolerance.Value):g} mm{zone}"
    if getattr(obj, "Uncertainty", None) is not None and obj.Uncertainty.Value > 0:
        return [f"{obj.Decision} (ISO 14253-1, U {mm_text(obj.Uncertainty.Value)})", profile,
                f"the profile alone: {obj.Verdict}"]
    return [obj.Verdict, profile]


def band_rows(tolerance, offset=0.0):
    """The legend's rows [(rgb, text)] of a tolerance t mm centred at offset mm, top down: out
    above (> offset + t/2), near above, in, near below, out below, with their limits in mm."""
    low, near_low, near_high, high = (f"{value:+.4f}" for value in band_limits(tolerance, offset))
    texts = (f"out below: < {low} mm", f"near: {low} .. {near_low} mm", f"in: {near_low} .. {near_high} mm",
             f"near: {near_high} .. {high} mm", f"out above: > {high} mm")
    return list(zip(BAND_COLOURS, texts))[::-1]


def dots(points, rgb):
    """Filled circles at points (N, 3) mm in colours rgb (N, 3), drawn over the part (an
    annotation) and not pickable (the object's own vertices are)."""
    node = coin.SoAnnotation()
    pick = coin.SoPickStyle()
    pick.style = coin.SoPickStyle.UNPICKABLE
    material = coin.SoMaterial()
    material.diffuseColor.setValues(0, len(rgb), [tuple(map(float, c)) for c in rgb])
    binding = coin.SoMaterialBinding()
    binding.value = coin.SoMaterialBinding.PER_VERTEX
    light = coin.SoLightModel()
    light.model = coin.SoLightModel.BASE_COLOR
    coordinates = coin.SoCoordinate3()
    coordinates.point.setValues(0, len(points), [tuple(map(float, p)) for p in points])
    marker = coin.SoMarkerSet()
    marker.markerIndex = coin.SoMarkerSet.CIRCLE_FILLED_9_9
    marker.numPoints = len(points)
    outline = coin.SoMarkerSet()
    outline.markerIndex = coin.SoMarkerSet.CIRCLE_LINE_9_9
    outline.numPoints = len(points)
    ring = coin.SoSeparator()
    ring_colour = coin.SoBaseColor()
    ring_colour.rgb = LABEL_COLOUR
    for child in (ring_colour, outline):
        ring.addChild(child)
    for child in (pick, light, coordinates, material, binding, marker, ring):
        node.addChild(child)
    return node


def attach_when_missing(obj):
    """Give measured points restored from a document saved headless their view provider, once the
    document has finished loading."""
    QtCore.QTimer.singleShot(0, lambda: _attach_if_missing(obj))


def _attach_if_missing(obj):
    try:
        vobj = obj.ViewObject
    except ReferenceError:
        return
    if vobj is None or isinstance(getattr(vobj, "Proxy", None), ViewProviderMeasuredPoints):
        return
    if is_measured_points(obj):
        provider = ViewProviderMeasuredPoints(vobj)
        if not hasattr(provider, "Object"):
            provider.attach(vobj)
