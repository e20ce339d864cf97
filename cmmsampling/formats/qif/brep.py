"""The B-rep of a QIF 3.0 document's product built into an OpenCASCADE shape.

QIF keeps the model as sets: points, 3D curves (``Curve13Set``: segments, circular arcs,
NURBS, aggregates of these), surfaces (``SurfaceSet``: planes, cylinders, cones, spheres,
tori, NURBS), and topology (vertices on points, edges on curves between two vertices, loops
of oriented edges, faces on a surface with their loops, shells, bodies). Each face is built
here from its surface and its loops' 3D edges (OCC makes the edges' curves on the surface),
the edges of a loop meeting exactly at the file's vertices (each curve's ends are set on
them: the file writes points to 7-10 digits, which would leave gaps OCC does not bridge).
The faces are sewn into a shell and, where the shell closes into a valid solid, a solid.
Lengths are converted to mm.
"""
from __future__ import annotations

import base64
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ...geometry.validation import InputError
from .xml import tag

# Sewing tolerance, mm: the file's points agree to about 1e-6 of the part's size.
SEWING_MM = 1e-4
# Points taken inside a face to tell which face it is (inner_points).
INNER_POINTS = 12


@dataclass
class BuiltModel:
    """A QIF model's shape (a Part.Shape: a solid where the file describes one, else a shell or
    faces), the QIF id of each of its faces in FreeCAD's order (``face_ids[k]`` is Face<k+1>),
    and the faces the file describes that could not be built (QIF id, why)."""

    shape: object
    face_ids: list[str]
    failed: list[tuple[str, str]]


def build_model(root: ET.Element, mm_per_unit: float, path: str = "") -> BuiltModel:
    """The shape of the first body of a parsed QIF document's product (every face when it
    names no body), in mm (the file's lengths times mm_per_unit). InputError when the document
    holds no B-rep or no face could be built."""
    import Part

    items = {element.get("id", ""): element for element in root.iter() if element.get("id") is not None}
    face_ids = _body_faces(root)
    if not face_ids:
        raise InputError(f"{path}: holds no B-rep faces (no Product TopologySet FaceSet); give a QIF MBD file "
                         "with its model, or a STEP file of it with shape=")
    builder = _Builder(items)
    faces: list = []
    built: list[str] = []
    failed: list[tuple[str, str]] = []
    for ident in face_ids:
        try:
            faces.append(builder.face(items[ident]))
            built.append(ident)
        except (Part.OCCError, RuntimeError, ValueError, KeyError, NotImplementedError) as exc:
            failed.append((ident, str(exc) or type(exc).__name__))
    if not faces:
        raise InputError(f"{path}: none of its {len(face_ids)} faces could be built ({failed[0][1]})")
    shape = _joined(faces)
    order = _face_order(shape, faces, built)
    if mm_per_unit != 1.0:
        shape = shape.copy()
        shape.scale(mm_per_unit)
    return BuiltModel(shape, order, failed)


def _body_faces(root: ET.Element) -> list[str]:
    """The face ids of the product's first body (its FaceIds), else every face in the file's order."""
    for body in root.iter(tag("Body")):
        listed = body.find(tag("FaceIds"))
        if listed is not None:
            return [(ident.text or "").strip() for ident in listed.iter(tag("Id"))]
    return [face.get("id", "") for face in root.iter(tag("Face")) if face.get("id") is not None]


def _joined(faces):
    """The faces sewn into one shell, then a solid where the shell closes and the solid is
    valid; else the sewn shape (whose faces :func:`_face_order` names)."""
    import Part

    sewn = Part.Compound(faces)
    sewn.sewShape(SEWING_MM)
    shells = sewn.Shells
    if len(shells) == 1 and shells[0].isClosed() and len(shells[0].Faces) == len(faces):
        solid = Part.Solid(shells[0])
        if solid.Volume < 0:
            solid = Part.Solid(shells[0].reversed())
        if solid.isValid():
            return solid
    return sewn


def _face_order(shape, faces, ids):
    """The QIF id of each face of ``shape`` in its order: the built face that points inside it
    lie on and whose area it has (sewing keeps the faces but may renumber them)."""
    import Part

    boxes = face_boxes(faces)
    order = []
    for face in shape.Faces:
        points = inner_points(face, 5)
        vertices = [Part.Vertex(*point) for point in points]
        near = boxes_holding(boxes, points, SEWING_MM)
        near = near if near.size else np.arange(len(faces))

        def misfit(k):
            return max(faces[k].distToShape(v)[0] for v in vertices) + abs(faces[k].Area - face.Area)

        order.append(ids[min(near, key=misfit)])
    return order


def face_boxes(faces) -> np.ndarray:
    """(F, 6) mm: each face's bounding box, its minimum corner then its maximum."""
    return np.array([[f.BoundBox.XMin, f.BoundBox.YMin, f.BoundBox.ZMin, f.BoundBox.XMax, f.BoundBox.YMax,
                      f.BoundBox.ZMax] for f in faces]).reshape(-1, 6)


def boxes_holding(boxes: np.ndarray, points: np.ndarray, margin: float) -> np.ndarray:
    """Indices of the boxes ((F, 6), :func:`face_boxes`) that hold every one of points (N, 3) mm
    (or one point (3,)) within ``margin`` mm."""
    points = np.reshape(points, (-1, 3))
    return np.flatnonzero(np.all((points.min(axis=0) >= boxes[:, :3] - margin)
                                 & (points.max(axis=0) <= boxes[:, 3:] + margin), axis=1))


class _Builder:
    """Builds faces from a QIF document's items (elements by id), each edge once."""

    def __init__(self, items: dict[str, ET.Element]) -> None:
        self.items = items
        self.edges: dict[str, list] = {}

    def face(self, element: ET.Element):
        """A Part.Face of a QIF Face element: its surface trimmed by its loops (outer first)."""
        import Part

        core = self.core(element, "Surface")
        surface = _surface(core)
        loops = [self.items[_text(ident)] for ident in _child(element, "LoopIds").iter(tag("Id"))]
        loops.sort(key=lambda loop: loop.get("form") != "OUTER")
        wires = [Part.Wire(self.loop_edges(loop)) for loop in loops]
        bound = _patch_area(core)
        if bound is None:
            face = _trimmed(surface, wires)
        else:
            # On a closed surface (a torus, a sphere) a loop bounds two regions and OCC's fix
            # picks either (OCC 7.6 the one, 7.8 the other): the face is the region within the
            # file's patch of the surface, tried on copies of the loops.
            tried = [_trimmed(surface, [wire.copy() for wire in wires]),
                     _trimmed(surface, [wires[0].copy().reversed()] + [wire.copy() for wire in wires[1:]])]
            fits = [candidate for candidate in tried if candidate.Area <= bound]
            face = min(fits or tried, key=lambda candidate: candidate.Area)
        if element.get("turned") == "true":
            face.reverse()
        return face

    def core(self, element: ET.Element, name: str) -> ET.Element:
        """The core element (e.g. Plane23Core) of the item an element's ``name``/Id refers to."""
        return _core(self.items[_text(_child(_child(element, name), "Id"))])

    def loop_edges(self, loop: ET.Element) -> list:
        """A loop's edges in order, each oriented as the loop runs."""
        edges = []
        for coedge in _child(loop, "CoEdges"):
            oriented = _child(coedge, "EdgeOriented")
            pieces = self.edge(_text(_child(oriented, "Id")))
            if oriented.get("turned") == "true":
                pieces = [piece.reversed() for piece in reversed(pieces)]
            edges += pieces
        return edges

    def edge(self, ident: str) -> list:
        """A QIF edge's Part.Edges (several for an aggregate curve), from its start vertex to
        its end vertex as the curve runs, its ends on the vertices' points."""
        if ident not in self.edges:
            element = self.items[ident]
            start = self.vertex(element, "VertexBeg")
            end = self.vertex(element, "VertexEnd")
            self.edges[ident] = _curve_edges(self.core(element, "Curve"), start, end)
        return self.edges[ident]

    def vertex(self, edge: ET.Element, name: str) -> np.ndarray:
        """(3,) the point of an edge's vertex."""
        vertex = self.items[_text(_child(_child(edge, name), "Id"))]
        point = self.items[_text(_child(_child(vertex, "Point"), "Id"))]
        return _numbers(_child(point, "XYZ"))


def _trimmed(surface, wires):
    """A Part.Face on surface bounded by wires (the outer first), fixed: the inner wires'
    orientation, the edges' curves on the surface."""
    import Part

    face = Part.Face(surface, wires[0])   # (with a list of wires OCC makes no face on a cylinder)
    if len(wires) > 1:
        face.cutHoles(wires[1:])
    face.fix(1e-7, 1e-7, SEWING_MM)
    return face


def _patch_area(core: ET.Element) -> float | None:
    """The most area a face on a closed surface core can have (mm^2 in the file's units): its
    torus or sphere patch's (LatitudeLongitudeSweep), whatever latitude its zero is at; None
    for the other surfaces, on which a loop bounds one region."""
    kind = core.tag.split("}")[-1]
    sweep = core.find(tag("LatitudeLongitudeSweep"))
    if kind not in ("Torus23Core", "Sphere23Core") or sweep is None:
        return None
    latitude = np.ptp(_numbers(_child(sweep, "DomainLatitude")))
    longitude = np.ptp(_numbers(_child(sweep, "DomainLongitude")))
    slack = 1.0 + 1e-6
    if kind == "Torus23Core":
        major, minor = _number(core, "DiameterMajor") / 2.0, _number(core, "DiameterMinor") / 2.0
        return slack * minor * longitude * (major * latitude + 2.0 * minor)
    radius = _number(core, "Diameter") / 2.0
    return slack * radius ** 2 * longitude * min(2.0, latitude)


def _curve_edges(core: ET.Element, start: np.ndarray, end: np.ndarray) -> list:
    """The Part.Edges of a 3D curve core (Segment13Core, ArcCircular13Core, Nurbs13Core,
    Aggregate13Core), the first starting at ``start`` and the last ending at ``end`` (3,)."""
    kind = core.tag.split("}")[-1]
    if kind == "Aggregate13Core":
        subs = list(_child(core, "SubCurves"))
        pieces: list[tuple[object, np.ndarray]] = []
        for k, sub in enumerate(subs):
            inner = _core(sub)
            ends = _natural_ends(inner)
            if sub.get("turned") == "true":
                ends = ends[::-1]
            first = start if k == 0 else pieces[-1][1]
            last = end if k == len(subs) - 1 else ends[1]
            piece = _curve_edges(inner, *((last, first) if sub.get("turned") == "true" else (first, last)))[0]
            pieces.append((piece.reversed() if sub.get("turned") == "true" else piece, last))
        return [piece for piece, _ in pieces]
    return [_simple_edge(core, start, end)]


def _natural_ends(core: ET.Element) -> tuple[np.ndarray, np.ndarray]:
    """(start, end) of a simple curve core as it runs over its domain."""
    edge = _simple_edge(core, None, None)
    return np.array(tuple(edge.valueAt(edge.FirstParameter))), np.array(tuple(edge.valueAt(edge.LastParameter)))


def _simple_edge(core: ET.Element, start: np.ndarray | None, end: np.ndarray | None):
    """A Part.Edge of a segment, circular arc or NURBS curve core over its domain, its ends
    moved onto ``start``/``end`` (3,) where given (a NURBS's end poles, a segment's ends, an
    arc through its middle point)."""
    import Part
    from FreeCAD import Vector

    kind = core.tag.split("}")[-1]
    domain = [float(v) for v in core.get("domain", "0 1").split()]
    if kind == "Segment13Core":
        a = _numbers(_child(core, "StartPoint")) if start is None else start
        b = _numbers(_child(core, "EndPoint")) if end is None else end
        return Part.LineSegment(Vector(*a), Vector(*b)).toShape()
    if kind == "ArcCircular13Core":
        radius = _number(core, "Radius")
        centre, first, normal = (_numbers(_child(core, n)) for n in ("Center", "DirBeg", "Normal"))
        first = first / np.linalg.norm(first)
        normal = normal / np.linalg.norm(normal)
        second = np.cross(normal, first)

        def at(angle):
            return centre + radius * (np.cos(angle) * first + np.sin(angle) * second)

        a = at(domain[0]) if start is None else start
        b = at(domain[1]) if end is None else end
        if np.linalg.norm(a - b) < 1e-9 * max(radius, 1.0):   # a full circle
            circle = Part.Circle(Vector(*centre), Vector(*normal), radius)
            circle.XAxis = Vector(*first)
            return Part.Edge(circle, domain[0], domain[1])
        return Part.Arc(Vector(*a), Vector(*at(0.5 * (domain[0] + domain[1]))), Vector(*b)).toShape()
    if kind == "Nurbs13Core":
        curve = _nurbs_curve(core)
        if start is not None:
            curve.setPole(1, Vector(*start))
        if end is not None:
            curve.setPole(curve.NbPoles, Vector(*end))
        return curve.toShape()
    raise NotImplementedError(f"a {kind.removesuffix('Core')} curve is not built")


def _nurbs_curve(core: ET.Element):
    """A Part.BSplineCurve from a Nurbs13Core (order, knots, control points, weights)."""
    import Part
    from FreeCAD import Vector

    order = int(_number(core, "Order"))
    poles = _points(core, "CPs", 3)
    weights = _weights(core, len(poles))
    knots, multiplicities = _knots(_numbers(_child(core, "Knots")))
    curve = Part.BSplineCurve()
    curve.buildFromPolesMultsKnots([Vector(*p) for p in poles], multiplicities, knots, False, order - 1,
                                   weights)
    return curve


def _surface(core: ET.Element):
    """A Part surface of a surface core: Plane23, Cylinder23, Cone23, Sphere23, Torus23, Nurbs23."""
    import Part
    from FreeCAD import Vector

    kind = core.tag.split("}")[-1].removesuffix("Core")
    axis = core.find(tag("Axis"))
    if axis is not None:
        point = Vector(*_numbers(_child(axis, "AxisPoint")))
        direction = Vector(*_numbers(_child(axis, "Direction")))
    if kind == "Plane23":
        origin, u, v = (Vector(*_numbers(_child(core, n))) for n in ("Origin", "DirU", "DirV"))
        return Part.Plane(origin, u.cross(v))
    if kind == "Cylinder23":
        cylinder = Part.Cylinder()
        cylinder.Radius = _number(core, "Diameter") / 2.0
        cylinder.Center, cylinder.Axis = point, direction
        return cylinder
    if kind == "Cone23":
        bottom, top = _number(core, "DiameterBottom") / 2.0, _number(core, "DiameterTop") / 2.0
        return Part.Cone(point, point + direction.normalize() * _number(core, "Length"), bottom, top)
    if kind == "Sphere23":
        sphere = Part.Sphere()
        sphere.Radius = _number(core, "Diameter") / 2.0
        sphere.Center = Vector(*_numbers(_child(core, "Location")))
        return sphere
    if kind == "Torus23":
        torus = Part.Toroid()
        torus.MajorRadius = _number(core, "DiameterMajor") / 2.0
        torus.MinorRadius = _number(core, "DiameterMinor") / 2.0
        torus.Center, torus.Axis = point, direction
        return torus
    if kind == "Nurbs23":
        return _nurbs_surface(core)
    raise NotImplementedError(f"a {kind} surface is not built")


def _nurbs_surface(core: ET.Element):
    """A Part.BSplineSurface from a Nurbs23Core (control points with u varying fastest)."""
    import Part
    from FreeCAD import Vector

    order_u, order_v = int(_number(core, "OrderU")), int(_number(core, "OrderV"))
    knots_u, mults_u = _knots(_numbers(_child(core, "KnotsU")))
    knots_v, mults_v = _knots(_numbers(_child(core, "KnotsV")))
    count_u, count_v = sum(mults_u) - order_u, sum(mults_v) - order_v
    poles = _points(core, "CPs", 3).reshape(count_v, count_u, 3).transpose(1, 0, 2)
    weights = np.reshape(_weights(core, count_u * count_v), (count_v, count_u)).T
    surface = Part.BSplineSurface()
    surface.buildFromPolesMultsKnots([[Vector(*p) for p in row] for row in poles], mults_u, mults_v, knots_u,
                                     knots_v, False, False, order_u - 1, order_v - 1,
                                     [[float(w) for w in row] for row in weights])
    return surface


def _knots(values: np.ndarray) -> tuple[list[float], list[int]]:
    """Distinct knots and their multiplicities from a full knot vector."""
    distinct: list[float] = []
    counts: list[int] = []
    for value in values:
        if distinct and abs(value - distinct[-1]) <= 1e-12 * max(1.0, abs(value)):
            counts[-1] += 1
        else:
            distinct.append(float(value))
            counts.append(1)
    return distinct, counts


def _points(core: ET.Element, name: str, size: int) -> np.ndarray:
    """(N, size) numbers of a point array, written as text or base64 doubles (``<name>Binary``)."""
    written = core.find(tag(name))
    if written is not None:
        return _numbers(written).reshape(-1, size)
    data = base64.b64decode("".join((_child(core, name + "Binary").text or "").split()))
    return np.array(struct.unpack(f"<{len(data) // 8}d", data)).reshape(-1, size)


def _weights(core: ET.Element, count: int) -> list[float]:
    """The control points' weights (all 1 where the file gives none)."""
    written = core.find(tag("Weights"))
    return [1.0] * count if written is None else [float(w) for w in _numbers(written)]


def _numbers(element: ET.Element) -> np.ndarray:
    """The numbers of an element's text."""
    return np.array((element.text or "").split(), dtype=float)


def _child(element: ET.Element, name: str) -> ET.Element:
    """An element's child of a QIF name; ValueError naming what is missing."""
    found = element.find(tag(name))
    if found is None:
        raise ValueError(f"{element.tag.split('}')[-1]} {element.get('id', '')} has no {name}")
    return found


def _number(element: ET.Element, name: str) -> float:
    """The number a child of a QIF name holds."""
    return float(_text(_child(element, name)))


def _text(element: ET.Element) -> str:
    """An element's stripped text."""
    return (element.text or "").strip()


def _core(item: ET.Element) -> ET.Element:
    """The core child (e.g. Plane23Core) of a geometry item."""
    found = next((child for child in item if child.tag.endswith("Core")), None)
    if found is None:
        raise ValueError(f"{item.tag.split('}')[-1]} {item.get('id', '')} has no core")
    return found


def inner_points(face, count: int = INNER_POINTS) -> np.ndarray:
    """(<= count, 3) mm: points inside a face, none on its boundary (shared with its neighbours):
    the centres of triangles of its tessellation spread over it, moved onto its surface."""
    vertices, triangles = face.tessellate(max(face.BoundBox.DiagonalLength, 1e-6) / 50.0)
    corners = np.array([tuple(v) for v in vertices], dtype=float)[np.array(triangles, dtype=int).reshape(-1, 3)]
    if not len(corners):
        centres = np.array([tuple(face.CenterOfMass)])
    else:
        centres = corners.mean(axis=1)[np.linspace(0, len(corners) - 1, min(count, len(corners))).astype(int)]
    surface = face.Surface
    return np.array([tuple(surface.value(*surface.parameter(_vector(centre)))) for centre in centres], dtype=float)


def _vector(point: np.ndarray):
    """A FreeCAD.Vector of a (3,) point."""
    from FreeCAD import Vector

    return Vector(*map(float, point))
