"""The substitute as OCC geometry: the fitted B-spline handed to FreeCAD (Part.BSplineSurface) over
the face's parameter range, the surface the deviation is measured on, and that surface trimmed like
the face (the shape the document shows)."""
from __future__ import annotations

from typing import TYPE_CHECKING

from ..geometry.freecad_env import import_part
from ..geometry.surface import make_bspline_surface

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import numpy as np
    import Part

    from .substitute import SubstituteSpace
else:
    Part = import_part()
from FreeCAD import Base  # noqa: E402  (importable once import_part() has set the path)


def substitute_surface(space: SubstituteSpace, poles: np.ndarray) -> Part.BSplineSurface:
    """The substitute fitted in ``space`` (a SubstituteSpace) as a Part.BSplineSurface over the
    face's parameter range. poles: (n_u, n_v, 3) mm."""
    return make_bspline_surface(poles, space.degrees, uknots=space.uknots, vknots=space.vknots)


def trimmed_like(face: Part.Face, surface: Part.BSplineSurface) -> Part.Shape:
    """The substitute ``surface`` (Part.BSplineSurface over the face's parameter range) trimmed like
    the Part.Face ``face`` in the parameter plane: a Part.Face bounded by the face's wires' curves on
    its surface, laid on the substitute (holes cut). Where OCC cannot build a valid face from them,
    the substitute's whole rectangle (``surface.toShape()``)."""
    try:
        outer = _wire_on(face, face.OuterWire, surface)
        trimmed = Part.Face(surface, outer)
        if trimmed.Area < 0:
            outer.reverse()
            trimmed = Part.Face(surface, outer)
        holes = [_wire_on(face, wire, surface) for wire in face.Wires if not wire.isSame(face.OuterWire)]
        if holes:
            trimmed.cutHoles(holes)
        if trimmed.isValid() and trimmed.Area > 0:
            return trimmed
    except Part.OCCError:
        pass
    return surface.toShape()


def _wire_on(face: Part.Face, wire: Part.Wire, surface: Part.BSplineSurface) -> Part.Wire:
    """A wire of ``face`` laid on ``surface``: each edge's curve on the face's surface, run in the
    wire's direction, as an edge of the substitute over the same parameter interval. A STEP
    file's curves on the surface often leave gaps at the corners (1e-4 of a parameter on
    Ventilator faces, within the edges' tolerance), which OCC's wire does not bridge: each gap
    is closed at its middle first (:func:`_close_gaps`)."""
    curves = [_directed_curve(face, edge) for edge in wire.OrderedEdges or wire.Edges]
    _close_gaps(curves)
    return Part.Wire([curve.toShape(surface, curve.FirstParameter, curve.LastParameter) for curve in curves])


def _directed_curve(face: Part.Face, edge: Part.Edge) -> Part.Geom2d.BSplineCurve2d:
    """The edge's curve on the face's surface as a 2D B-spline (Part.Geom2d.BSplineCurve2d) that
    runs the way the edge is used in its wire (reversed for a reversed edge)."""
    curve, first, last = face.curveOnSurface(edge)[:3]
    spline = curve.toBSpline(first, last)
    if edge.Orientation == "Reversed":
        spline.reverse()
    return spline


def _close_gaps(curves: list[Part.Geom2d.BSplineCurve2d]) -> None:
    """Make each 2D B-spline of a closed chain (a list, in order) end where the next one starts:
    the last pole of one and the first pole of the next (a clamped spline's end points) both
    moved to the middle of the gap between them."""
    for current, following in zip(curves, curves[1:] + curves[:1]):
        end, start = current.value(current.LastParameter), following.value(following.FirstParameter)
        middle = Base.Vector2d((end.x + start.x) / 2, (end.y + start.y) / 2)
        current.setPole(current.NbPoles, middle)
        following.setPole(1, middle)
