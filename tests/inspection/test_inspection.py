"""The inspection loop with the virtual CMM: measured points read back, aligned, judged.

The alignment is checked against an independent point-to-plane fit written here with OCC's own
closest points (distToShape) and scipy's rotations, on a built rational face and on a face of the
shared CAD files (skipped without them)."""

import re

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation
from support.faces import Part, rational_patch_face, shared_face

import cmmsampling
from cmmsampling.geometry.validation import InputError

import FreeCAD  # noqa: E402,I100  (importable once support.faces has set the path)

MISPLACED = {"rx": 0.6, "ry": -0.8, "rz": 1.0, "x": 1.5, "y": -2.0, "z": 0.7}


@pytest.fixture(scope="module", params=["rational patch", "surf114 Face2"])
def planned(request):
    """A Halton plan of 36 points on a built rational face or on a real part's free-form face
    (surf114.igs's second face: one face alone fixes all six motions there, unlike a narrow strip
    such as the Ventilator's Face61, which lets the points slide along it)."""
    face = rational_patch_face() if request.param == "rational patch" else shared_face("surf114.igs", 1)
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
    found = cmmsampling.inspect(planned, tmp_path / "measured.csv", tolerance=0.05, alignment="best_fit")
    aligned, deviations = point_to_plane_fit(planned.face, made.actual)
    assert np.abs(found.deviations - deviations).max() < 1e-3   # 1 um
    assert np.linalg.norm(found.points - aligned, axis=1).max() < 1e-3
    assert 0.005 < found.profile < 0.12 and found.profile == pytest.approx(2 * np.abs(deviations).max(), abs=2e-3)


def test_min_max_gives_a_profile_no_wider_than_the_best_fits(planned, tmp_path):
    cmmsampling.simulate_measurement(planned, tmp_path / "measured.dmi", form_error=0.03, noise=0.002,
                                     misplacement=MISPLACED, seed=2)
    best = cmmsampling.inspect(planned, tmp_path / "measured.dmi", alignment="best_fit")
    chebyshev = cmmsampling.inspect(planned, tmp_path / "measured.dmi")
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


@pytest.mark.parametrize("separator", [", ", ";", "  "])
def test_labelled_text_in_any_separator_pairs_by_label(planned, tmp_path, separator):
    made = cmmsampling.simulate_measurement(planned, tmp_path / "measured.dmi", misplacement={"z": 0.3})
    order = np.random.default_rng(1).permutation(len(made.labels))[:30]
    lines = ["# measured on the CMM, contact points, mm"] + [
        separator.join([made.labels[k]] + [f"{c:.7f}" for c in made.actual[k]]) for k in order]
    (tmp_path / "measured.txt").write_text("\n".join(lines) + "\n")
    found = cmmsampling.inspect(planned, tmp_path / "measured.txt", locked=("rx", "ry", "rz"))
    assert found.labels == [made.labels[k] for k in order]
    assert np.abs(found.deviations).max() < 1e-5 and found.notes == [
        "6 planned points were not measured: " + ", ".join(l for l in made.labels if l not in found.labels)]


def test_labelled_text_refuses_what_it_cannot_read(planned, tmp_path):
    def refused(text, message):
        (tmp_path / "bad.txt").write_text(text)
        with pytest.raises(InputError, match=message):
            cmmsampling.inspect(planned, tmp_path / "bad.txt")

    refused("P1;12,5;3,25;1,0\n", r"bad.txt, line 1: '12,5' has a decimal comma; write numbers with a decimal "
                                  r"point \(12.5\)")
    refused("P1 12,5 3,25 1,0\n", "line 1: '12,5' has a decimal comma")
    refused("# head\nP1, 1, 2, 3\nP2, 1, 2\n", "line 3: 3 fields where the first point has 4")
    refused("P1, 1, 2, 3\nP1, 1, 2, 4\n", "line 2: point P1 is given twice")
    refused("P1, 1, 2, nan\n", "line 1: z 'nan' is not a finite number")
    refused("# nothing\n\n", "no measured point found")
    refused("1, 2\n", "line 1: 2 fields; a measured point is one of x y z")
    (tmp_path / "centres.csv").write_text("P1, 1, 2, 3\n")
    with pytest.raises(InputError, match="ball centres .* carry no vectors"):
        cmmsampling.inspect(planned, tmp_path / "centres.csv", probe_radius=1.0)


def test_a_plan_is_inspected_with_one_alignment_for_the_part(tmp_path):
    block = Part.makeBox(40, 30, 10)
    made_plan = cmmsampling.plan(block, n_total=48, strategy="uniform_parametric", faces=[1, 3, 6], processes=1)
    made = cmmsampling.simulate_measurement(made_plan, tmp_path / "part.dmi", misplacement=MISPLACED)
    with pytest.raises(InputError, match="give part="):
        cmmsampling.inspect(made_plan, tmp_path / "part.dmi")
    found = cmmsampling.inspect(made_plan, tmp_path / "part.dmi", part=block, tolerance=0.01)
    assert sorted(set(found.faces)) == ["Face1", "Face3", "Face6"] and len(found.labels) == 48
    assert found.labels[0].startswith(found.faces[0] + "_P")
    assert np.linalg.norm(found.points - made.nominal, axis=1).max() < 1e-3 and found.passed
    faces = found.face_profiles
    assert list(faces) == ["Face1", "Face3", "Face6"] and max(faces.values()) == found.profile
    assert all(f"{name}: profile {value:.4f} mm, PASS" in found.summary() for name, value in faces.items())
    assert list(found.face_forms) == ["Face1", "Face3", "Face6"]
    assert all(found.face_forms[name] <= faces[name] + 1e-9 for name in faces), "alone, a face fits no worse"


def test_each_face_of_a_plan_has_a_form_profile_of_its_own(tmp_path):
    """A box's top 20 um too high against its bottom (a part made so): with the part's one alignment
    the top's profile shows the misplacement; aligned alone its form is its own 5 um
    waviness, as an independent minimum zone of the top's heights alone finds (a plane: the
    zone is max - min of z over a tilt, checked here without a tilt as an upper bound)."""
    block = Part.makeBox(40, 30, 10)
    made_plan = cmmsampling.plan(block, n_total=80, strategy="halton", faces=[1, 3, 5, 6], processes=1)
    point_set = cmmsampling.formats.exporting.as_point_set(made_plan)
    actual = point_set.points.copy()
    top = np.array([face == "Face6" for face in point_set.faces])
    wave = 0.0025 * np.sin(actual[:, 0] / 5.0)
    actual[top, 2] += 0.02 + wave[top]
    measured = cmmsampling.PointSet(point_set.labels, actual, point_set.normals)
    found = cmmsampling.inspect(made_plan, measured, part=block)
    assert found.face_profiles["Face6"] > 0.015
    assert found.face_forms["Face6"] <= np.ptp(wave[top]) + 1e-6
    assert found.face_forms["Face6"] == pytest.approx(np.ptp(wave[top]), rel=0.2)
    assert "Face6: profile" in found.summary() and "form" in found.summary()


def test_an_offset_zone_judges_from_its_own_centre(planned):
    """ISO 1101's UZ: a face measured all out of the material (0.01 .. 0.03 mm) fails a centred
    0.03 mm zone and passes the unilateral one outside (offset +t/2); bands follow the centre."""
    from cmmsampling.inspection.result import band_limits, tolerance_bands

    away = np.linspace(0.01, 0.03, planned.n)
    measured = cmmsampling.PointSet([f"P{i}" for i in range(1, planned.n + 1)],
                                    planned.points + away[:, None] * planned.normals, planned.normals)
    centred = cmmsampling.inspect(planned, measured, alignment="none", tolerance=0.03)
    outside = cmmsampling.inspect(planned, measured, alignment="none", tolerance=0.03, zone_offset=0.015)
    assert centred.profile == pytest.approx(0.06, abs=1e-6) and not centred.passed
    assert outside.profile == pytest.approx(0.03, abs=1e-6) and outside.passed and outside.within.all()
    assert "zone offset +0.015 mm" in outside.summary()
    assert tolerance_bands(np.array([-0.001, 0.002, 0.005, 0.0299, 0.031]), 0.03, 0.015).tolist() == [-2, -1, 0, 1, 2]
    assert band_limits(0.03, 0.015) == pytest.approx((0.0, 0.003, 0.027, 0.03))
    with pytest.raises(InputError, match="zone_offset must be a finite number"):
        cmmsampling.inspect(planned, measured, zone_offset=float("nan"))


def test_the_substitute_is_rebuilt_from_the_measured_points(planned, tmp_path):
    """The paper's step: the measured points' substitute and its deviation map from the nominal;
    without a form error it is the planned substitute, with one it departs by about that much."""
    cmmsampling.simulate_measurement(planned, tmp_path / "exact.dmi", misplacement=MISPLACED)
    exact = cmmsampling.inspect(planned, tmp_path / "exact.dmi")
    assert np.abs(exact.substitute_poles - planned.poles).max() < 1e-3
    assert exact.substitute_deviation.maximum == pytest.approx(planned.deviation.maximum, abs=1e-3)
    cmmsampling.simulate_measurement(planned, tmp_path / "formed.dmi", form_error=0.05, misplacement=MISPLACED)
    formed = cmmsampling.inspect(planned, tmp_path / "formed.dmi")
    assert 0.01 < np.abs(formed.substitute_poles - planned.poles).max() < 1.0
    change = np.nanmax(np.abs(formed.substitute_deviation.field - planned.deviation.field))
    assert 0.005 < change < 0.5
    assert formed.substitute.NbUPoles == planned.substitute.NbUPoles
    u, v = planned.uv[0]
    ours = formed.space.evaluate(formed.substitute_poles, planned.uv[:1])[0]
    assert formed.substitute.value(u, v).distanceToPoint(FreeCAD.Vector(*ours)) < 1e-9   # OCC's surface is ours


def test_the_demo_closes_the_loop_and_draws_the_measured_face(tmp_path, capsys):
    from cmmsampling.cli import _inspection_loop
    from cmmsampling.inspection.figure import write_inspection_figure

    face = cmmsampling.reference_face()
    result = cmmsampling.sample(face, 25, "halton", occ_check=False)
    _inspection_loop(face, result, str(tmp_path / "loop"))
    said = capsys.readouterr().out
    assert "Inspection of the Halton points measured on a virtual CMM" in said and "tolerance 0.1 mm: PASS" in said
    assert "(minimum zone, ISO 1101)" in said and "capped" not in said, "the minimum-zone verdict, a settled fit"
    assert "motions the points do not hold (kept where their labels put them): none" in said
    assert "ISO 14253-1: conforms (profile " in said and "probing u = 0.001 mm per point" in said
    block = said[said.index("The datum block's top (Face3) measured with its datums A = Face1"):]
    assert "aligned on datums A|B|C" in block and "(relative to datums A|B|C: location and form, ISO 1101)" in block
    assert re.search(r"ISO 14253-1: (conforms|does not conform|undecided) \(profile \d\.\d{4} mm, tolerance 0.05 mm, "
                     r"guard band U\): U = \d\.\d{4} mm \(k = 2", block), block
    assert cmmsampling.read_points(tmp_path / "loop" / "measured.dmi").metadata["dmis_features"] == "actual"
    assert (tmp_path / "loop" / "deviation.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    cmmsampling.simulate_measurement(result, tmp_path / "bad.dmi", form_error=0.05, seed=3)
    failed = cmmsampling.inspect(result, tmp_path / "bad.dmi", alignment="none", tolerance=0.04)
    assert not failed.passed and (~failed.within).any()
    assert write_inspection_figure(failed, face, str(tmp_path / "bad.png")) == str(tmp_path / "bad.png")


def test_an_unconstrained_motion_does_not_run_away():
    """Points on a tilted plane whose normals carry rounding noise: sliding along the plane costs
    nothing, and the fit must not slide the points far (it slid them 1e16 mm)."""
    from cmmsampling.inspection.align import align

    normal = np.array([1e-17, -0.5, np.sqrt(0.75)])
    rng = np.random.default_rng(0)
    grid = rng.uniform(-20, 20, (30, 2))
    along = np.array([[1.0, 0.0, 0.0], [0.0, np.sqrt(0.75), 0.5]])
    points = grid @ along + 0.3 * normal

    def closest(where):
        heights = where @ normal
        return where - heights[:, None] * normal, np.tile(normal, (len(where), 1))

    found = align(points, closest)
    assert np.abs(found.deviations).max() < 1e-9 and found.moved_mm < 1.0
