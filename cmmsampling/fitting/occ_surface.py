"""The substitute as OCC geometry: the fitted B-spline handed to FreeCAD (Part.BSplineSurface) over
the face's parameter range, the surface the deviation is measured on, and that surface trimmed like
the face (the shape the document shows)."""
from ..geometry.freecad_env import import_part
from ..geometry.surface import make_bspline_surface

Part = import_part()


def substitute_surface(space, poles):
    """The substitute fitted in ``space`` (a SubstituteSpace) as a Part.BSplineSurface over the
    face's parameter range. poles: (n_u, n_v, 3) mm."""
    return make_bspline_surface(poles, space.degrees, uknots=space.uknots, vknots=space.vknots)


def trimmed_like(face, surface):
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


def _wire_on(face, wire, surface):
    """A wire of ``face`` laid on ``surface``: each edge's curve on the face's surface, as an edge of
    the substitute over the same parameter interval."""
    edges = []
    for edge in wire.OrderedEdges or wire.Edges:
        curve, first, last = face.curveOnSurface(edge)[:3]
        edges.append(curve.toShape(surface, first, last))
    return Part.Wire(edges)
