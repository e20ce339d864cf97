"""SurfaceModel: a face's NURBS definition, evaluated for many (u, v) at once.

Units are the document's (mm). Parameters ``uv`` are always in the face's own parameter
range, i.e. what ``face.valueAt(u, v)`` takes on :attr:`SurfaceModel.face` (for faces that had
to be converted with ``toNurbs()`` this is the converted face, whose parametrisation differs
from the original analytic one).
"""
from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from .bspline import clamped_uniform_knots, full_knots
from .freecad_env import import_part
from .nurbs import NurbsPatch
from .validation import InputError, InputTypeError

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

# How far a probe point may lie from its face, mm, by OCC's distance (BRepExtrema): points
# farther off (beyond a trimmed boundary, or past an edge whose parameter range is wider than
# the face) are moved onto the face by SurfaceModel.onto_face.
ON_FACE_MM = 1e-5
# The most a point may lie off a tolerant face (one whose own tolerance is larger than
# ON_FACE_MM) by OCC's distance and count as on it: OCC's distance and its classifier
# (``isInside(p, 1e-4, True)``) agree to it, and a CMM program's nominal is on the face to it.
# A wider band (the face's tolerance) takes points between a face's curves on the surface and
# its 3D edges (Top.brep's Face66: 0.012 mm off, inside the curves, outside the classifier).
TOLERANT_ON_FACE_MM = 1e-4
# Samples per edge of a trimming loop at least; relative area difference that makes a face trimmed.
LOOP_SAMPLES_PER_EDGE = 200
# Edge spans: cut where an edge's curve on the surface is less than C^2 smooth.
SPAN_CONTINUITY = 2
TRIM_AREA_TOLERANCE = 1e-7
INWARD_STEP = 1e-7
INWARD_DOUBLINGS = 40


class SurfaceModel(NurbsPatch):
    """A face's NURBS definition (see NurbsPatch) together with the face it came from.

    Build it with :meth:`from_face`. face: the Part.Face evaluated (a B-spline face; the input
    itself or its ``toNurbs()``); source_face: the face as given.
    """

    def __init__(self, face: Part.Face, source_face: Part.Face, surface: Part.BSplineSurface) -> None:
        super().__init__(
            (surface.UDegree, surface.VDegree),
            [[tuple(p) for p in row] for row in surface.getPoles()],
            surface.getWeights(),
            full_knots(surface.getUKnots(), surface.getUMultiplicities()),
            full_knots(surface.getVKnots(), surface.getVMultiplicities()),
            face.ParameterRange,
            face.Orientation == "Reversed",
        )
        self.face = face
        self.source_face = source_face

    @classmethod
    def from_face(cls, face: Part.Shape) -> SurfaceModel:
        """Model of a Part.Face: B-spline faces as they are, any other surface via ``toNurbs()``.

        Periodic B-splines are made non-periodic (same geometry, clamped knots).
        Raises TypeError for anything that is not a single face.
        """
        face = as_face(face)
        evaluated = face
        if not isinstance(face.Surface, Part.BSplineSurface):
            evaluated = face.toNurbs().Faces[0]
        surface = evaluated.Surface.copy()
        if surface.isUPeriodic():
            surface.setUNotPeriodic()
        if surface.isVPeriodic():
            surface.setVNotPeriodic()
        return cls(evaluated, face, surface)

    @cached_property
    def area(self) -> float:
        """The face's area, mm^2 (OCC)."""
        return float(self.face.Area)

    @cached_property
    def extent(self) -> np.ndarray:
        """(3,) lengths of the face's bounding box along x, y and z, mm (OCC)."""
        box = self.face.BoundBox
        return np.array([box.XLength, box.YLength, box.ZLength])

    @property
    def diagonal(self) -> float:
        """Length of the face's bounding-box diagonal, mm."""
        return float(np.linalg.norm(self.extent))

    @cached_property
    def trimmed(self) -> bool:
        """True when the face is smaller than its surface over the face's parameter range (a
        trimmed boundary or holes)."""
        full = self.face.Surface.toShape(*self.face.ParameterRange)
        return (abs(full.Area - self.area) > TRIM_AREA_TOLERANCE * full.Area
                or len(self.face.Wires) > 1)

    def trim_loops(self, step: float) -> list[np.ndarray]:
        """The face's boundary loops as (u, v) polygons: list of (K, 2) arrays, one per wire,
        each its edges' samples (:meth:`trim_edges`) end to end."""
        return [np.concatenate(edges) for edges in self.trim_edges(step) if edges]

    def trim_edges(self, step: float) -> list[list[np.ndarray]]:
        """The samples of the face's edges in (u, v), wire by wire: a list per wire of (K, 2)
        arrays, one per edge in the wire's order, each running the way the wire does.

        Each edge's curve on the surface is sampled at least LOOP_SAMPLES_PER_EDGE times, at equal
        steps of its parameter and at most ``step`` mm apart along the edge (3D), so the samples
        serve the edge clearance too.
        """
        wires = []
        for wire in self.face.Wires:
            pieces = []
            for edge in wire.OrderedEdges or wire.Edges:
                curve, first, last = self.face.curveOnSurface(edge)[:3]
                count = max(LOOP_SAMPLES_PER_EDGE, int(np.ceil(edge.Length / step)) + 1)
                piece = _curve_uv(curve, first, last, count)
                pieces.append(piece[::-1] if edge.Orientation == "Reversed" else piece)
            wires.append(pieces)
        return wires

    @cached_property
    def edge_spans(self) -> list[list[tuple[Any, float, float]]]:
        """The face's edges cut where their curve on the surface is less than C^SPAN_CONTINUITY
        smooth (at such knots of a B-spline curve), so that a cubic through the samples of one
        span follows it closely: a list per wire of (curve, start, end) in the wire's order, the
        parameters running the way the wire does (start > end on a reversed edge)."""
        wires = []
        for wire in self.face.Wires:
            spans: list[tuple[Any, float, float]] = []
            for edge in wire.OrderedEdges or wire.Edges:
                curve, first, last = self.face.curveOnSurface(edge)[:3]
                cuts = np.concatenate([[first], _breaks(curve, first, last), [last]])
                pieces = list(zip(cuts[:-1], cuts[1:]))
                if edge.Orientation == "Reversed":
                    pieces = [(end, start) for start, end in reversed(pieces)]
                spans.extend((curve, start, end) for start, end in pieces)
            wires.append(spans)
        return wires

    def span_samples(self, counts: Sequence[Sequence[int]]) -> list[list[np.ndarray]]:
        """Each edge span (:attr:`edge_spans`) at ``counts`` (a list per wire of ints) equal steps
        of its parameter, from its start to its end: a list per wire of (count, 2) uv arrays."""
        return [[_curve_uv(*span, count) for span, count in zip(spans, wire_counts)]
                for spans, wire_counts in zip(self.edge_spans, counts)]

    def distance_to_face(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """OCC's distance (mm) from the model's points at uv (N, 2) to the face, and the nearest
        points on it: ((N,) mm, (N, 3) mm), by BRepExtrema (``distToShape``) alone: a probe point
        counts as on the face only where that finds it so too, although it may put a point of the
        face off it (cmmsampling.geometry.occ_distance). One OCC query per point: a final check,
        not for optimiser loops."""
        found = [self.face.distToShape(Part.Vertex(*point)) for point in self.points(uv)]
        return (np.array([d[0] for d in found]),
                np.array([tuple(d[1][0][0]) for d in found]).reshape(-1, 3))

    def on_face(self, uv: np.ndarray) -> np.ndarray:
        """(N,) True where the points at uv (N, 2) lie on the face by OCC: inside its boundary by
        OCC's face classifier (``isPartOfDomain``) and within :attr:`tolerance` of it. Both are
        asked: on a planar face with tolerant edges OCC's distance was seen to be 0 for a point
        outside its boundary."""
        off, _, inside = self._occ_placement(uv)
        return (off <= self.tolerance) & inside

    @property
    def tolerance(self) -> float:
        """mm a point may lie from the face and count as on it: ON_FACE_MM, or the face's own
        tolerance where that is larger (OCC's distance to a valid face with a tolerant surface),
        up to TOLERANT_ON_FACE_MM. Not its edges' tolerance: on a plane whose edges are 0.014 mm
        tolerant (Ventilator Face16) points 0.014-0.024 mm outside its boundary counted as on it."""
        return max(ON_FACE_MM, min(float(self.face.Tolerance), TOLERANT_ON_FACE_MM))

    def _occ_placement(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """OCC's view of the points at uv (N, 2): (distance (N,) mm, nearest face points (N, 3)
        mm, inside the boundary by the face classifier (N,) bool)."""
        uv = np.asarray(uv, dtype=float)
        off, feet = self.distance_to_face(uv)
        return off, feet, np.array([self.face.isPartOfDomain(u, v) for u, v in uv], dtype=bool)

    def onto_face(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """uv (N, 2) with every point that is not on the face (:meth:`on_face`) moved onto it.

        An off point goes to the parameters of its nearest point on the face (OCC), and from there
        inward (away from where it was) by steps doubling from INWARD_STEP of the parameter range
        until OCC finds it on the face (an edge's 3D curve and its curve on the surface differ
        by up to the edge's tolerance); where that finds none (a point inside the face's curves on
        the surface but off its 3D boundary: the nearest point lies beyond the curves), from the
        point itself away from that nearest point. Returns (uv (N, 2), moved (N,) bool, off (N,)
        mm: each point's OCC distance from the face before the move).
        """
        uv = np.array(uv, dtype=float)
        off, feet, inside = self._occ_placement(uv)
        moved = (off > self.tolerance) | ~inside
        for i in np.flatnonzero(moved):
            uv[i] = self._inward(uv[i], feet[i])
        return uv, moved, off

    def _inward(self, outside: np.ndarray, foot: np.ndarray) -> np.ndarray:
        """Parameters (2,) of a point on the face near ``foot`` (3,) mm, the nearest face point
        of the parameters ``outside`` (2,)."""
        low, high = np.array(self.bounds[0::2]), np.array(self.bounds[1::2])
        start = np.clip(self.face.Surface.parameter(FreeCAD.Vector(*foot)), low, high)
        direction = start - outside
        if np.linalg.norm(direction / (high - low)) < INWARD_STEP:   # off by the edge's tolerance only
            direction = 0.5 * (low + high) - start
        steps = np.concatenate([[0.0], INWARD_STEP * 2.0 ** np.arange(INWARD_DOUBLINGS)])
        for origin, towards in ((start, direction), (outside, -direction)):
            towards = towards / np.linalg.norm(towards / (high - low))
            for step in steps:
                candidate = np.clip(origin + step * towards, low, high)
                if self.on_face(candidate[None])[0]:
                    return candidate
        raise InputError("a point off the face could not be moved onto it; the face's boundary "
                         "may be broken: check it with Part's Check geometry")


def as_face(shape: Any) -> Part.Face:
    """The single Part.Face in ``shape`` (a Face, or a Shape holding exactly one face).

    Raises TypeError naming what was given otherwise.
    """
    if isinstance(shape, Part.Face):
        return shape
    if isinstance(shape, Part.Shape):
        faces = shape.Faces
        if len(faces) == 1:
            return faces[0]
        if not faces:
            raise InputTypeError(
                f"expected a face, got a{'n' if shape.ShapeType[0] in 'AEIOU' else ''} "
                f"{shape.ShapeType} with no faces; select a face of a solid, shell or surface"
            )
        raise InputTypeError(
            f"expected one face, got a {shape.ShapeType} with {len(faces)} faces; "
            "pick a single face, e.g. shape.Faces[0]"
        )
    raise InputTypeError(
        f"expected a Part.Face, got {type(shape).__name__}; "
        "pass a face, e.g. obj.Shape.Faces[0] or cmmsampling.reference_face()"
    )


def points_of(face: Part.Face, count: int = 3) -> np.ndarray:
    """Up to ``count`` points on a face (mm): its coarse tessellation's first, middle and last
    vertices, (K, 3)."""
    deflection = max(face.BoundBox.DiagonalLength / 20.0, 1e-6)
    vertices = face.tessellate(deflection)[0] or [vertex.Point for vertex in face.Vertexes]
    chosen = np.unique(np.linspace(0, len(vertices) - 1, count).round().astype(int))
    return np.array([[vertices[k].x, vertices[k].y, vertices[k].z] for k in chosen], dtype=float)


def lies_on(face: Part.Face, shape: Part.Shape, tolerance: float = 1e-4) -> bool:
    """True when face is part of shape: a few of its points (:func:`points_of`) lie within
    tolerance mm (or the shapes' own tolerance, if larger) of shape."""
    allowed = max(tolerance, face.Tolerance, shape.getTolerance(1))
    return all(shape.distToShape(Part.Vertex(FreeCAD.Vector(*point)))[0] <= allowed for point in points_of(face))


def reference_poles() -> np.ndarray:
    """Poles of the reference surface: (9, 9, 3) mm.

    x_i = 12.5 i, y_j = 12.5 j (i, j = 0..8),
    z = 12 sin(2.5 pi x / 100) cos(1.7 pi y / 100) + 8 exp(-((x - 70)^2 + (y - 30)^2) / 300).
    """
    x, y = np.meshgrid(12.5 * np.arange(9), 12.5 * np.arange(9), indexing="ij")
    z = 12 * np.sin(2.5 * np.pi * x / 100) * np.cos(1.7 * np.pi * y / 100) + 8 * np.exp(
        -((x - 70) ** 2 + (y - 30) ** 2) / 300
    )
    return np.stack([x, y, z], axis=-1)


def make_bspline_surface(poles: np.ndarray, degrees: Sequence[int], weights: np.ndarray | None = None,
                         uknots: np.ndarray | None = None, vknots: np.ndarray | None = None) -> Part.BSplineSurface:
    """A Part.BSplineSurface from poles (n_u, n_v, 3), degrees (k_u, k_v) and full knot vectors.

    Knots default to clamped uniform on [0, 1]; weights (n_u, n_v) default to 1.
    """
    poles = np.asarray(poles, dtype=float)
    n_u, n_v = poles.shape[:2]
    if uknots is None:
        uknots = clamped_uniform_knots(degrees[0], n_u)
    if vknots is None:
        vknots = clamped_uniform_knots(degrees[1], n_v)
    ku, mu = np.unique(uknots, return_counts=True)
    kv, mv = np.unique(vknots, return_counts=True)
    vectors = [[FreeCAD.Vector(*map(float, p)) for p in row] for row in poles]
    surface = Part.BSplineSurface()
    args = [vectors, mu.tolist(), mv.tolist(), ku.tolist(), kv.tolist(), False, False,
            int(degrees[0]), int(degrees[1])]
    if weights is not None:
        args.append(np.asarray(weights, dtype=float).tolist())
    surface.buildFromPolesMultsKnots(*args)
    return surface


def reference_face() -> Part.Face:
    """The built-in reference face: degree (5, 5), 9 x 9 poles over a 100 x 100 mm square.

    Clamped uniform knots, all weights 1; see :func:`reference_poles` for the pole heights.
    """
    return make_bspline_surface(reference_poles(), (5, 5)).toShape()


def _curve_uv(curve: Any, start: float, end: float, count: int) -> np.ndarray:
    """(count, 2) points of a 2D curve at equal parameter steps from start to end (count may
    be 0)."""
    return np.array([(p.x, p.y) for p in map(curve.value, np.linspace(start, end, count))]).reshape(-1, 2)


def _breaks(curve: Any, first: float, last: float) -> np.ndarray:
    """The parameters strictly between first and last where a 2D curve is less than
    C^SPAN_CONTINUITY smooth: a B-spline's knots of multiplicity above degree - SPAN_CONTINUITY;
    none for other curves."""
    if not hasattr(curve, "getMultiplicities"):
        return np.zeros(0)
    knots, multiplicities = np.array(curve.getKnots()), np.array(curve.getMultiplicities())
    rough = knots[multiplicities > curve.Degree - SPAN_CONTINUITY]
    return rough[(rough > min(first, last)) & (rough < max(first, last))]
