"""The point files line for line: export() of a fixed point set against files in tests/data/golden that
were read by eye when they were made (DMIS, XYZIJK, CSV; global, and a turned local frame with a
probe radius along a short path: CSV ball centres, DMIS contact points with the radius stated). A
change in any writer shows here as a differing line. The words, labels and statements must be the
same character for character; the numbers in them equal to 1e-9 (relative, 1e-9 mm near zero), so
that the last digits another processor's rounding gives do not count. The fixed points are placed
so that no two of their distances tie: the short path's order is unique by construction.

After a deliberate change of a format, write the files again with
``CMMSAMPLING_WRITE_GOLDEN=1 /usr/bin/python3 -m pytest tests/formats/test_golden_files.py``, read the
diff and commit it with the change.
"""
import os
import re

import numpy as np
import pytest
from support.faces import FreeCAD
from support.paths import DATA

from support import dmis_syntax

import cmmsampling
from cmmsampling.formats.pointset import PointSet

GOLDEN = os.path.join(DATA, "golden")
CASES = {
    "global.dmi": {},
    "global.xyz": {},
    "global.csv": {},
    "local_probe_radius_short_path.dmi": {"probe_radius": 1.5, "order": "short_path", "name": "FIXTURE A"},
    "local_probe_radius_short_path.csv": {"probe_radius": 1.5, "order": "short_path"},
}
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
FRAME = FreeCAD.Placement(FreeCAD.Vector(100.0, -20.0, 5.0), FreeCAD.Rotation(30.0, 10.0, 5.0))


def point_set():
    """Five points on a saddle-like patch with tilted normals, face parameters, deviations and
    the facts a run would state (a fixed set: no FreeCAD geometry, no optimiser)."""
    uv = np.array([[0.0, 0.0], [1.0, 0.15], [0.35, 0.55], [0.05, 1.0], [0.9, 0.85]])
    points = np.column_stack([40.0 * uv, 2.5 * (uv[:, 0] - 0.5) * (uv[:, 1] - 0.5)])
    normals = np.column_stack([-0.1 * (uv[:, 1] - 0.5), -0.1 * (uv[:, 0] - 0.5), np.ones(5)])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    metadata = {"source": "Body:Face1", "strategy": "optimal", "n": 5, "edge_offset": 0.0,
                "max_mm": 0.0123, "mean_mm": 0.0045, "note": "a long comment " + "that wraps " * 8}
    return PointSet(["P1", "P2", "P3", "P4", "P5"], points, normals, uv,
                    np.array([0.001, 0.0123, 0.0, 0.004, 0.0051]), metadata)


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_written_file_is_the_golden_one(name, tmp_path):
    options = dict(CASES[name])
    if name.startswith("local"):
        options["frame"] = FRAME
    written = tmp_path / name
    cmmsampling.export(point_set(), str(written), **options)
    golden = os.path.join(GOLDEN, name)
    if os.environ.get("CMMSAMPLING_WRITE_GOLDEN"):
        with open(golden, "wb") as stream:
            stream.write(written.read_bytes())
    with open(golden, encoding="utf-8") as stream:
        expected = stream.read().splitlines()
    lines = written.read_text(encoding="utf-8").splitlines()
    assert len(lines) == len(expected), f"{name}: {len(lines)} lines, tests/data/golden/{name} has {len(expected)}"
    for number, (line, wanted) in enumerate(zip(lines, expected), 1):
        assert _same_line(line, wanted), f"{name} line {number}: {line!r}, golden {wanted!r}"
    if name.endswith(".dmi"):
        assert dmis_syntax.check(written.read_text()) == []


def _same_line(line, wanted):
    """The same text between the numbers, character for character, and the same numbers to 1e-9."""
    if NUMBER.split(line) != NUMBER.split(wanted):
        return False
    found = np.array([float(x) for x in NUMBER.findall(line)])
    expected = np.array([float(x) for x in NUMBER.findall(wanted)])
    return found.shape == expected.shape and bool(np.all(np.abs(found - expected) <= 1e-9 * np.maximum(1.0, np.abs(expected))))


def test_the_fixed_points_have_no_tied_distances():
    """Which point the short path visits next is decided by distances at least 0.1 mm apart, not by
    rounding (the five points of a square and its centre tied, and the order differed between an
    Intel and an AMD processor)."""
    points = point_set().points
    distances = np.linalg.norm(points[:, None] - points[None], axis=2)[np.triu_indices(len(points), 1)]
    assert np.diff(np.sort(distances)).min() > 0.1


def test_a_last_digit_does_not_count_but_a_word_or_a_number_does():
    assert _same_line("P3,-47.9255589,1.0000000000e+02", "P3,-47.9255589,1.0000000000000001e+02")
    assert not _same_line("P3,-47.9255589", "P4,-47.9255589")
    assert not _same_line("P3,-47.9255589", "P3,-47.9255599")
    assert not _same_line("FEAT/POINT,CART", "FEAT/PLANE,CART")
    assert not _same_line("1,2", "1,2,3")


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_golden_files_read_back(name):
    read = cmmsampling.read_points(os.path.join(GOLDEN, name))
    source = point_set()
    assert sorted(read.labels) == source.labels
    if name.startswith("global"):
        assert np.abs(read.points - source.points[[source.labels.index(x) for x in read.labels]]).max() < 1e-6
    else:
        assert read.metadata["frame"] == "local"
        stated = "ball_radius_mm" if name.endswith(".dmi") else "probe_radius_mm"
        assert read.metadata[stated] == 1.5
        offset = 0.0 if name.endswith(".dmi") else 1.5
        rows = [source.labels.index(x) for x in read.labels]
        expected = FRAME.inverse()
        points = np.array([tuple(expected.multVec(FreeCAD.Vector(*p))) for p in
                           source.points[rows] + offset * source.normals[rows]])
        assert np.abs(read.points - points).max() < 1e-6


def test_the_dmis_frame_statements_turn_the_cad_frame_into_the_local_one():
    """D(LOCAL)=TRANS then ROTAT about Z, Y, X (FreeCAD's yaw, pitch and roll where the pitch is
    not +-90 deg): Rz Ry Rx of the turns written is the frame's rotation, for the golden frame and
    for turns at and near the +-90 deg pitch."""
    from cmmsampling.formats.dmis import frame_statements
    from cmmsampling.formats.frames import frame_facts

    lines = frame_statements(frame_facts(FRAME, "Fixture A"))
    assert lines[1:] == ["D(Fixture_A)=TRANS/XORIG,100.0000000,YORIG,-20.0000000,ZORIG,5.0000000",
                         "D(Fixture_A)=ROTAT/ZAXIS,30.0000", "D(Fixture_A)=ROTAT/YAXIS,10.0000",
                         "D(Fixture_A)=ROTAT/XAXIS,5.0000"]
    assert frame_statements({"frame": "global"}) == []

    from support.dmis_cmm import rotation as turn

    for yaw, pitch, roll in ((30, 10, 5), (-120, 89.9999, 40), (10, 90, 0), (0, -90, 0), (170, -45, -170)):
        placement = FreeCAD.Placement(FreeCAD.Vector(), FreeCAD.Rotation(yaw, pitch, roll))
        rotation = np.array(placement.toMatrix().A).reshape(4, 4)[:3, :3]
        turns = {line.split("/")[1][0]: float(line.split(",")[1])
                 for line in frame_statements(frame_facts(placement)) if "ROTAT/" in line}
        a, b, c = (turns.get(axis, 0.0) for axis in "ZYX")   # written to 4 decimals: 1e-6 rad
        assert np.allclose(turn(2, a) @ turn(1, b) @ turn(0, c), rotation, atol=5e-6)
        if abs(pitch) < 89:
            assert np.allclose((a, b, c), placement.Rotation.getYawPitchRoll(), atol=5e-5)
