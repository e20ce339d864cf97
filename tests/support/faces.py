"""Geometry shared by the tests: faces of every kind, random parameters, the test-data folder."""
import os

import numpy as np
import pytest

from cmmsampling.geometry.freecad_env import import_part

Part = import_part()
import FreeCAD  # noqa: E402,F401  (importable once import_part() has set the path)
from cmmsampling.geometry.surface import make_bspline_surface, reference_poles  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TESTDATA = os.path.join(os.path.dirname(ROOT), "shared", "testdata")


def reference_document(name, undo_mode):
    """A fresh FreeCAD document with the reference face as Part::Feature 'Body'; undo_mode 1 or 0."""
    import cmmsampling

    document = FreeCAD.newDocument(name)
    document.UndoMode = undo_mode
    document.addObject("Part::Feature", "Body").Shape = cmmsampling.reference_face()
    document.recompute()
    return document


def closed(document_name):
    """Close the document of that name if it is still open."""
    if document_name in FreeCAD.listDocuments():
        FreeCAD.closeDocument(document_name)


def rational_patch_face(seed=3):
    """A rational bicubic NURBS patch (5 x 4 poles, weights 0.5..2) as a Part.Face."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 40, 5), np.linspace(0, 30, 4), indexing="ij")
    z = 5 * np.sin(x / 13) * np.cos(y / 11) + rng.normal(0, 1, x.shape)
    weights = rng.uniform(0.5, 2.0, x.shape)
    surface = make_bspline_surface(np.stack([x, y, z], -1), (3, 3), weights=weights)
    return surface.toShape()


def rational_saddle(seed=1):
    """A rational bicubic saddle, 7 x 7 poles over 100 x 100 mm, weights 0.4..2.5."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 100, 7), np.linspace(0, 100, 7), indexing="ij")
    z = 20 * ((x - 50) ** 2 - (y - 50) ** 2) / 2500
    return make_bspline_surface(np.stack([x, y, z], -1), (3, 3),
                                weights=rng.uniform(0.4, 2.5, x.shape)).toShape()


def clustered_reversed_face():
    """A rational, reversed 40 x 40 mm patch (degrees 2 x 3, knots clustered near u = 0, a
    v range of [2, 50]) where OCC's distToShape puts a point of the face itself 6.07 mm off it
    (at u, v = 0.799, 2.056)."""
    x, y = np.meshgrid(np.linspace(0, 40, 6), np.linspace(0, 40, 6), indexing="ij")
    poles = [[FreeCAD.Vector(a, b, 5 * np.cos(a / 9) * np.sin(b / 8)) for a, b in zip(row_x, row_y)]
             for row_x, row_y in zip(x, y)]
    surface = Part.BSplineSurface()
    surface.buildFromPolesMultsKnots(poles, [3, 1, 1, 1, 3], [4, 1, 1, 4], [0, 0.01, 0.03, 0.9, 1],
                                     [2, 2.1, 2.2, 50], False, False, 2, 3,
                                     (1 + 2 * (x / 40) ** 2).tolist())
    return surface.toShape().reversed()


def creased_face():
    """A degree-1 patch of 3 x 3 flat quads, 45 x 45 mm, heights 0, 2 or 4 mm: only C0 across its
    knot lines u, v = 1 and 2 (creases), its largest kinks where those lines cross."""
    poles = [[FreeCAD.Vector(15 * i, 15 * j, ((i * j) % 3) * 2) for j in range(4)] for i in range(4)]
    surface = Part.BSplineSurface()
    surface.buildFromPolesMultsKnots(poles, [2, 1, 1, 2], [2, 1, 1, 2], [0, 1, 2, 3], [0, 1, 2, 3],
                                     False, False, 1, 1)
    return surface.toShape()


def strip_face():
    """A curved strip 60 mm long and 2 mm wide (a blade-like face)."""
    x, y = np.meshgrid(np.linspace(0, 60, 7), np.linspace(0, 2, 4), indexing="ij")
    z = 6 * np.sin(x / 12) + 0.8 * y * np.cos(x / 9)
    return make_bspline_surface(np.stack([x, y, z], -1), (3, 3)).toShape()


def shared_face(name, index):
    """Face ``index`` of the shared CAD file ``name`` (e.g. 'surf114.igs'); the test is skipped
    where the shared test data are not beside the checkout."""
    path = os.path.join(TESTDATA, name)
    if not os.path.isfile(path):
        pytest.skip(f"the shared test data ({name}) is not here")
    return Part.read(path).Faces[index]


def collapsed_face():
    """The reference surface with its first pole row collapsed to one point (a degenerate edge)."""
    poles = reference_poles().copy()
    poles[0, :, :] = poles[0, 4, :]
    return make_bspline_surface(poles, (5, 5)).toShape()


def tolerant_face():
    """A degree-8 Bezier patch trimmed by a wobbly closed curve whose 3D curve and curve on the
    surface differ by up to 0.012 mm, its tolerance raised to 0.02 mm: valid by OCC's
    ``isValid()`` and ``check(True)``, yet points on its boundary by the face classifier lie up to
    0.02 mm from it by OCC's distance."""
    grid = np.arange(9) * 10.0
    x, y = np.meshgrid(grid, grid, indexing="ij")
    surface = make_bspline_surface(np.stack([x, y, 3 * np.sin(0.07 * x) * np.cos(0.05 * y)], -1), (8, 8))
    angles = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    wobble = 0.012 * np.sin(3 * angles)
    boundary = [surface.value(0.5 + 0.4 * np.cos(a), 0.5 + 0.4 * np.sin(a))
                + FreeCAD.Vector(np.cos(a), np.sin(a), 0) * w for a, w in zip(angles, wobble)]
    curve = Part.BSplineCurve()
    curve.interpolate(boundary, PeriodicFlag=True)
    face = Part.Face(surface, Part.Wire([curve.toShape()]))
    face.fix(1e-7, 1e-7, 0.1)
    face.fixTolerance(0.02)
    return face


def wavy_plate():
    """A wavy 100 x 100 mm bicubic B-spline plate as a Part.Face."""
    x, y = np.meshgrid(np.linspace(0, 100, 6), np.linspace(0, 100, 6), indexing="ij")
    z = 8 * np.sin(x / 30) * np.cos(y / 25)
    return make_bspline_surface(np.stack([x, y, z], -1), (3, 3)).toShape()


def holed_face(diameter=16.0):
    """The wavy plate with a hole of that diameter (mm) cut through it (trimmed)."""
    hole = Part.makeCylinder(0.5 * diameter, 100, FreeCAD.Vector(40, 55, -50))
    return wavy_plate().cut(hole).Faces[0]


def diagonal_band():
    """A 6 mm wide band of the wavy plate, trimmed diagonally across it (curved trim curves)."""
    box = Part.makeBox(6, 200, 100, FreeCAD.Vector(-3, -100, -50))
    box.rotate(FreeCAD.Vector(0, 0, 0), FreeCAD.Vector(0, 0, 1), -45)
    box.translate(FreeCAD.Vector(50, 50, 0))
    return wavy_plate().common(box).Faces[0]


def cartesian_refuses(strategy, closed, run):
    """For uniform Cartesian on a closed face (its far side hides behind its near side in every
    machine view, so the footprint grid misses it) check that run() is refused and return True;
    otherwise return False and leave the run to the caller."""
    if strategy != "uniform_cartesian" or not closed:
        return False
    with pytest.raises(ValueError, match="leaves part of the face without points"):
        run()
    return True


def uv_samples(model, count=40, seed=0):
    """Random (count, 2) parameters inside the model's parameter range."""
    u0, u1, v0, v1 = model.bounds
    unit = np.random.default_rng(seed).random((count, 2))
    return np.column_stack([u0 + unit[:, 0] * (u1 - u0), v0 + unit[:, 1] * (v1 - v0)])


def sample_faces():
    """Named faces covering non-rational, rational, converted, reversed and periodic cases."""
    import cmmsampling

    box = Part.makeBox(30, 20, 10)
    return {
        "reference_bspline": cmmsampling.reference_face(),
        "rational_patch": rational_patch_face(),
        "cylinder_converted": Part.makeCylinder(10, 20).Faces[0],
        "torus_converted": Part.makeTorus(20, 5).Faces[0],
        "sphere_converted": Part.makeSphere(10).Faces[0],
        "box_face_reversed": [f for f in box.Faces if f.Orientation == "Reversed"][0],
    }


def walled_part():
    """A 60 x 40 x 10 mm base with a wall 10 mm thick and 50 mm high over x = 0..10, and the
    numbers (from 1) of its two upward faces: (Part.Shape, [k, k])."""
    part = Part.makeBox(60, 40, 10).fuse(Part.makeBox(10, 40, 60, FreeCAD.Vector(0, 0, 10))).removeSplitter()
    upward = [k for k, face in enumerate(part.Faces, start=1)
              if face.normalAt(*face.Surface.parameter(face.CenterOfMass)).z > 0.5]
    return part, upward

