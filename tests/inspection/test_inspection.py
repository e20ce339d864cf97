"""The inspection loop with the virtual CMM: measured points read back, aligned, judged.

The alignment is checked against an independent point-to-plane fit written here with OCC's own
closest points (distToShape) and scipy's rotations, on a built rational face and on a face of the
shared CAD files (skipped without them)."""
import os

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation
from support.faces import TESTDATA, Part, rational_patch_face

import cmmsampling
from cmmsampling.geometry.validation import InputError

import FreeCAD  # noqa: E402,I100  (importable once support.faces has set the path)

MISPLACED = {"rx": 0.6, "ry": -0.8, "rz": 1.0, "x": 1.5, "y": -2.0, "z": 0.7}


@pytest.fixture(scope="module", params=["rational patch", "surf114 Face2"])
def planned(request):
    """A Halton plan of 36 points on a built rational face or on a real part's free-form face
    (surf114.igs's second face: one face alone fixes all six motions there, unlike a narrow strip
    such as the Ventilator's Face61, which lets the points slide along it)."""
    if request.param == "rational patch":
        face = rational_patch_face()
    else:
        path = os.path.join(TESTDATA, "surf114.igs")
        if not os.path.isfile(path):
            pytest.skip("the shared test data (surf114.igs) is not here")
        face = Part.read(path).Faces[1]
    return cmmsampling.sample(face, 36, "halton", occ_check=False)


def occ_feet(face, points):
    """Feet and outward normals of points (N, 3) on face by OCC, written here independently."""
    feet, normals = [], []
    for point in points:
        foot = face.distToShape(Part.Vertex(FreeCAD.Vector(*point)))[1][0][0]
        u, v = face.Surface.parameter(foot)
        feet.append(tuple(foot))
        normals.append(tuple(face.normalAt(u, v)))
    return np.array(feet), np.array(normals)


def point_to_plane_fit(face, points):
    """The least-squares rigid motion by scipy's least_squares over a rotation vector about the
    points' box corner and a shift, the residuals OCC's signed distances: the aligned points
    (N, 3) and their signed deviations (N,)."""
    origin = points.min(axis=0)

    def moved(x):
        return Rotation.from_rotvec(x[:3]).apply(points - origin) + origin + x[3:]

    def residuals(x):
        where = moved(x)
        feet, normals = occ_feet(face, where)
        return np.einsum("ij,ij->i", where - feet, normals)

    solved = least_squares(residuals, np.zeros(6), x_scale=np.r_[np.full(3, 0.01), np.ones(3)],
                           xtol=1e-14, ftol=1e-14, gtol=1e-14)
    return moved(solved.x), residuals(solved.x)


def test_the_best_fit_undoes_a_misplacement_to_a_micrometre(planned, tmp_path):
    made = cmmsampling.simulate_measurement(planned, tmp_path / "measured.dmi", misplacement=MISPLACED)
    assert np.linalg.norm(made.actual - planned.points, axis=1).min() > 0.5   # the part really lies elsewhere
    found = cmmsampling.inspect(planned, tmp_path / "measured.dmi", tolerance=0.01)
    assert found.labels == [f"P{i}" for i in range(1, 37)]
    assert np.linalg.norm(found.points - planned.points, axis=1).max() < 1e-3   # 1 um at the points
    assert np.abs(found.deviations).max() < 1e-3 and found.passed
    assert np.allclose(found.transform @ made.misplacement, np.eye(4), atol=1e-5)
    placement = found.placement.toMatrix()
    assert np.allclose([placement.A[k] for k in range(16)], found.transform.ravel(), atol=1e-12)
    assert found.alignment.moved_mm > 0.5


def test_with_a_form_error_the_deviations_are_an_independent_point_to_plane_fits(planned, tmp_path):
    made = cmmsampling.simulate_measurement(planned, tmp_path / "measured.csv", form_error=0.03,
                                            misplacement=MISPLACED, seed=4)
    found = cmmsampling.inspect(planned, tmp_path / "measured.csv", tolerance=0.05)
    aligned, deviations = point_to_plane_fit(planned.face, made.actual)
    assert np.abs(found.deviations - deviations).max() < 1e-3   # 1 um
    assert np.linalg.norm(found.points - aligned, axis=1).max() < 1e-3
    assert 0.005 < found.profile < 0.12 and found.profile == pytest.approx(2 * np.abs(deviations).max(), abs=2e-3)


def test_min_max_gives_a_profile_no_wider_than_the_best_fits(planned, tmp_path):
    cmmsampling.simulate_measurement(planned, tmp_path / "measured.dmi", form_error=0.03, noise=0.002,
                                     misplacement=MISPLACED, seed=2)
    best = cmmsampling.inspect(planned, tmp_path / "measured.dmi")
    chebyshev = cmmsampling.inspect(planned, tmp_path / "measured.dmi", alignment="min_max")
    assert chebyshev.profile <= best.profile + 1e-9
    assert chebyshev.deviations.max() == pytest.approx(-chebyshev.deviations.min(), abs=2e-4)   # equioscillation


def test_locked_degrees_of_freedom_stay_put(planned, tmp_path):
    cmmsampling.simulate_measurement(planned, tmp_path / "shifted.dmi", misplacement={"z": 0.4})
    found = cmmsampling.inspect(planned, tmp_path / "shifted.dmi", locked=("rx", "ry", "rz", "x", "y"))
    assert np.allclose(found.transform[:3, :3], np.eye(3)) and np.allclose(found.transform[:2, 3], 0)
    assert found.transform[2, 3] == pytest.approx(-0.4, abs=1e-4) and np.abs(found.deviations).max() < 1e-4
    same = cmmsampling.inspect(planned, tmp_path / "shifted.dmi", alignment="none")
    assert np.allclose(same.transform, np.eye(4)) and np.abs(same.deviations).max() > 0.1


def test_a_tolerance_judges_each_point_and_the_face(planned, tmp_path):
    cmmsampling.simulate_measurement(planned, tmp_path / "measured.dmi", form_error=0.03, seed=5)
    found = cmmsampling.inspect(planned, tmp_path / "measured.dmi", alignment="none", tolerance=0.02)
    assert found.profile > 0.02 and not found.passed
    assert np.array_equal(found.within, np.abs(found.deviations) <= 0.01) and not found.within.all()
    assert "tolerance 0.02 mm: FAIL" in found.summary()


def test_bad_measurements_are_named(planned, tmp_path):
    made = cmmsampling.simulate_measurement(planned, tmp_path / "measured.dmi")
    text = (tmp_path / "measured.dmi").read_text()
    (tmp_path / "stranger.dmi").write_text(text.replace("FA(P7)=", "FA(Q7)="))
    with pytest.raises(InputError, match="measured point Q7 was not planned"):
        cmmsampling.inspect(planned, tmp_path / "stranger.dmi")
    (tmp_path / "twice.dmi").write_text(text.replace("FA(P7)=", "FA(P8)="))
    with pytest.raises(InputError, match=r"line \d+: FA\(P8\) is given twice"):
        cmmsampling.inspect(planned, tmp_path / "twice.dmi")
    lines = text.splitlines()
    broken = next(k for k, line in enumerate(lines) if line.startswith("FA(P3)="))
    lines[broken] = lines[broken].replace("FEAT/POINT,CART,", "FEAT/POINT,CART,1,5,")
    (tmp_path / "broken.dmi").write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=f"line {broken + 1}: expected 6 numbers"):
        cmmsampling.inspect(planned, tmp_path / "broken.dmi")
    few = cmmsampling.PointSet(made.labels[:2], made.actual[:2], planned.normals[:2])
    with pytest.raises(InputError, match="2 measured points cannot fix 6 degrees of freedom"):
        cmmsampling.inspect(planned, few)
    unlabelled = cmmsampling.PointSet([f"M{i}" for i in range(5)], made.actual[:5], planned.normals[:5])
    with pytest.raises(InputError, match="cannot be paired by order"):
        cmmsampling.inspect(planned, unlabelled)
    with pytest.raises(InputError, match="alignment must be one of none, best_fit, min_max"):
        cmmsampling.inspect(planned, few, alignment="icp")
    with pytest.raises(InputError, match="'tz' is no degree of freedom"):
        cmmsampling.inspect(planned, few, locked=("tz",))
