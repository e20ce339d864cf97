"""The workbench's document objects: the proxies of the probe points and the substitute surface,
the functions that make them and the probe path's wires. Lengths in mm.

This module never imports the GUI at its top: view providers are attached only when ``FreeCAD.GuiUp``.
"""
import json

import numpy as np

from ..access.obstacles import Obstacles
from ..access.probe import Probe
from ..formats.exporting import measuring_groups, spacing_by_face
from ..formats.pointset import PointSet
from ..geometry.freecad_env import import_part
from ..geometry.surface import SurfaceModel
from ..geometry.validation import InputError
from ..inspection.judge import Planned
from ..planning.datum_points import datum_labels
from ..access.probe_moves import moves_through
from .object_types import PART_PLAN, PROBE_POINTS, SUBSTITUTE_SURFACE, plan_probe_points, source_face

Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

POINT_TOLERANCE_MM = 1e-7
NOTES_DOC = "What the run did that the user should know, in sentences (e.g. points moved onto the face)"
SUMMARY_FIGURES = (
    ("MaxDeviation", "maximum",
     "Largest distance in space from the face to the substitute, over the grid's nodes on the face"),
    ("MeanDeviation", "mean", "Mean distance from the face to the substitute at the nodes"),
    ("RmsDeviation", "rms", "Root-mean-square distance at the nodes"),
    ("StdDeviation", "std", "Standard deviation of the distance at the nodes"),
    ("OccMaxDeviation", "occ_maximum",
     "The maximum again: OpenCASCADE's closest-point distance at the nodes of largest deviation"),
)


def make_probe_points(doc, source=None, surface=None, report=None):
    """A probe-points object (Part::FeaturePython), empty until :func:`write_result` fills it."""
    obj = doc.addObject("Part::FeaturePython", "ProbePoints")
    ProbePoints(obj)
    obj.Label = "Probe points"
    if source is not None:
        obj.Source = (source[0], [source[1]])
        obj.SourceName = f"{source[0].Label}:{source[1]}"
    obj.Substitute = surface
    obj.Report = report
    if FreeCAD.GuiUp:
        from ..gui import view_providers

        view_providers.ViewProviderProbePoints(obj.ViewObject)
    return obj


def make_substitute_surface(doc):
    """A substitute-surface object (Part::FeaturePython), empty until :func:`write_substitute`."""
    obj = doc.addObject("Part::FeaturePython", "SubstituteSurface")
    SubstituteSurface(obj)
    obj.Label = "Substitute surface"
    if FreeCAD.GuiUp:
        from ..gui import view_providers

        view_providers.ViewProviderSubstituteSurface(obj.ViewObject)
    return obj


def make_plan_group(doc):
    """A part plan's group (App::DocumentObjectGroupPython with a PartPlanGroup), empty; in the
    GUI with its view provider (cmmsampling.gui.view_providers.ViewProviderPartPlan)."""
    group = doc.addObject("App::DocumentObjectGroupPython", "Plan")
    PartPlanGroup(group)
    if FreeCAD.GuiUp:
        from ..gui import view_providers

        view_providers.ViewProviderPartPlan(group.ViewObject)
    return group


# Colours of a probe path: the moves between points and the touches (approach and retract).
PATH_COLOURS = {"moves": (0.15, 0.35, 0.85), "touches": (0.85, 0.15, 0.1)}


def make_probe_path(doc, moves):
    """Two wire objects of a probe path (cmmsampling.access.probe_moves.ProbeMoves): "Probe
    moves" (travel and axis moves, blue) and "Probe touches" (approach and retract, red), ball
    centres in mm; returns them."""
    objects = []
    for name, label, chosen in (("ProbeMoves", "Probe moves", moves.kinds != "touch"),
                                ("ProbeTouches", "Probe touches", moves.kinds == "touch")):
        starts, ends = moves.waypoints[:-1][chosen], moves.waypoints[1:][chosen]
        keep = np.linalg.norm(ends - starts, axis=1) > 1e-9
        edges = [Part.LineSegment(FreeCAD.Vector(*a), FreeCAD.Vector(*b)).toShape()
                 for a, b in zip(starts[keep], ends[keep])]
        obj = doc.addObject("Part::Feature", name)
        obj.Label = label
        obj.Shape = Part.Compound(edges)
        if FreeCAD.GuiUp:
            obj.ViewObject.LineColor = PATH_COLOURS["moves" if name == "ProbeMoves" else "touches"]
            obj.ViewObject.LineWidth = 2.0
        objects.append(obj)
    return objects


class TypedProxy:
    """A document-object proxy that saves only its Type with the document (FreeCAD 0.20 and
    0.21+ names)."""

    Type = ""

    def __getstate__(self):
        return {"Type": self.Type}

    def __setstate__(self, state):
        return None

    def dumps(self):
        return self.__getstate__()

    def loads(self, state):
        return self.__setstate__(state)


class ProbePoints(TypedProxy):
    """Proxy of the probe-points object: N labelled points with approach vectors on a face.

    Properties: Labels; Points (mm) and Normals (unit, out of the material); U, V (face
    parameters); Deviation (mm, substitute to face at each point); Source (the face) and
    SourceName ('Label:FaceK', kept when the face is deleted);
    Strategy, Parameters (JSON), RunTime (s), Cancelled; the deviation summary (mm);
    Substitute and Report (the other two result objects); Orphaned, Outdated, Status.
    """

    Type = PROBE_POINTS

    def __init__(self, obj):
        obj.Proxy = self
        self.add_properties(obj)

    @staticmethod
    def add_properties(obj):
        """Create the properties it lacks (read-only where they come from a run): all of them for
        a new object, those added since for one made by an earlier version."""
        points = [
            ("App::PropertyStringList", "Labels", "Point labels P1..PN, behind LabelPrefix"),
            ("App::PropertyString", "LabelPrefix",
             "What the labels start with: the face's name and _ in a part plan (Face61_P1), else nothing"),
            ("App::PropertyVectorList", "Points", "Probe points on the face (mm)"),
            ("App::PropertyVectorList", "Normals",
             "Approach vectors: unit normals out of the material (the probe travels along -normal)"),
            ("App::PropertyFloatList", "U", "Face parameter u of each point"),
            ("App::PropertyFloatList", "V", "Face parameter v of each point"),
            ("App::PropertyFloatList", "Deviation",
             "Distance from the substitute surface to the face at each point (mm)"),
        ]
        sampling = [
            ("App::PropertyString", "Strategy", "Sampling strategy of the run"),
            ("App::PropertyString", "Parameters", "Every parameter of the run (JSON)"),
            ("App::PropertyFloat", "RunTime", "Duration of the sampling run (s)"),
            ("App::PropertyBool", "Cancelled", "The run was stopped early (best points so far)"),
            ("App::PropertyStringList", "Notes", NOTES_DOC),
        ]
        reach = [
            ("App::PropertyVectorList", "Axes",
             "The probe's axis at each point, ball towards head (NaN where it cannot reach); empty when "
             "the run did not know the part"),
            ("App::PropertyBoolList", "Tilted",
             "Points reached only with the stylus tilted (the head's orientation nearest the normal is blocked)"),
            ("App::PropertyString", "Probe", "The probe whose reach was judged (JSON), empty when none"),
            ("App::PropertyFloatList", "Unreached",
             "Regions of the face the probe cannot reach, as parameter rectangles u0, u1, v0, v1 in turn"),
            ("App::PropertyArea", "UnreachedArea", "Area of the face the probe cannot reach (mm^2)"),
        ]
        status = [
            ("App::PropertyString", "SourceName", "The sampled face when the points were made"),
            ("App::PropertyBool", "Orphaned", "The source face was deleted"),
            ("App::PropertyBool", "Outdated",
             "The source face no longer passes through the points; run Re-evaluate"),
            ("App::PropertyString", "Status", "Whether the points still match their face"),
        ]
        figures = [("App::PropertyLength", prop, doc + " (mm)") for prop, _, doc in SUMMARY_FIGURES] + [
            ("App::PropertyAngle", "MaxNormalAngle",
             "Largest angle between the face's normal and the substitute's, over the grid's nodes (degrees): a "
             "substitute corrugated within a small distance shows here")]
        for group, props in (("Probe points", points), ("Sampling", sampling), ("Probe reach", reach),
                             ("Source", status), ("Deviation", figures)):
            for kind, name, doc in props:
                if name not in obj.PropertiesList:
                    obj.addProperty(kind, name, group, doc)
                    obj.setEditorMode(name, 1)
        for name, kind, group, doc in (
                ("Source", "App::PropertyLinkSubGlobal", "Source", "The sampled face"),
                ("Substitute", "App::PropertyLink", "Results", "The substitute surface"),
                ("Report", "App::PropertyLink", "Results", "The deviation report sheet")):
            if name not in obj.PropertiesList:
                obj.addProperty(kind, name, group, doc)

    def execute(self, obj):
        """Shape: a compound of the points as vertices; Status: whether the face still fits."""
        obj.Shape = Part.makeCompound([Part.Vertex(p) for p in obj.Points])
        face, problem = source_face(obj)
        obj.Orphaned = face is None and bool(obj.SourceName)
        obj.Outdated = face is not None and not passes_through(face, obj)
        if obj.Orphaned:
            obj.Status = f"orphaned: {problem}"
            FreeCAD.Console.PrintWarning(f"{obj.Label} is orphaned: {problem}\n")
        elif face is None:
            obj.Status = problem
        elif obj.Outdated:
            obj.Status = "outdated: the source face changed; run Re-evaluate"
        else:
            obj.Status = "up to date"

    def onDocumentRestored(self, obj):
        _view_provider_when_missing(obj)

    def point_set(self, obj):
        """The probe points as a :class:`cmmsampling.formats.pointset.PointSet`."""
        settings = json.loads(obj.Parameters or "{}")
        metadata = {
            "source": obj.SourceName, **settings,
            **{key: getattr(obj, prop).Value for prop, key in (
                ("MaxDeviation", "max_mm"), ("MeanDeviation", "mean_mm"), ("RmsDeviation", "rms_mm"),
                ("StdDeviation", "std_mm"), ("OccMaxDeviation", "occ_max_mm"))},
        }
        axes = [tuple(a) for a in getattr(obj, "Axes", [])]
        return PointSet(
            labels=list(obj.Labels),
            points=np.array([tuple(p) for p in obj.Points], dtype=float).reshape(-1, 3),
            normals=np.array([tuple(n) for n in obj.Normals], dtype=float).reshape(-1, 3),
            uv=np.column_stack([obj.U, obj.V]).reshape(-1, 2),
            deviation=np.array(obj.Deviation, dtype=float),
            metadata=metadata,
            axes=np.array(axes, dtype=float) if len(axes) == len(obj.Labels) and axes else None,
        )

    def planned(self, obj):
        """What measured points are judged against (cmmsampling.inspect): the labels, the points
        and their source face as it is now; InputError where the face is gone."""
        point_set = self.point_set(obj)
        return Planned(point_set.labels, point_set.points, [inspected_face(obj)], [obj.SourceName or obj.Label],
                       np.zeros(len(point_set), dtype=int))

    def probe_moves(self, obj, motion=None):
        """The collision-free probe path through the points (cmmsampling.access.probe_moves.
        ProbeMoves) on their source object's shape, with the probe and axes of their run; motion:
        the CMM's speeds (cmmsampling.access.probe.Motion). ValueError naming what is missing
        (:meth:`path_probe`)."""
        probe, point_set = self.path_probe(obj), self.point_set(obj)
        return moves_through(probe, Obstacles(obj.Source[0].Shape), point_set.points, point_set.normals,
                             point_set.axes, motion)

    @staticmethod
    def path_probe(obj):
        """The Probe of a run a probe path can go through: InputError naming what is missing
        where the points were sampled without the part, the probe cannot reach some of them, or
        their part was deleted."""
        axes = [tuple(axis) for axis in getattr(obj, "Axes", [])]
        if not getattr(obj, "Probe", "") or not axes or len(axes) != len(obj.Labels):
            raise InputError(f"{obj.Label} were sampled without the part, so they have no probe axes: sample "
                             "the face again with the part (and a probe), or export with order='short_path'")
        if not np.isfinite(axes).all():
            raise InputError(f"the probe cannot reach some of {obj.Label}: export with order='short_path'")
        if obj.Source is None:
            raise InputError(f"the part of {obj.Label} was deleted; a probe path needs it to keep clear of")
        return Probe(**json.loads(obj.Probe))

    def follows_probe(self, obj):
        """True when the points were sampled with the part, the probe reaches them all and the
        part is still there: their export may follow the collision-free probe path."""
        try:
            self.path_probe(obj)
        except InputError:
            return False
        return True


class PartPlanGroup(TypedProxy):
    """Proxy of a part plan's group (App::DocumentObjectGroupPython): a sub-group per face, each
    with its probe points, and the plan report. It exports as one program: :meth:`point_set`
    joins the faces' points (labels Face61_P1, unique across the faces) and :meth:`probe_moves`
    goes through all of them."""

    Type = PART_PLAN

    def __init__(self, obj):
        obj.Proxy = self
        self.add_properties(obj)

    @staticmethod
    def add_properties(obj):
        """Create the plan's stated properties it lacks (a group made by an earlier version has none):
        Datums, the datum faces primary first, Tolerance, the profile tolerance planned to, and for
        a plan from a QIF MBD model its file (MbdFile), the characteristics planned and the datums
        its programs set the frame on (FrameDatums)."""
        for kind, name, doc in (
                ("App::PropertyStringList", "Datums",
                 "The datum faces, primary first (datums A, B, C): measured first, the part's frame set on them"),
                ("App::PropertyLength", "Tolerance",
                 "The profile tolerance the plan was made to (mm); 0 for a plan to a total of points or "
                 "with a tolerance per face (a QIF MBD model's)"),
                ("App::PropertyFile", "MbdFile", "The QIF MBD model whose characteristics the plan was made from "
                 "('' for a plan of faces)"),
                ("App::PropertyStringList", "Characteristics",
                 "The model's characteristics planned: id, kind, tolerance, datums, faces"),
                ("App::PropertyStringList", "FrameDatums",
                 "A plan from a QIF MBD model: the datums its programs set the part's frame on, primary first, "
                 "each its label and faces ('B Face43 Face44'), measured first")):
            if name not in obj.PropertiesList:
                obj.addProperty(kind, name, "Plan", doc)
                obj.setEditorMode(name, 1)

    def onDocumentRestored(self, obj):
        self.add_properties(obj)
        _view_provider_when_missing(obj)

    def stated(self, obj):
        """(the datum faces' names, primary first; the tolerance in mm or None): what the plan
        states, which ``cmmsampling.inspect`` takes unless told otherwise."""
        tolerance = float(getattr(obj, "Tolerance", 0.0))
        return list(getattr(obj, "Datums", [])), (tolerance or None)

    def point_set(self, obj):
        """Every face's probe points as one :class:`cmmsampling.formats.pointset.PointSet`, face
        by face (the datum faces first), with the plan's datums ({label: face}, or {label: faces}
        of a QIF MBD plan's frame) and tolerance in its metadata; InputError for a plan group
        without points."""
        members = plan_probe_points(obj)
        if not members:
            raise InputError(f"{obj.Label} holds no probe points: plan the part again")
        sets = [member.Proxy.point_set(member) for member in members]
        faces = [member.SourceName.rpartition(":")[2] or member.Label for member in members]
        labels = [label if label.startswith(face + "_") else f"{face}_{label}"
                  for face, point_set in zip(faces, sets) for label in point_set.labels]
        axes = [point_set.axes for point_set in sets]
        metadata = {"source": obj.Label, "faces": len(members), "strategy": sets[0].metadata.get("strategy", ""),
                    "points_per_face": {face: len(point_set) for face, point_set in zip(faces, sets)},
                    **spacing_by_face({face: point_set.metadata for face, point_set in zip(faces, sets)})}
        if members[0].Probe:
            metadata["probe"] = json.loads(members[0].Probe)
        datums, tolerance = self.stated(obj)
        if datums:
            metadata["datums"] = dict(zip(datum_labels(len(datums)), datums))
        frame = [entry.split() for entry in getattr(obj, "FrameDatums", [])]
        if frame:
            metadata["datums"] = {label: faces for label, *faces in frame}
        if tolerance is not None:
            metadata["tolerance_mm"] = tolerance
        return PointSet(labels, np.concatenate([s.points for s in sets]), np.concatenate([s.normals for s in sets]),
                        np.concatenate([s.uv for s in sets]), np.concatenate([s.deviation for s in sets]), metadata,
                        [face for face, point_set in zip(faces, sets) for _ in range(len(point_set))],
                        np.concatenate(axes) if all(a is not None for a in axes) else None)

    def planned(self, obj):
        """What measured points are judged against (cmmsampling.inspect): every face's labels
        (Face61_P1, as exported), points and faces; InputError where a face is gone."""
        members = plan_probe_points(obj)
        point_set = self.point_set(obj)
        faces = [inspected_face(member) for member in members]
        names = [member.SourceName or member.Label for member in members]
        counts = [len(member.Labels) for member in members]
        return Planned(point_set.labels, point_set.points, faces, names, np.repeat(np.arange(len(members)), counts))

    def follows_probe(self, obj):
        """True when every face's points were planned with a probe that reaches them all, on a part
        still in the document: the plan exports along the probe's path."""
        members = plan_probe_points(obj)
        return bool(members) and all(member.Proxy.follows_probe(member) for member in members)

    def probe_moves(self, obj, motion=None):
        """The collision-free probe path through every face's points on their part (see
        :meth:`ProbePoints.probe_moves`); ValueError naming what is missing (the first face's
        :meth:`ProbePoints.path_probe` that says so)."""
        point_set = self.point_set(obj)
        members = plan_probe_points(obj)
        probes = [ProbePoints.path_probe(member) for member in members]
        return moves_through(probes[0], Obstacles(members[0].Source[0].Shape), point_set.points, point_set.normals,
                             point_set.axes, motion, groups=measuring_groups(point_set))


class SubstituteSurface(TypedProxy):
    """Proxy of the substitute surface: the fitted B-spline face and its deviation field.

    Properties: Shape (the fitted face); GridU (g_u), GridV (g_v): the evaluation grid's
    parameters; DeviationField: g_u * g_v deviations in mm, row-major (u first), NaN off the face;
    MaxDeviation (mm); MaxLocation: the face's point (mm) where the largest deviation lies.
    """

    Type = SUBSTITUTE_SURFACE
    PROPERTIES = (
        ("App::PropertyFloatList", "GridU", "Parameters u of the evaluation grid"),
        ("App::PropertyFloatList", "GridV", "Parameters v of the evaluation grid"),
        ("App::PropertyFloatList", "DeviationField",
         "Deviation from the face at each grid node (mm), u-major, NaN off the face"),
        ("App::PropertyLength", "MaxDeviation", "Largest deviation of the delivered substitute (mm)"),
        ("App::PropertyVector", "MaxLocation", "Point of the face where the largest deviation lies (mm)"),
    )

    def __init__(self, obj):
        obj.Proxy = self
        self.add_missing_properties(obj)

    @classmethod
    def add_missing_properties(cls, obj):
        """Add the properties obj lacks (all of them for a new object, MaxLocation for one saved by
        an earlier version: then taken at the raster node of largest deviation, on the
        substitute), read-only in the property editor."""
        for kind, name, doc in cls.PROPERTIES:
            if not hasattr(obj, name):
                obj.addProperty(kind, name, "Deviation", doc)
                obj.setEditorMode(name, 1)
                if name == "MaxLocation" and obj.DeviationField and obj.Shape.Faces:
                    obj.MaxLocation = cls.raster_maximum(obj)

    @classmethod
    def raster_maximum(cls, obj):
        """FreeCAD.Vector: the substitute's point at the raster node of largest deviation."""
        u, v, field = cls.deviation_grid(obj)
        i, j = np.unravel_index(int(np.nanargmax(field)), field.shape)
        return obj.Shape.Faces[0].Surface.value(float(u[i]), float(v[j]))

    def execute(self, obj):
        """Nothing to rebuild: the shape is written with the result."""

    def onDocumentRestored(self, obj):
        self.add_missing_properties(obj)
        _view_provider_when_missing(obj)

    @staticmethod
    def deviation_grid(obj):
        """(GridU (g_u,), GridV (g_v,), field (g_u, g_v) mm) as numpy arrays."""
        u = np.array(obj.GridU, dtype=float)
        v = np.array(obj.GridV, dtype=float)
        return u, v, np.array(obj.DeviationField, dtype=float).reshape(len(u), len(v))


def _view_provider_when_missing(obj):
    """In the GUI, give an object restored from a document saved headless its view provider."""
    if FreeCAD.GuiUp:
        from ..gui import view_providers

        view_providers.attach_when_missing(obj)


def inspected_face(points):
    """The source face (Part.Face) measured points of probe points are judged on, as it is now;
    InputError naming why where it is gone."""
    face, why = source_face(points)
    if face is None:
        raise InputError(f"{points.Label} cannot be inspected: {why}; measured points are judged on the face "
                         "they were planned on")
    return face


def passes_through(face, points):
    """True when the face at the stored (u, v) still gives the stored points."""
    if not points.Points:
        return True
    uv = np.column_stack([points.U, points.V])
    now = SurfaceModel.from_face(face).points(uv)
    stored = np.array([tuple(p) for p in points.Points], dtype=float)
    return bool(np.abs(now - stored).max() <= POINT_TOLERANCE_MM)
