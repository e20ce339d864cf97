"""Export and reading back: DMIS, PC-DMIS XYZ and CSV files, frames, probe radius, probing order,
atomic writes, label rules, the DMIS grammar, and measured points against the CAD face."""
import dataclasses
import itertools
import os
import subprocess
import sys
import time

from support import dmis_syntax
import numpy as np
import pytest
from support.faces import FreeCAD, Part

import cmmsampling
from cmmsampling.formats.dmis import sanitise_labels
from cmmsampling.formats.exporting import export, reordered
from cmmsampling.formats.files import TEMPORARY, ExportError
from cmmsampling.formats.frames import placement_from_metadata
from cmmsampling.measurement import measured_deviation
from cmmsampling.formats.pointfiles import read_points
from cmmsampling.formats.pointset import PointSet
from cmmsampling.geometry.probe_path import path_length, short_path

EXTENSIONS = {"dmis": "dmi", "xyz": "xyz", "csv": "csv"}
PLACEMENT = FreeCAD.Placement(FreeCAD.Vector(12.5, -40.0, 7.25),
                              FreeCAD.Rotation(FreeCAD.Vector(1, 2, 3), 37.0))


@pytest.fixture(scope="module")
def results():
    """25 uniform parametric points on the reference surface and on a converted cylinder face."""
    return {
        "reference": cmmsampling.sample(cmmsampling.reference_face(), 25, "uniform_parametric"),
        "cylinder": cmmsampling.sample(Part.makeCylinder(10, 20).Faces[0], 25, "uniform_parametric"),
    }


@pytest.fixture(scope="module")
def point_sets(results):
    """The results as PointSets with labels that are not P1..PN."""
    return {
        name: dataclasses.replace(PointSet.from_result(result, f"{name}:Face1"),
                                  labels=[f"{name[:3].upper()}-{i:02d}.a_b" for i in range(result.n)])
        for name, result in results.items()
    }


def exported(source, tmp_path, fmt, **options):
    """Export source as fmt into tmp_path; the DMIS file must pass the grammar. Returns (path, report)."""
    path = tmp_path / f"points.{EXTENSIONS[fmt]}"
    report = export(source, path, **options)
    if fmt == "dmis":
        assert dmis_syntax.check(path.read_text()) == []
    return path, report


def in_global(points, normals, placement):
    """Local points and normals (N, 3) back to global through FreeCAD's own placement arithmetic."""
    return (np.array([tuple(placement.multVec(FreeCAD.Vector(*p))) for p in points]),
            np.array([tuple(placement.Rotation.multVec(FreeCAD.Vector(*n))) for n in normals]))


@pytest.mark.parametrize("fmt", sorted(EXTENSIONS))
@pytest.mark.parametrize("face", ["reference", "cylinder"])
def test_round_trip(point_sets, tmp_path, fmt, face):
    original = point_sets[face]
    path, report = exported(original, tmp_path, fmt)
    back = read_points(path)
    assert (report.count, report.format, report.path) == (25, fmt, str(path))
    expected_labels = [f"P{i + 1}" for i in range(25)] if fmt == "xyz" else original.labels
    assert back.labels == expected_labels
    assert np.abs(back.points - original.points).max() < 1e-7
    assert np.abs(back.normals - original.normals).max() < 1e-7
    if fmt == "csv":
        assert np.abs(back.uv - original.uv).max() < 1e-9
        assert np.abs(back.deviation - original.deviation).max() < 1e-7
    if fmt != "xyz":
        assert back.metadata["strategy"] == "uniform_parametric" and back.metadata["n"] == 25
        assert back.metadata["source"] == f"{face}:Face1"
        assert back.metadata["max_mm"] == original.metadata["max_mm"]
        assert back.metadata["fit_poles"] == original.metadata["fit_poles"]
        assert back.metadata["frame"] == "global"
        if fmt == "dmis":
            assert back.metadata["ball_radius_mm"] == 1.0 and "probe_radius_mm" not in back.metadata, \
                "contact points, the sensor's ball (cmmsampling.Probe()'s 2 mm) stated"
            assert "S(A0B0)=SNSDEF/PROBE,INDEX,POL,0.0000,0.0000,$" in path.read_text()
        else:
            assert back.metadata["probe_radius_mm"] == 0


def test_a_sampling_result_exports_with_its_own_labels(results, tmp_path):
    path, report = exported(results["reference"], tmp_path, "dmis")
    back = read_points(path)
    assert back.labels == results["reference"].labels and report.count == 25
    assert np.abs(back.points - results["reference"].points).max() < 1e-7


def test_dmis_program_layout(point_sets, tmp_path):
    path, _ = exported(point_sets["reference"], tmp_path, "dmis", approach=3, retract=1.5, search=7.25,
                       name="Lid 'A' inspection")
    lines = path.read_text().splitlines()
    assert lines[0] == "DMISMN/'Lid _A_ inspection',05.2" and lines[-1] == "ENDFIL"
    for statement in ("UNITS/MM,ANGDEC", "MODE/PROG,MAN", "SNSET/APPRCH,3.0000000", "SNSET/RETRCT,1.5000000",
                      "SNSET/SEARCH,7.2500000"):
        assert statement in lines
    label = point_sets["reference"].labels[3]
    first = lines.index(f"MEAS/POINT,F({label}),1")
    assert lines[first - 2].startswith(f"F({label})=FEAT/POINT,CART,") and lines[first + 3] == "ENDMES"
    assert sum(line.startswith("PTMEAS/CART,") for line in lines) == 25
    assert "$$ strategy: uniform_parametric" in lines and "$$ source: reference:Face1" in lines
    assert all(len(line) <= 80 for line in lines)


def test_dmis_without_comments_still_states_frame_and_radius(point_sets, tmp_path):
    path, _ = exported(point_sets["reference"], tmp_path, "dmis", comments=False, probe_radius=1.5)
    text = path.read_text()
    assert "strategy" not in text and "max_mm" not in text
    assert "$$ ball_radius_mm: 1.5" in text and "$$ frame: global" in text
    assert "probe_radius_mm" not in text, "a probe radius of 0 beside the ball's reads as a contradiction"


def test_long_labels_and_comments_wrap_within_80_characters(point_sets, tmp_path):
    original = point_sets["reference"]
    long = dataclasses.replace(
        original, labels=[f"{i:02d}" + "L" * 62 for i in range(25)],
        metadata={**original.metadata, "source": "Body:" + "Face" * 40, "note": "word " * 40 + "Zürich"},
    )
    path, _ = exported(long, tmp_path, "dmis")
    text = path.read_text(encoding="ascii")
    assert max(map(len, text.splitlines())) <= 80
    back = read_points(path)
    assert back.labels == long.labels
    assert back.metadata["source"] == long.metadata["source"]
    assert back.metadata["note"] == ("word " * 40).strip() + " Z\\xfcrich"


def test_xyz_header_columns(point_sets, tmp_path):
    path, _ = exported(point_sets["cylinder"], tmp_path, "xyz")
    lines = path.read_text().splitlines()
    assert lines[0][0:6] == "XYZIJK" and lines[0][10:16] == "METRIC" and lines[0][6:10] == "    "
    assert len(lines) == 26 and all(len(line.split(",")) == 6 for line in lines[1:])


def test_xyz_in_inch_is_read_in_mm(tmp_path):
    path = tmp_path / "inch.xyz"
    path.write_text("XYZIJK    INCH\n1.0,2.0,0.5,0.0,0.0,1.0\n")
    back = read_points(path)
    assert np.allclose(back.points, [[25.4, 50.8, 12.7]]) and back.metadata["xyz_units"] == "INCH"


def test_csv_header_and_unknown_uv(point_sets, tmp_path):
    bare = dataclasses.replace(point_sets["reference"], uv=None, deviation=None, metadata={})
    path, _ = exported(bare, tmp_path, "csv")
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    assert rows[0] == "label,x,y,z,i,j,k,u,v"
    assert rows[1].endswith(",,")
    back = read_points(path)
    assert back.uv is None and back.deviation is None
    with_deviation, _ = exported(point_sets["reference"], tmp_path, "csv")
    assert "label,x,y,z,i,j,k,u,v,deviation" in with_deviation.read_text().splitlines()


def test_csv_keeps_labels_dmis_cannot_take(point_sets, tmp_path):
    labels = [f"point {i}, #{i}" for i in range(25)]
    path, _ = exported(dataclasses.replace(point_sets["reference"], labels=labels), tmp_path, "csv")
    assert read_points(path).labels == labels


@pytest.mark.parametrize("fmt", sorted(EXTENSIONS))
def test_local_frame_round_trip(point_sets, tmp_path, fmt):
    original = point_sets["reference"]
    path, report = exported(original, tmp_path, fmt, frame=PLACEMENT)
    back = read_points(path)
    assert report.frame == "local"
    assert np.abs(back.points - original.points).max() > 1.0
    points, normals = in_global(back.points, back.normals, PLACEMENT)
    assert np.abs(points - original.points).max() < 1e-7
    assert np.abs(normals - original.normals).max() < 1e-7
    if fmt != "xyz":
        stated = placement_from_metadata(back.metadata)
        assert np.allclose(np.array(stated.toMatrix().A), np.array(PLACEMENT.toMatrix().A), atol=1e-12)


def test_frame_from_a_document_object(point_sets, tmp_path):
    doc = FreeCAD.newDocument("ExportFrame")
    try:
        datum = doc.addObject("Part::Feature", "Datum")
        datum.Label = "Fixture LCS"
        datum.Placement = PLACEMENT
        by_object, _ = exported(point_sets["reference"], tmp_path, "csv", frame=datum)
        back = read_points(by_object)
        assert back.metadata["frame_name"] == "Fixture LCS"
        points, _ = in_global(back.points, back.normals, PLACEMENT)
        assert np.abs(points - point_sets["reference"].points).max() < 1e-7
    finally:
        FreeCAD.closeDocument(doc.Name)


@pytest.mark.parametrize("fmt", sorted(set(EXTENSIONS) - {"dmis"}))
def test_probe_radius_moves_points_along_the_normals(point_sets, tmp_path, fmt):
    original = point_sets["cylinder"]
    path, report = exported(original, tmp_path, fmt, probe_radius=1.5)
    back = read_points(path)
    assert report.probe_radius == 1.5
    assert np.abs(back.points - (original.points + 1.5 * original.normals)).max() < 1e-7
    if fmt != "xyz":
        assert back.metadata["probe_radius_mm"] == 1.5 and "ball centres" in back.metadata["points"]


def test_dmis_nominals_stay_contact_points_and_state_the_ball_radius(point_sets, tmp_path):
    """DMIS FEAT/POINT and PTMEAS are surface points (the CMM takes its ball radius off itself):
    a probe radius is stated, never added; ball centres read from a CSV go back to contact points."""
    original = point_sets["cylinder"]
    path, report = exported(original, tmp_path, "dmis", probe_radius=1.5)
    back = read_points(path)
    assert report.probe_radius == 0.0 and report.ball_radius == 1.5
    assert "contact points, ball radius 1.5 mm stated" in str(report)
    assert np.abs(back.points - original.points).max() < 1e-7
    assert "probe_radius_mm" not in back.metadata and back.metadata["ball_radius_mm"] == 1.5
    assert back.metadata["points"].startswith("contact points on the face")
    centres, _ = exported(original, tmp_path, "csv", probe_radius=1.5)
    again, report = exported(read_points(centres), tmp_path, "dmis")
    assert report.ball_radius == 1.5 and np.abs(read_points(again).points - original.points).max() < 1e-7


def test_probe_radius_in_a_local_frame(point_sets, tmp_path):
    original = point_sets["reference"]
    path, _ = exported(original, tmp_path, "csv", frame=PLACEMENT, probe_radius=2.0)
    back = read_points(path)
    points, _ = in_global(back.points, back.normals, PLACEMENT)
    assert np.abs(points - (original.points + 2.0 * original.normals)).max() < 1e-7
    contact, _ = exported(original, tmp_path, "dmis", frame=PLACEMENT, probe_radius=2.0)
    points, _ = in_global(read_points(contact).points, back.normals, PLACEMENT)
    assert np.abs(points - original.points).max() < 1e-7


def test_compensating_or_moving_twice_is_refused(point_sets, tmp_path):
    path, _ = exported(point_sets["reference"], tmp_path, "csv", probe_radius=1.0, frame=PLACEMENT)
    back = read_points(path)
    with pytest.raises(ValueError, match="already probe-ball centres"):
        export(back, tmp_path / "again.csv", probe_radius=1.0)
    with pytest.raises(ValueError, match="already in a local frame"):
        export(back, tmp_path / "again.csv", frame=PLACEMENT)
    again = read_points(export(back, tmp_path / "again.csv").path)
    assert again.metadata["probe_radius_mm"] == 1.0 and again.metadata["frame"] == "local"
    assert np.abs(again.points - back.points).max() < 1e-7


def test_short_path_export(point_sets, tmp_path):
    original = point_sets["reference"]
    shuffled = reordered(original, np.random.default_rng(7).permutation(25))
    path, report = exported(shuffled, tmp_path, "dmis", order="short_path")
    assert report.length_before == pytest.approx(path_length(shuffled.points))
    assert report.length_after < 0.7 * report.length_before and report.saving > 0
    back = read_points(path)
    assert sorted(back.labels) == sorted(original.labels)
    positions = {label: p for label, p in zip(original.labels, original.points)}
    assert np.abs(back.points - np.array([positions[label] for label in back.labels])).max() < 1e-7
    assert path_length(back.points) == pytest.approx(report.length_after, abs=1e-5)
    _, kept = exported(shuffled, tmp_path, "csv")
    assert kept.length_before == kept.length_after == pytest.approx(path_length(shuffled.points))


def test_short_path_is_a_permutation_never_longer():
    rng = np.random.default_rng(3)
    for count in (1, 2, 3, 10, 57):
        points = rng.random((count, 3)) * 100
        result = short_path(points)
        assert sorted(result.order.tolist()) == list(range(count))
        assert result.length_after <= result.length_before + 1e-9
        assert result.length_after == pytest.approx(path_length(points, result.order))
    line = np.column_stack([np.arange(20.0), np.zeros(20), np.zeros(20)])
    assert short_path(line).length_after == pytest.approx(19.0)
    shuffled = line[rng.permutation(20)]
    assert path_length(shuffled) > 19.0 and short_path(shuffled).length_after == pytest.approx(19.0)


def test_two_opt_leaves_no_improving_reversal():
    points = np.random.default_rng(11).random((12, 3)) * [100, 80, 10]
    result = short_path(points)
    best = path_length(points, result.order)
    for i, j in itertools.combinations(range(12), 2):
        order = result.order.copy()
        order[i:j + 1] = order[i:j + 1][::-1]
        assert path_length(points, order) >= best - 1e-9


def test_short_path_of_a_thousand_points_is_quick():
    points = np.random.default_rng(5).random((1000, 3)) * [200, 200, 30]
    start = time.perf_counter()
    result = short_path(points)
    assert time.perf_counter() - start < 5.0
    assert result.length_after < 0.15 * result.length_before


def test_document_object_source(point_sets, tmp_path):
    class ProbePointsProxy:
        def __init__(self, point_set):
            self.points = point_set

        def point_set(self, obj):
            return dataclasses.replace(self.points, metadata={**self.points.metadata, "source": obj.Label})

    doc = FreeCAD.newDocument("ExportSource")
    try:
        obj = doc.addObject("App::FeaturePython", "ProbePoints")
        obj.Label = "Probe points of Face1"
        obj.Proxy = ProbePointsProxy(point_sets["cylinder"])
        path, report = exported(obj, tmp_path, "dmis")
        back = read_points(path)
        assert report.count == 25 and back.labels == point_sets["cylinder"].labels
        assert back.metadata["source"] == "Probe points of Face1"
        assert np.abs(back.points - point_sets["cylinder"].points).max() < 1e-7
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_bad_sources_and_options(point_sets, tmp_path):
    with pytest.raises(TypeError, match="PointSet, a SamplingResult"):
        export(np.zeros((3, 3)), tmp_path / "x.csv")
    with pytest.raises(ValueError, match="'dmis'.*'xyz'.*'csv'"):
        export(point_sets["reference"], tmp_path / "points.step")
    with pytest.raises(ValueError, match="order"):
        export(point_sets["reference"], tmp_path / "x.csv", order="shortest")
    with pytest.raises(ValueError, match="approach"):
        export(point_sets["reference"], tmp_path / "x.dmi", approach=0)
    with pytest.raises(TypeError, match="frame"):
        export(point_sets["reference"], tmp_path / "x.dmi", frame=(1, 2, 3))
    report = export(point_sets["reference"], tmp_path / "points.out", format="csv")
    assert report.format == "csv" and read_points(tmp_path / "points.out", format="csv").labels


def test_unwritable_paths_give_a_clear_error(point_sets, tmp_path):
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file")
    with pytest.raises(ExportError, match=f"could not write {blocker}/points.dmi: {blocker} is a file"):
        export(point_sets["reference"], blocker / "points.dmi")
    missing = tmp_path / "missing" / "points.csv"
    with pytest.raises(OSError, match=f"{tmp_path / 'missing'} does not exist"):
        export(point_sets["reference"], missing)
    assert sorted(os.listdir(tmp_path)) == ["not_a_folder"] and blocker.read_text() == "a file"


def test_failed_replace_leaves_the_old_file(point_sets, tmp_path, monkeypatch):
    path = tmp_path / "points.dmi"
    path.write_text("old program\n")

    def refuse(source, target):
        raise PermissionError(13, "Permission denied", target)

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(ExportError, match=f"could not write {path}: no permission"):
        export(point_sets["reference"], path)
    assert path.read_text() == "old program\n" and os.listdir(tmp_path) == ["points.dmi"]


def test_invalid_points_leave_the_old_file(point_sets, tmp_path):
    path = tmp_path / "points.xyz"
    path.write_text("old points\n")
    points = point_sets["reference"].points.copy()
    points[4, 1] = np.nan
    with pytest.raises(ValueError, match="points of point REF-04.a_b contain NaN"):
        export(dataclasses.replace(point_sets["reference"], points=points), path)
    normals = point_sets["reference"].normals * 2
    with pytest.raises(ValueError, match="unit vectors"):
        export(dataclasses.replace(point_sets["reference"], normals=normals), path)
    assert path.read_text() == "old points\n" and os.listdir(tmp_path) == ["points.xyz"]


@pytest.mark.parametrize("label, problem", [
    ("P 1", "cannot be used in DMIS"), ("P(1)", "cannot be used in DMIS"), ("", "cannot be used in DMIS"),
    ("A" * 65, "cannot be used in DMIS"), ("Ü1", "cannot be used in DMIS"), ("P2", "used by points 1 and 2"),
])
def test_labels_invalid_for_dmis(point_sets, tmp_path, label, problem):
    labels = [label] + [f"P{i}" for i in range(2, 26)]
    source = dataclasses.replace(point_sets["reference"], labels=labels)
    with pytest.raises(ValueError, match=problem):
        export(source, tmp_path / "points.dmi")
    assert not os.listdir(tmp_path)
    fixed = sanitise_labels(labels)
    assert len(set(fixed)) == 25 and fixed[2:] == labels[2:]
    report = export(dataclasses.replace(source, labels=fixed), tmp_path / "points.dmi")
    assert read_points(report.path).labels == fixed


def test_sanitise_labels():
    labels = ["a b", "a_b", "", "x" * 70, "x" * 70]
    assert sanitise_labels(labels) == ["a_b", "a_b_2", "P3", "x" * 64, "x" * 62 + "_2"]


GOOD = """DMISMN/'probe points',05.2
$$ a comment
UNITS/MM,ANGDEC
MODE/PROG,MAN
SNSET/APPRCH,2.0000000
F(P1)=FEAT/POINT,CART,1.0000000,2.0000000,3.0000000,$
0.000000000,0.000000000,1.000000000
MEAS/POINT,F(P1),1
PTMEAS/CART,1.0000000,2.0000000,3.0000000,$
0.000000000,0.000000000,1.000000000
ENDMES
ENDFIL
"""


def test_the_grammar_accepts_a_good_program():
    assert dmis_syntax.check(GOOD) == []


@pytest.mark.parametrize("broken, error", [
    (GOOD.replace("ENDMES\n", ""), "ENDFIL inside MEAS"),
    (GOOD.replace("PTMEAS/CART,1.0000000,", "PTMEAS/CART,1.0000000,9.0000000,"), "expected 6 numbers"),
    (GOOD.replace("F(P1)", "F(P 1)"), "label 'P 1'"),
    (GOOD.replace("$$ a comment", "$$ " + "c" * 78), "81 characters"),
    (GOOD.replace("CART,1.0000000,2.0000000,", "CART,2.0000000,", 1), "got 5"),
    (GOOD.replace("ENDFIL\n", ""), "last statement must be ENDFIL"),
    (GOOD.replace("MEAS/POINT,F(P1)", "MEAS/POINT,F(P7)"), "before its FEAT"),
    ("$$ first\n" + GOOD, "line 1 must be the DMISMN"),
    (GOOD.replace("3.0000000,$", "3e0,$", 1), "fixed-notation"),
    (GOOD.replace("1.000000000", "0.900000000", 1), "length 0.9"),
    (GOOD.replace("MEAS/POINT,F(P1),1", "MEAS/POINT,F(P1),2"), "announced 2 points, got 1"),
    (GOOD.replace("UNITS/MM,ANGDEC\n", ""), "FEAT before UNITS"),
])
def test_the_grammar_rejects_broken_programs(broken, error):
    errors = dmis_syntax.check(broken)
    assert any(error in e for e in errors), errors


def test_reading_dmis_actuals_and_bad_files(tmp_path):
    output = tmp_path / "measured.dmi"
    actual = "FA(P1) = FEAT/POINT,CART, 1.5, 2.0, 3.25, 0.0, 0.0, 1.0\n"
    output.write_text(GOOD.replace("ENDFIL", actual + "ENDFIL"))
    back = read_points(output)
    assert back.labels == ["P1"] and np.allclose(back.points, [[1.5, 2.0, 3.25]])
    assert back.metadata["dmis_features"] == "actual"
    polar = tmp_path / "polar.dmi"
    polar.write_text("F(P1)=FEAT/POINT,POL,1,2,3,0,0,1\n")
    with pytest.raises(ValueError, match="line 1: only Cartesian"):
        read_points(polar)
    short = tmp_path / "short.csv"
    short.write_text("label,x,y,i,j,k\nP1,1,2,0,0,1\n")
    with pytest.raises(ValueError, match="lacks the column.*z"):
        read_points(short)
    words = tmp_path / "words.xyz"
    words.write_text("XYZIJK    METRIC\n1,2,3,0,0,1\n1,2,x,0,0,1\n")
    with pytest.raises(ValueError, match="line 3: value 'x' is not a number"):
        read_points(words)


def displaced(point_set, offsets):
    """point_set with each point moved by offsets (N,) mm along its outward normal."""
    return dataclasses.replace(point_set, points=point_set.points + offsets[:, None] * point_set.normals)


def test_measured_deviation_is_signed_along_the_outward_normal(point_sets, tmp_path):
    original = point_sets["reference"]
    offsets = 0.05 * np.sin(np.arange(25.0))
    measured = measured_deviation(cmmsampling.reference_face(), displaced(original, offsets))
    assert np.abs(measured.distances - offsets).max() < 1e-6
    assert np.abs(measured.closest - original.points).max() < 1e-5
    assert measured.maximum == pytest.approx(np.abs(offsets).max(), abs=1e-6)
    assert measured.rms == pytest.approx(np.sqrt(np.mean(offsets ** 2)), abs=1e-6)
    assert measured.summary()["lowest_mm"] == pytest.approx(offsets.min(), abs=1e-6)


def test_measured_deviation_reads_frame_and_radius_from_the_file(point_sets, tmp_path):
    offsets = np.linspace(-0.1, 0.1, 25)
    measured_points = displaced(point_sets["cylinder"], offsets)
    path, _ = exported(measured_points, tmp_path, "csv", frame=PLACEMENT, probe_radius=1.0)
    measured = measured_deviation(Part.makeCylinder(10, 20).Faces[0], str(path))
    assert measured.probe_radius == 1.0
    assert np.abs(measured.distances - offsets).max() < 1e-6
    xyz, _ = exported(displaced(point_sets["cylinder"], offsets), tmp_path, "xyz", frame=PLACEMENT)
    unplaced = measured_deviation(Part.makeCylinder(10, 20).Faces[0], xyz)
    assert unplaced.maximum > 1.0
    placed = measured_deviation(Part.makeCylinder(10, 20).Faces[0], xyz, frame=PLACEMENT)
    assert np.abs(placed.distances - offsets).max() < 1e-6


def test_measured_deviation_on_a_reversed_solid_face():
    box = Part.makeBox(30, 20, 10)
    bottom = [f for f in box.Faces if f.Orientation == "Reversed" and abs(f.CenterOfMass.z) < 1e-9][0]
    points = np.array([[10.0, 5.0, -0.2], [20.0, 15.0, 0.3]])
    source = PointSet(["out", "in"], points, np.tile([0.0, 0.0, -1.0], (2, 1)))
    measured = measured_deviation(bottom, source)
    assert np.allclose(measured.distances, [0.2, -0.3], atol=1e-9)


def test_temporary_files_of_a_killed_export_are_removed_by_the_next_export(tmp_path, reference):
    target = tmp_path / "points.csv"
    killed = subprocess.run(
        [sys.executable, "-c", "import os, sys; sys.path[:0] = sys.argv[2:]; "
         "from cmmsampling.formats.files import _temporary_file; _temporary_file(sys.argv[1]); os._exit(9)",
         str(target), *sys.path], capture_output=True, text=True)
    assert killed.returncode == 9, killed.stderr
    [left] = [name for name in os.listdir(tmp_path) if name.endswith(".tmp")]
    assert TEMPORARY.match(left)
    ours = tmp_path / f".other.csv.{os.getpid()}.abcdefgh.tmp"
    ours.write_text("a write of this live process")
    cmmsampling.export(cmmsampling.sample(reference, 9, "uniform_parametric", occ_check=False), str(target))
    assert sorted(os.listdir(tmp_path)) == sorted([ours.name, "points.csv"])
