"""View providers: probe points with labels and approach vectors, the deviation-coloured substitute.

Attached by :mod:`cmmsampling.document` when ``FreeCAD.GuiUp``; they only draw what the
document objects hold.
"""
import FreeCAD
import numpy as np
from pivy import coin
from scipy.interpolate import RegularGridInterpolator
from scipy.ndimage import distance_transform_edt
from scipy.spatial import cKDTree
from PySide import QtCore, QtGui

from ..fitting.deviation import NUMERICAL_ZERO_MM, mm_text
from ..geometry.domain import inside_loops
from ..geometry.surface import SurfaceModel
from ..document.object_types import is_part_plan, is_probe_points, is_substitute_surface, plan_probe_points, source_face
from . import colormap, icon, labels

LABEL_COLOUR = (0.0, 0.0, 0.0)
APPROACH_COLOUR = (0.75, 0.05, 0.05)
POINT_COLOUR = (0.75, 0.05, 0.05)
APPROACH_FRACTION = 0.05
DEFAULT_APPROACH_MM = 5.0
# Tessellation tolerance of the coloured face, as a fraction of its diagonal.
TESSELLATION_FRACTION = 2e-3
# A tessellation point and its triangulation node are matched when they lie this share of the
# face's diagonal apart at most: the points on the edges come from the edges' polygons, off the
# surface by up to the edges' tolerance (on the Ventilator up to 4 um, 0.27 % of a 1 mm face).
UV_MATCH_FRACTION = 1e-2
POINT_VIEW_PROPERTIES = ("ShowLabels", "ShowApproach", "ApproachLength", "LabelSize")
# The shade over the regions a probe cannot reach: colour, transparency, and the quads across the
# face's parameter range that follow its curvature.
UNREACHED_COLOUR = (0.55, 0.55, 0.55)
UNREACHED_TRANSPARENCY = 0.35
UNREACHED_QUADS = 64
# The mark at the largest deviation: a filled circle and its value beside it.
MAXIMUM_COLOUR = (0.0, 0.0, 0.0)


class Stateless:
    """A view provider that saves nothing with the document (FreeCAD 0.20 and 0.21+ names)."""

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    def dumps(self):
        return None

    def loads(self, state):
        return None


class Annotated(Stateless):
    """A view provider that draws its own coin nodes (``self.annotation``) below the object's root
    node, shown while the object is visible; subclasses give redraw(vobj)."""

    def attach(self, vobj):
        """Add the annotation below the object's root node and draw it."""
        self.Object = vobj.Object
        self.switch = coin.SoSwitch()
        self.annotation = coin.SoSeparator()
        self.switch.addChild(self.annotation)
        self.switch.whichChild = 0 if vobj.Visibility else -1
        vobj.RootNode.addChild(self.switch)
        self.redraw(vobj)

    def follow_visibility(self, vobj):
        """Show or hide the annotation with the object (onChanged of Visibility)."""
        if hasattr(self, "switch"):
            self.switch.whichChild = 0 if vobj.Visibility else -1

    def redraw(self, vobj):
        """Rebuild the annotation from the object's data."""
        raise NotImplementedError


class ViewProviderProbePoints(Annotated):
    """Draws the probe points as vertices (the Part view), each with its approach vector (a line
    along the outward normal, ``ApproachLength`` mm long) and labels P1..PN. Labels are drawn
    over the surface (never hidden behind it) and thinned so that they keep apart on screen at any
    zoom (:mod:`cmmsampling.gui.labels`; ``LabelSpacing`` mm: none closer however far the view
    zooms in, 0: all of them once it zooms in far enough); hovering a point
    names it in the status bar. Points sampled with the part shade the regions of the face the
    probe cannot reach in grey (``ShowUnreached``)."""

    def __init__(self, vobj):
        vobj.addProperty("App::PropertyBool", "ShowLabels", "Probe points", "Show the labels P1..PN")
        vobj.addProperty("App::PropertyBool", "ShowApproach", "Probe points",
                         "Show the approach vectors (outward normals)")
        vobj.addProperty("App::PropertyLength", "ApproachLength", "Probe points",
                         "Length of the drawn approach vectors (mm)")
        vobj.addProperty("App::PropertyInteger", "LabelSize", "Probe points", "Label font size (pixels)")
        vobj.addProperty("App::PropertyLength", "LabelSpacing", "Probe points",
                         "No labels closer than this (mm), however far the view zooms in; 0: all of them, zoomed in "
                         "far enough (fewer are drawn as the view zooms out, so that they keep apart)")
        vobj.addProperty("App::PropertyBool", "ShowUnreached", "Probe points",
                         "Shade the regions of the face the probe cannot reach (points sampled with the part)")
        vobj.ShowUnreached = True
        vobj.ShowLabels = True
        vobj.ShowApproach = True
        vobj.ApproachLength = approach_length(vobj.Object)
        vobj.LabelSize = 13
        vobj.LabelSpacing = 0.0
        vobj.PointSize = 6
        vobj.PointColor = POINT_COLOUR
        vobj.Proxy = self

    def updateData(self, obj, prop):
        if prop in ("Points", "Normals", "Labels", "Unreached", "UnreachedArea") and obj.ViewObject is not None:
            self.redraw(obj.ViewObject)

    def onChanged(self, vobj, prop):
        if prop == "Visibility":
            self.follow_visibility(vobj)
        elif prop in POINT_VIEW_PROPERTIES + ("LabelSpacing", "ShowUnreached"):
            self.redraw(vobj)

    def redraw(self, vobj):
        """Rebuild the labels and approach lines from the object's Points, Normals and Labels."""
        if not hasattr(self, "annotation") or not all(hasattr(vobj, p) for p in POINT_VIEW_PROPERTIES):
            return
        self.annotation.removeAllChildren()
        obj = vobj.Object
        points = np.array([tuple(p) for p in obj.Points], dtype=float).reshape(-1, 3)
        normals = np.array([tuple(n) for n in obj.Normals], dtype=float).reshape(-1, 3)
        if len(points) == 0 or len(normals) != len(points):
            return
        tips = points + normals * float(vobj.ApproachLength.Value)
        pick = coin.SoPickStyle()
        pick.style = coin.SoPickStyle.UNPICKABLE
        self.annotation.addChild(pick)
        if vobj.ShowApproach:
            self.annotation.addChild(approach_lines(points, tips))
        if vobj.ShowLabels:
            self.annotation.addChild(self.label_levels(vobj, tips))
        rectangles = np.reshape(getattr(obj, "Unreached", []), (-1, 4))
        if getattr(vobj, "ShowUnreached", True) and len(rectangles):
            face = source_face(obj)[0]
            if face is not None:
                self.annotation.addChild(unreached_shade(face, rectangles))
                self.annotation.addChild(unreached_key(obj))

    def label_levels(self, vobj, tips):
        """The labels at tips (N, 3) mm as levels that keep apart on screen at any zoom
        (:mod:`cmmsampling.gui.labels`): over the part's box for a plan's points (all its
        faces then pick the same level, and keep apart from the labels the plan's other faces
        draw at it), else of the points; away from the max label drawn near them. Keeps the
        ladder of spacings (mm, finest first) and each level's indices (``levels``)."""
        obj = vobj.Object
        plan = plan_holding(obj)
        corners = part_box(obj) if plan is not None else None
        box = labels.points_box(tips if corners is None else corners)
        floor = label_spacing(vobj)
        ladder = labels.spacings(float(np.linalg.norm(box[1] - box[0])), floor)
        taken = None
        if plan is not None:
            others = [getattr(other.ViewObject.Proxy, "level_tips", None) for other in plan_probe_points(plan)
                      if other is not obj and other.ViewObject is not None
                      and getattr(other.ViewObject.Proxy, "ladder", None) == ladder]
            others = [levels for levels in others if levels]
            taken = [np.concatenate([levels[k] for levels in others]) for k in range(len(ladder))] if others else None
        node, self.ladder, self.levels = labels.decluttered(list(obj.Labels), tips, vobj.LabelSize, LABEL_COLOUR,
                                                            floor, box, taken, labelled_maximum(obj, plan))
        self.level_tips = [tips[shown] for shown in self.levels]
        return node

    def doubleClicked(self, vobj):
        """Open Sample face again on the points' face with the values of their run."""
        from .panels.sample_face import reopen

        return reopen(vobj.Object) is not None

    def setupContextMenu(self, vobj, menu):
        """'Sample again...' in the tree's context menu: what a double click does."""
        text = FreeCAD.Qt.translate("CMMSampling", "Sample again...")
        action = menu.addAction(QtGui.QIcon(icon("SampleFace.svg")), text)
        action.triggered.connect(lambda: self.doubleClicked(vobj))

    def getIcon(self):
        return icon("ProbePoints.svg")


class ViewProviderSubstituteSurface(Stateless):
    """Draws the deviation of the substitute surface from the CAD face as colours on the CAD
    face itself ("Deviation" display mode, the default: its own tessellation, smooth along
    trimmed edges, drawn over the part), with a colour legend in mm titled with the face's name.
    The substitutes of one part plan share one scale, from 0 to the plan's largest maximum, and
    their legend is titled with the plan's name.
    Where the source face is gone, the substitute's evaluation grid is drawn instead. The Part
    display modes stay available (they show the substitute over the face's whole parameter range).

    The legends of all substitutes sit in the same corner of the 3D view, so one is shown at a
    time: a new substitute's legend, or one switched on with ShowLegend, hides the others'.
    """

    def __init__(self, vobj):
        vobj.addProperty("App::PropertyBool", "ShowLegend", "Deviation", "Show the colour legend (mm)")
        vobj.ShowLegend = True
        vobj.Proxy = self
        hide_other_legends(vobj.Object)

    def attach(self, vobj):
        """Register the "Deviation" display mode."""
        self.Object = vobj.Object
        self.coloured = coin.SoSeparator()
        vobj.addDisplayMode(self.coloured, "Deviation")
        self.redraw(vobj)

    def getDisplayModes(self, vobj):
        return ["Deviation"]

    def getDefaultDisplayMode(self):
        return "Deviation"

    def setDisplayMode(self, mode):
        return mode

    def updateData(self, obj, prop):
        if prop in ("Shape", "DeviationField", "Label") and obj.ViewObject is not None:
            self.redraw(obj.ViewObject)

    def onChanged(self, vobj, prop):
        if prop == "ShowLegend":
            if vobj.ShowLegend and not vobj.Object.Document.Restoring:
                hide_other_legends(vobj.Object)
            self.redraw(vobj)

    def redraw(self, vobj):
        """Rebuild the coloured grid mesh and the legend from the object's deviation field; the
        legend reaches the reported maximum (the edge nodes' included, which the raster's field
        may not hold). While the document loads, once after it has loaded, however many of the
        object's properties (and its plan's other substitutes) arrive before."""
        if not hasattr(self, "coloured"):
            return
        if getattr(vobj.Object.Document, "Restoring", False):
            self._redraw_once_loaded(vobj)
            return
        self.coloured.removeAllChildren()
        obj = vobj.Object
        if not obj.Shape.Faces or not obj.DeviationField:
            return
        u, v, field = obj.Proxy.deviation_grid(obj)
        sharing = scale_sharers(obj)
        worst = max(float(getattr(other, "MaxDeviation", 0.0)) for other in sharing)
        maximum = self.maximum = colormap.shown_maximum(max(float(np.nanmax(field)), worst))
        redraw_others(obj, sharing, maximum)
        self.coloured.addChild(in_front())
        face = source_of(obj)
        if face is not None:
            self.coloured.addChild(face_mesh(self._tessellation(face), u, v, field, maximum))
        else:
            surface = obj.Shape.Faces[0].Surface
            nodes = np.array([tuple(surface.value(a, b)) for a in u for b in v], dtype=float)
            self.coloured.addChild(coloured_mesh(nodes, field, maximum))
        if getattr(vobj, "ShowLegend", True):
            self.coloured.addChild(colormap.legend(maximum, legend_title(obj)))
        if getattr(obj, "MaxLocation", None) is not None and obj.MaxDeviation.Value >= NUMERICAL_ZERO_MM:
            self.coloured.addChild(maximum_mark(obj.MaxLocation, obj.MaxDeviation.Value,
                                                labelled=obj.MaxDeviation.Value >= worst))

    def _redraw_once_loaded(self, vobj):
        """One redraw when the event loop next runs (the document has loaded by then)."""
        if getattr(self, "_pending", False):
            return
        self._pending = True

        def later():
            self._pending = False
            try:
                alive = vobj.Object is not None
            except (ReferenceError, RuntimeError):   # the document was closed meanwhile
                alive = False
            if alive:
                self.redraw(vobj)

        QtCore.QTimer.singleShot(0, later)

    def _tessellation(self, face):
        """face_tessellation(face), kept while the face's geometry stays the same: a redraw for a
        new scale or legend only colours the mesh again."""
        key = (face.Area, tuple(face.ParameterRange), face.BoundBox.XMin, face.BoundBox.YMin, face.BoundBox.ZMin,
               face.BoundBox.XMax, face.BoundBox.YMax, face.BoundBox.ZMax)
        kept = getattr(self, "_tessellated", None)
        if kept is None or kept[0] != key:
            kept = self._tessellated = (key, face_tessellation(face))
        return kept[1]

    def getIcon(self):
        return icon("SubstituteSurface.svg")


class ViewProviderPartPlan(Stateless):
    """The view provider of a part plan's group: its icon, and a Python proxy, without which
    FreeCAD 1.1 brings a Python group (and everything in it) back visible however it was saved."""

    def __init__(self, vobj):
        vobj.Proxy = self

    def attach(self, vobj):
        self.Object = vobj.Object

    def getIcon(self):
        return icon("PlanPart.svg")


def in_front():
    """A polygon offset that draws the substitute over the CAD face it lies on (the two
    coincide to within the deviation), so the part can stay visible beside it."""
    offset = coin.SoPolygonOffset()
    offset.factor = -2.0
    offset.units = -2.0
    return offset


def unreached_shade(face, rectangles):
    """A flat, partly transparent grey shade over the regions of ``face`` (Part.Face) a probe
    cannot reach, drawn over the face and its substitute (its key: :func:`unreached_key`).

    rectangles: (K, 4) parameter rectangles (u0, u1, v0, v1) of the face's NURBS (the probe
    points' Unreached). Each is cut into quads, about UNREACHED_QUADS across the face's parameter
    range, evaluated on the surface; on a trimmed face the quads whose centre is off the face are
    left out.
    """
    model = SurfaceModel.from_face(face)
    u0, u1, v0, v1 = model.bounds
    nodes, quads, count = [], [], 0
    for a, b, c, d in rectangles:
        count_u = max(1, int(np.ceil(UNREACHED_QUADS * (b - a) / (u1 - u0)))) + 1
        count_v = max(1, int(np.ceil(UNREACHED_QUADS * (d - c) / (v1 - v0)))) + 1
        nodes.append(np.stack(np.meshgrid(np.linspace(a, b, count_u), np.linspace(c, d, count_v),
                                          indexing="ij"), -1).reshape(-1, 2))
        quads.append(grid_quads(count_u, count_v) + count)
        count += count_u * count_v
    uv, quads = np.concatenate(nodes), np.concatenate(quads)
    if model.trimmed:
        step = model.diagonal / (4 * UNREACHED_QUADS)
        quads = quads[inside_loops(model.trim_loops(step), uv[quads].mean(axis=1))]
    node = coin.SoSeparator()
    offset = in_front()
    offset.factor = offset.units = -4.0
    material = coin.SoMaterial()
    material.diffuseColor = UNREACHED_COLOUR
    material.transparency = UNREACHED_TRANSPARENCY
    coords = coin.SoCoordinate3()
    points = model.points(uv)
    coords.point.setValues(0, len(points), [tuple(map(float, p)) for p in points])
    faces = coin.SoIndexedFaceSet()
    index = polygon_index(quads)
    faces.coordIndex.setValues(0, len(index), index)
    hints = coin.SoShapeHints()
    hints.vertexOrdering = coin.SoShapeHints.UNKNOWN_ORDERING
    flat = coin.SoLightModel()
    flat.model = coin.SoLightModel.BASE_COLOR   # one grey whatever the light: the key's swatch
    for child in (offset, hints, flat, material, coords, faces):
        node.addChild(child)
    return node


def unreached_key(points):
    """The key of the unreached shade (a colormap key below the legend): its swatch and
    'Out of the probe's reach: <area> mm^2' of the probe points' face."""
    area = float(getattr(points, "UnreachedArea", 0.0))
    return colormap.key(UNREACHED_COLOUR, f"Out of the probe's reach: {area:.4g} mm^2")


def maximum_mark(location, maximum, labelled=True):
    """A filled circle at location (FreeCAD.Vector, mm) and, when labelled, 'max <maximum> mm'
    beside it, drawn over the scene (an annotation). A plan's faces label only the worst one's
    (the others' figures are in the plan's report): one text, which no zoom makes overlap
    another."""
    node = coin.SoAnnotation()
    colour = coin.SoBaseColor()
    colour.rgb = MAXIMUM_COLOUR
    coordinates = coin.SoCoordinate3()
    coordinates.point.setValue(float(location.x), float(location.y), float(location.z))
    marker = coin.SoMarkerSet()
    marker.markerIndex = coin.SoMarkerSet.CIRCLE_FILLED_9_9
    marker.numPoints = 1
    for child in (colour, coordinates, marker):
        node.addChild(child)
    if labelled:
        label = colormap.text_node(MAXIMUM_COLOUR, colormap.FONT_SIZE)
        label.addChild(colormap.text_at(f"  max {mm_text(maximum)}", (float(location.x), float(location.y),
                                                                     float(location.z))))
        node.addChild(label)
    return node


def probe_points_of(surface):
    """The probe-points object that uses this substitute, or None."""
    return next((points for points in surface.InList if is_probe_points(points)), None)


def source_of(surface):
    """The source face (Part.Face) of the probe points that use this substitute, or None."""
    points = probe_points_of(surface)
    return None if points is None else source_face(points)[0]


def face_tessellation(face):
    """The face's tessellation for colouring: (points (M, 3) mm, triangles as a Coin polygon index,
    uv (M, 2) the points' parameters), or None where OCC gives no triangles. face: Part.Face."""
    points, triangles = face.tessellate(TESSELLATION_FRACTION * face.BoundBox.DiagonalLength)
    if not triangles:
        return None
    points = np.array([tuple(p) for p in points], dtype=float)
    return points, polygon_index(np.array(triangles)), tessellation_uv(face, points)


def tessellation_uv(face, points):
    """The parameters (M, 2) of a face's tessellation points (M, 3) mm: OCC's own, the
    triangulation's nodes (Part.Face.getUVNodes), matched to the points by position; each point
    projected on the surface (Surface.parameter, about 0.7 ms a point) where they do not match
    one to one within UV_MATCH_FRACTION of the face's diagonal."""
    nodes = np.array(face.getUVNodes() if hasattr(face, "getUVNodes") else [], dtype=float).reshape(-1, 2)
    if len(nodes) == len(points):
        at = np.array([tuple(face.valueAt(float(u), float(v))) for u, v in nodes], dtype=float)
        distances, index = cKDTree(at).query(points)
        if distances.max() <= UV_MATCH_FRACTION * face.BoundBox.DiagonalLength and len(np.unique(index)) == len(points):
            return nodes[index]
    return np.array([face.Surface.parameter(FreeCAD.Vector(*p)) for p in points], dtype=float)


def face_mesh(tessellation, u, v, field, maximum):
    """A face's tessellation (:func:`face_tessellation`) coloured per vertex by the deviation at
    its (u, v).

    u (g_u,), v (g_v,): the grid's parameters; field: (g_u, g_v) mm, NaN off the face (those nodes
    take the value of the nearest node on it); maximum: the deviation shown red (mm). Between
    nodes the deviation is interpolated linearly.
    """
    if tessellation is None or np.isnan(field).all():
        return coin.SoSeparator()
    points, index, uv = tessellation
    nearest = distance_transform_edt(np.isnan(field), return_distances=False, return_indices=True)
    filled = field[tuple(nearest)]
    values = RegularGridInterpolator((u, v), filled, bounds_error=False, fill_value=None)(uv)
    return indexed_mesh(points, index, colormap.colours(values, maximum))


def plan_of(surface):
    """The part plan's group that holds this substitute (in one of its faces' groups), or None."""
    return next((outer for holder in surface.InList for outer in getattr(holder, "InList", []) if is_part_plan(outer)),
                None)


def scale_sharers(surface):
    """The substitutes whose colours share one scale with this one: its part plan's (itself
    included), or itself alone."""
    plan = plan_of(surface)
    if plan is None:
        return [surface]
    return [points.Substitute for points in plan_probe_points(plan) if points.Substitute is not None]


def redraw_others(surface, sharing, maximum):
    """Draw again the substitutes of ``sharing`` other than ``surface`` that were drawn on another
    scale than ``maximum`` (mm): a plan's faces follow its largest maximum as it is written."""
    for other in sharing:
        proxy = getattr(getattr(other, "ViewObject", None), "Proxy", None)
        if other is not surface and getattr(proxy, "maximum", maximum) != maximum:
            proxy.redraw(other.ViewObject)


def legend_title(surface):
    """The legend's title: 'Deviation, <plan>' for a part plan's substitute (one scale for all its
    faces), else 'Deviation, <object>.<face>' of the probe points that use this substitute, or
    the substitute's label when they do not say their source."""
    plan = plan_of(surface)
    if plan is not None:
        return f"Deviation, {plan.Label}"
    points = probe_points_of(surface)
    if points is not None and points.SourceName:
        return f"Deviation, {points.SourceName.replace(':', '.')}"
    return f"Deviation, {surface.Label}"


def hide_other_legends(obj, same_kind=is_substitute_surface):
    """Switch off ShowLegend on every other object of obj's kind (``same_kind(object)``: a
    substitute surface, or an inspection's measured points) in obj's document."""
    for other in obj.Document.Objects:
        if other is obj or not same_kind(other):
            continue
        view = other.ViewObject
        if view is not None and getattr(view, "ShowLegend", False):
            view.ShowLegend = False


def attach_when_missing(obj):
    """Attach the object's view provider once the document has finished loading, unless the
    document brought one (a document saved without the GUI has none)."""
    QtCore.QTimer.singleShot(0, lambda: _attach_if_missing(obj))


def _attach_if_missing(obj):
    """Give obj its view provider unless it has one. FreeCAD marks a restored Python view
    provider without a proxy as attached (with a placeholder proxy), so attach() is called here."""
    try:
        vobj = obj.ViewObject
    except ReferenceError:
        return
    own = (ViewProviderProbePoints, ViewProviderSubstituteSurface, ViewProviderPartPlan)
    if vobj is None or isinstance(getattr(vobj, "Proxy", None), own):
        return
    if is_probe_points(obj):
        provider = ViewProviderProbePoints(vobj)
    elif is_substitute_surface(obj):
        provider = ViewProviderSubstituteSurface(vobj)
    elif is_part_plan(obj):
        provider = ViewProviderPartPlan(vobj)
    else:
        return
    if not hasattr(provider, "Object"):
        provider.attach(vobj)
    if isinstance(provider, ViewProviderSubstituteSurface):
        vobj.DisplayMode = vobj.listDisplayModes()
        vobj.DisplayMode = "Deviation"


def approach_length(obj):
    """Default length of the drawn approach vectors: 5 % of the source face's diagonal (mm)."""
    face, _ = source_face(obj) if is_probe_points(obj) else (None, None)
    if face is None:
        return DEFAULT_APPROACH_MM
    return APPROACH_FRACTION * face.BoundBox.DiagonalLength


def approach_lines(points, tips):
    """Line segments point -> tip for (N, 3) points and tips (mm), as one SoLineSet."""
    node = coin.SoSeparator()
    colour = coin.SoBaseColor()
    colour.rgb = APPROACH_COLOUR
    style = coin.SoDrawStyle()
    style.lineWidth = 2
    coords = coin.SoCoordinate3()
    ends = np.stack([points, tips], axis=1).reshape(-1, 3)
    coords.point.setValues(0, len(ends), [tuple(map(float, p)) for p in ends])
    lines = coin.SoLineSet()
    lines.numVertices.setValues(0, len(points), [2] * len(points))
    for child in (colour, style, coords, lines):
        node.addChild(child)
    return node


def redraw_plan_points(group):
    """Draw the labels and approach lines of a part plan's probe points again, now that they are
    in its group (their labels then keep apart over the whole part: :meth:`ViewProviderProbePoints.label_levels`)."""
    for points in plan_probe_points(group):
        view = points.ViewObject
        if view is not None and hasattr(view.Proxy, "redraw"):
            view.Proxy.redraw(view)


def plan_holding(points):
    """The part plan's group that holds these probe points, or None."""
    return next((parent for parent in points.InListRecursive if is_part_plan(parent)), None)


def part_box(points):
    """The box (2, 3) mm of the part the probe points were sampled on, None where it is gone."""
    part = None if points.Source is None else points.Source[0]
    if part is None or not hasattr(part, "Shape") or not part.Shape.BoundBox.isValid():
        return None
    bound = part.Shape.BoundBox
    return np.array([[bound.XMin, bound.YMin, bound.ZMin], [bound.XMax, bound.YMax, bound.ZMax]])


def labelled_maximum(points, plan):
    """(K, 3) mm: where the max label drawn near these probe points lies (their substitute's,
    or their plan's worst face's, which alone is labelled), none (0, 3) when not drawn."""
    surfaces = [other.Substitute for other in plan_probe_points(plan)] if plan is not None else [points.Substitute]
    surfaces = [s for s in surfaces if s is not None and getattr(s, "MaxLocation", None) is not None
                and s.ViewObject is not None and s.ViewObject.Visibility]
    if not surfaces:
        return np.empty((0, 3))
    worst = max(surfaces, key=lambda surface: surface.MaxDeviation.Value)
    return np.array([tuple(worst.MaxLocation)], dtype=float)


def label_spacing(vobj):
    """The view's LabelSpacing (mm); 0 (all labels) for a view saved before it existed."""
    spacing = getattr(vobj, "LabelSpacing", None)
    return 0.0 if spacing is None else float(spacing.Value)


def coloured_mesh(nodes, field, maximum):
    """The grid as a quad mesh coloured per vertex.

    nodes: (g_u * g_v, 3) mm, u-major; field: (g_u, g_v) deviations in mm (NaN off the face,
    whose quads are left out); maximum: the deviation shown red (mm).
    """
    flat = field.ravel()
    quads = grid_quads(*field.shape)
    quads = quads[~np.isnan(flat[quads]).any(axis=1)]
    return indexed_mesh(nodes, polygon_index(quads), colormap.colours(flat, maximum))


def grid_quads(g_u, g_v):
    """(Q, 4) node indices of the quads of a g_u x g_v grid of nodes numbered u-major, each
    counter-clockwise in (u, v)."""
    corner = (np.arange(g_u - 1)[:, None] * g_v + np.arange(g_v - 1)[None, :]).ravel()
    return np.stack([corner, corner + g_v, corner + g_v + 1, corner + 1], axis=1)


def polygon_index(polygons):
    """A coin coordIndex list of polygons (P, K) node indices: each polygon's indices ended by -1."""
    return np.hstack([polygons, -np.ones((len(polygons), 1), dtype=int)]).ravel().tolist()


def indexed_mesh(nodes, index, rgb):
    """A mesh of polygons coloured per vertex: nodes (K, 3) mm; index: node indices of each
    polygon, each ended by -1; rgb (K, 3) in [0, 1]. Lit on both sides."""
    node = coin.SoSeparator()
    hints = coin.SoShapeHints()
    hints.vertexOrdering = coin.SoShapeHints.UNKNOWN_ORDERING
    hints.creaseAngle = 0.8
    material = coin.SoMaterial()
    material.diffuseColor.setValues(0, len(rgb), [tuple(map(float, c)) for c in rgb])
    binding = coin.SoMaterialBinding()
    binding.value = coin.SoMaterialBinding.PER_VERTEX_INDEXED
    coords = coin.SoCoordinate3()
    coords.point.setValues(0, len(nodes), [tuple(map(float, p)) for p in nodes])
    faces = coin.SoIndexedFaceSet()
    faces.coordIndex.setValues(0, len(index), index)
    faces.materialIndex.setValues(0, len(index), index)
    for child in (hints, material, binding, coords, faces):
        node.addChild(child)
    return node
