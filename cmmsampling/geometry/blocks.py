"""A built part for datum reference frames: a block whose top is free-form and whose sides are
three planes square to each other (the demo's and the tests' part for profiles relative to
datums A | B | C). Lengths in mm."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .freecad_env import import_part

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

# The block's faces by role: the wavy top (the toleranced face) and the datums A, B, C.
TOP, DATUM_FACES = "Face3", ("Face1", "Face5", "Face4")


def datum_block(length: float = 100.0, depth: float = 60.0, height: float = 30.0, wave: float = 3.0) -> Part.Solid:
    """The block: Face1 the base (z = 0, datum A), Face5 the side y = 0 (B), Face4 the end x = 0
    (C) and Face3 the wavy top, a B-spline curve z = height + wave sin(3 pi x / length)
    interpolated through 21 points and extruded along y by depth; all mm."""
    xs = np.linspace(0.0, length, 21)
    top = [FreeCAD.Vector(x, 0.0, height + wave * np.sin(3 * np.pi * x / length)) for x in xs]
    curve = Part.BSplineCurve()
    curve.interpolate(top)
    edges = [Part.makeLine(FreeCAD.Vector(0, 0, 0), FreeCAD.Vector(length, 0, 0)),
             Part.makeLine(FreeCAD.Vector(length, 0, 0), top[-1]), curve.toShape(),
             Part.makeLine(top[0], FreeCAD.Vector(0, 0, 0))]
    return Part.Face(Part.Wire(Part.__sortEdges__(edges))).extrude(FreeCAD.Vector(0, depth, 0))
