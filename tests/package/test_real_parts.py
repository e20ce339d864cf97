"""Real geometry: trimmed, rational, analytic and lofted faces through STEP, and probe constraints."""
import os
import re

import numpy as np
import pytest
from support.faces import TESTDATA, FreeCAD, Part, rational_patch_face

import cmmsampling
from cmmsampling.cli import main as cli_main
from cmmsampling.strategies.sampling import make_problem

EDGE_OFFSET = 2.0
SPACING = 3.0
FAST = {"pso": {"iterations": 15, "population": 8}, "optimal": {"max_evaluations": 60}}


def _holed_face():
    """The reference face with a 15 mm hole through its middle."""
    cut = cmmsampling.reference_face().cut(Part.makeCylinder(15, 100, FreeCAD.Vector(50, 50, -50)))
    return cut.Faces[0]


def _lofted_face():
    """A free-form face lofted through three B-spline curves."""
    curves = []
    for y, amplitude in ((0, 3), (25, -4), (50, 2)):
        curve = Part.BSplineCurve()
        curve.interpolate([FreeCAD.Vector(x, y, amplitude * np.sin(x / 9)) for x in np.linspace(0, 60, 7)])
        curves.append(curve.toShape())
    return Part.makeLoft(curves, False, False).Faces[0]


@pytest.fixture(scope="module")
def step_faces(tmp_path_factory):
    """Test parts written to one STEP file and read back: {name: face}."""
    faces = {
        "holed_bspline": _holed_face(),
        "rational_patch": rational_patch_face(),
        "cylinder": Part.makeCylinder(20, 40).Faces[0],
        "torus": Part.makeTorus(30, 8).Faces[0],
        "lofted": _lofted_face(),
    }
    path = str(tmp_path_factory.mktemp("parts") / "parts.step")
    Part.Compound(list(faces.values())).exportStep(path)
    read = Part.read(path).Faces
    assert len(read) == len(faces)
    return dict(zip(faces, read))


def _check_points(face, result, edge_offset, spacing):
    """All points on the face, inside it, edge_offset from its edges and spacing apart (OCC)."""
    assert result.points.shape == (result.n, 3)
    vertices = [Part.Vertex(*p) for p in result.points]
    assert max(face.distToShape(v)[0] for v in vertices) < 1e-6
    assert all(result.model.face.isPartOfDomain(u, v) for u, v in result.uv)
    boundary = Part.Compound(face.Edges)
    assert min(boundary.distToShape(v)[0] for v in vertices) >= edge_offset
    gaps = np.linalg.norm(result.points[:, None] - result.points[None], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    assert gaps.min() >= spacing - 1e-9


@pytest.mark.parametrize("strategy", sorted(cmmsampling.self_contained()))
@pytest.mark.parametrize("name", ["holed_bspline", "rational_patch", "cylinder", "torus", "lofted"])
def test_every_strategy_keeps_points_on_the_face_and_off_its_edges(step_faces, name, strategy):
    face = step_faces[name]
    run = lambda: cmmsampling.sample(face, 20, strategy, grid=24, edge_offset=EDGE_OFFSET,  # noqa: E731
                                     min_spacing=SPACING, occ_check=False, **FAST.get(strategy, {}))
    try:
        result = run()
    except ValueError as refusal:
        # a closed torus hides half of itself from every machine axis: its footprint grid may
        # miss a part, and then uniform Cartesian must say so
        assert strategy == "uniform_cartesian" and name == "torus"
        assert "leaves part of the face without points" in str(refusal)
        return
    _check_points(face, result, EDGE_OFFSET, SPACING)


def test_deviation_is_measured_only_on_the_face(step_faces):
    """Nodes whose foot on the surface falls in the hole do not count; the others are on the face."""
    face = step_faces["holed_bspline"]
    result = cmmsampling.sample(face, 36, "uniform_parametric", grid=40)
    feet = result.problem.objective.nodes
    in_hole = np.linalg.norm(feet.uv - 0.5, axis=-1) < 0.1
    assert in_hole.any() and not feet.counted[in_hole].any() and feet.counted.mean() > 0.8
    assert np.isnan(result.deviation.field[in_hole]).all()
    sample = feet.points[feet.counted][::37]
    assert max(face.distToShape(Part.Vertex(*map(float, p)))[0] for p in sample) < 1e-6


def test_pso_still_beats_uniform_on_the_trimmed_face(step_faces):
    face = step_faces["holed_bspline"]
    uniform = cmmsampling.sample(face, 49, "uniform_parametric", grid=40, occ_check=False)
    pso = cmmsampling.sample(face, 49, "pso", grid=40, iterations=300, occ_check=False)
    assert pso.deviation.maximum < uniform.deviation.maximum
    _check_points(face, pso, 0.0, 0.0)


def test_uniform_strategies_give_exactly_n_points_on_a_trimmed_face(step_faces):
    for strategy in ("uniform_parametric", "uniform_cartesian"):
        result = cmmsampling.sample(step_faces["holed_bspline"], 30, strategy, grid=24, occ_check=False)
        assert result.n == 30
        assert not np.any(np.linalg.norm(result.uv - 0.5, axis=1) < 0.14)


@pytest.mark.parametrize("kwargs, message", [
    ({"n": 20, "edge_offset": 60.0}, "too narrow for edge_offset 60 mm.*edge_offset 50 mm fits"),
    ({"n": 400, "min_spacing": 10.0}, "400 points 10 mm apart do not fit.*lower n or min_spacing"),
    ({"n": 20, "edge_offset": -1.0}, "edge_offset must be at least 0"),
])
def test_a_face_that_cannot_hold_the_points_says_which_limit_to_change(reference, kwargs, message):
    with pytest.raises(ValueError, match=message):
        cmmsampling.sample(reference, strategy="uniform_parametric", **kwargs)


def test_command_line_lists_samples_and_writes(tmp_path, capsys, step_faces):
    path = str(tmp_path / "part.step")
    Part.Compound([step_faces["lofted"], step_faces["holed_bspline"]]).exportStep(path)
    assert cli_main(["faces", path]) == 0
    listing = capsys.readouterr().out
    assert "Face1" in listing and "Face2" in listing and "yes" in listing
    out = [str(tmp_path / "p.dmi"), str(tmp_path / "p.csv")]
    code = cli_main(["sample", path, "--face", "2", "-n", "16", "--strategy", "uniform_parametric",
                     "--out", out[0], "--out", out[1]])
    assert code == 0
    points = cmmsampling.read_points(out[1])
    assert len(points) == 16
    assert cli_main(["sample", path, "--face", "5", "-n", "16"]) == 2
    assert "--face must be between 1 and 2" in capsys.readouterr().err
    assert cli_main(["faces", str(tmp_path / "missing.step")]) == 2


SHARED = [("surf114.igs", 1), ("sunglasses_lens.igs", 5), ("Ventilator.stp", 10), ("hammer.iges", 1)]


@pytest.mark.skipif(not os.path.isdir(TESTDATA), reason="shared test data folder absent")
@pytest.mark.parametrize("filename, number", SHARED)
def test_faces_from_shared_cad_files(filename, number):
    face = Part.read(os.path.join(TESTDATA, filename)).Faces[number - 1]
    offset = 0.01 * face.BoundBox.DiagonalLength
    for strategy in ("uniform_parametric", "halton", "pso"):
        result = cmmsampling.sample(face, 16, strategy, grid=24, edge_offset=offset, occ_check=False,
                                    **FAST.get(strategy, {}))
        _check_points(face, result, offset, 0.0)
        assert np.isfinite(result.deviation.maximum)


def test_a_thin_strip_that_holds_points_at_the_offset_is_not_refused():
    """A 2.6 mm wide band of a cylinder: its middle line is 1.3 mm from both edges, so any offset up
    to 1.3 mm less the stated margin must be granted."""
    band = Part.makeCylinder(20, 2.6).Faces[0]
    margin = make_problem(band, 9, edge_offset=1.0).domain.margin
    assert margin < 0.15
    result = cmmsampling.sample(band, 9, "halton", edge_offset=1.3 - margin, occ_check=False)
    edges = Part.Compound(band.Edges)
    clearance = [edges.distToShape(Part.Vertex(*p))[0] for p in result.points]
    assert min(clearance) >= 1.3 - margin
    with pytest.raises(ValueError, match="too narrow for edge_offset 1.35 mm") as refusal:
        cmmsampling.sample(band, 9, "halton", edge_offset=1.35, occ_check=False)
    farthest, fits = map(float, re.search(r"farther than ([\d.]+) mm.*edge_offset ([\d.]+) mm fits",
                                          str(refusal.value)).groups())
    assert fits <= 1.3 <= farthest


def test_a_refusal_over_the_spacing_says_whether_the_caller_chose_it(reference):
    by_default = make_problem(reference, 16, min_spacing=None)
    assert by_default.spacing_advice().startswith(
        f"the default spacing of {by_default.min_spacing:.3g} mm applies; lower n or pass a smaller min_spacing")
    assert make_problem(reference, 16, min_spacing=1.0).spacing_advice() == "lower n or min_spacing"
