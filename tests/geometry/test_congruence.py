"""Congruent faces: a rigid copy of a face is found with the motion that makes it, a moved start
of a revolved face's parameters included; a scaled or mirrored face, or another face, is none."""
import math

import numpy as np
import pytest
from support.faces import FreeCAD, Part, holed_face, rational_patch_face, rational_saddle

from cmmsampling.geometry.congruence import FacePrint, face_copies, rigid_copy
from cmmsampling.geometry.surface import SurfaceModel


def printed(face):
    return FacePrint(SurfaceModel.from_face(face), face.Area)


def moved(face, angle_deg, axis, shift):
    """A copy of face with its geometry turned about axis through the origin, then moved by shift (mm)."""
    placement = FreeCAD.Placement(FreeCAD.Vector(*shift), FreeCAD.Rotation(FreeCAD.Vector(*axis), angle_deg))
    return face.transformGeometry(placement.toMatrix()).Faces[0]


def rotation_matrix(angle_deg, axis):
    rotation = FreeCAD.Rotation(FreeCAD.Vector(*axis), angle_deg).toMatrix()
    return np.array([[rotation.A[4 * row + col] for col in range(3)] for row in range(3)])


@pytest.fixture(scope="module")
def saddle():
    return rational_saddle()


def test_a_turned_and_moved_copy_is_found_with_its_motion(saddle):
    copy = moved(saddle, 37.0, (1, 2, 3), (10, -20, 5))
    found = rigid_copy(printed(saddle), printed(copy), index=4)
    assert found is not None and found.original == 4
    np.testing.assert_allclose(found.rotation, rotation_matrix(37.0, (1, 2, 3)), atol=1e-9)
    np.testing.assert_allclose(found.translation, [10, -20, 5], atol=1e-7)
    np.testing.assert_allclose(found.shift, [0, 0], atol=1e-12)
    assert found.angle_deg == pytest.approx(37.0, abs=1e-6)
    assert found.motion_text == f"turned 37 deg, moved {math.sqrt(525):.4g} mm"
    assert rigid_copy(printed(saddle), printed(saddle)).motion_text == "in place"


def test_a_revolved_face_started_at_another_angle_is_a_copy_with_a_parameter_shift():
    """Two 60 deg pieces of one cylinder, one from 0 deg, one from 90 deg: the second is the first
    turned 90 deg about the axis, its u parameters the first's plus pi / 2."""
    cylinder = Part.Cylinder()
    cylinder.Radius = 12.0
    first = cylinder.toShape(0.0, math.pi / 3, 0.0, 30.0)
    second = cylinder.toShape(math.pi / 2, math.pi / 2 + math.pi / 3, 0.0, 30.0)
    found = rigid_copy(printed(first), printed(second))
    assert found is not None
    np.testing.assert_allclose(found.shift, [math.pi / 2, 0.0], atol=1e-12)
    assert found.angle_deg == pytest.approx(90.0, abs=1e-6)
    longer = cylinder.toShape(0.0, math.pi / 2, 0.0, 30.0)
    assert rigid_copy(printed(first), printed(longer)) is None


def test_a_scaled_mirrored_or_other_face_is_no_copy(saddle):
    scale = FreeCAD.Matrix()
    scale.scale(1.001, 1.001, 1.001)
    assert rigid_copy(printed(saddle), printed(saddle.transformGeometry(scale).Faces[0])) is None
    mirror = FreeCAD.Matrix()
    mirror.scale(1.0, 1.0, -1.0)   # a mirror image: no proper rotation takes the saddle onto it
    assert rigid_copy(printed(saddle), printed(saddle.transformGeometry(mirror).Faces[0])) is None
    assert rigid_copy(printed(saddle), printed(rational_saddle(seed=2))) is None
    assert rigid_copy(printed(saddle), printed(rational_patch_face())) is None


def test_each_face_copies_the_first_original_it_matches(saddle):
    faces = [saddle, holed_face(), moved(saddle, 90.0, (0, 0, 1), (0, 0, 0)), rational_patch_face(),
             moved(saddle, 180.0, (0, 1, 0), (5, 5, 5))]
    prints = [printed(face) for face in faces[:3]] + [None] + [printed(faces[4])]
    found = face_copies(prints)
    assert [None if copy is None else copy.original for copy in found] == [None, None, 0, None, 0]
