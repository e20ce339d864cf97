"""The point files byte for byte: export() of a fixed point set against files in tests/data/golden that
were read by eye when they were made (DMIS, XYZIJK, CSV; global, and a turned local frame with a
probe radius along a short path: CSV ball centres, DMIS contact points with the radius stated). A change in any writer shows here as a diff of the file.

After a deliberate change of a format, write the files again with
``CMMSAMPLING_WRITE_GOLDEN=1 /usr/bin/python3 -m pytest tests/formats/test_golden_files.py``, read the
diff and commit it with the change.
"""
import os

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
FRAME = FreeCAD.Placement(FreeCAD.Vector(100.0, -20.0, 5.0), FreeCAD.Rotation(30.0, 10.0, 5.0))


def point_set():
    """Five points on a saddle-like patch with tilted normals, face parameters, deviations and
    the facts a run would state (a fixed set: no FreeCAD geometry, no optimiser)."""
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.5], [0.0, 1.0], [1.0, 1.0]])
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
    with open(golden, "rb") as stream:
        assert written.read_bytes() == stream.read(), f"{name} differs from tests/data/golden/{name}"
    if name.endswith(".dmi"):
        assert dmis_syntax.check(written.read_text()) == []


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
    """D(LOCAL)=TRANS then ROTAT about Z, Y, X by FreeCAD's yaw, pitch and roll: Rz Ry Rx is the
    frame's rotation, for the golden frame and for turns near the +-90 deg pitch."""
    from cmmsampling.formats.dmis import frame_statements
    from cmmsampling.formats.frames import frame_facts

    lines = frame_statements(frame_facts(FRAME, "Fixture A"))
    assert lines[1:] == ["D(Fixture_A)=TRANS/XORIG,100.0000000,YORIG,-20.0000000,ZORIG,5.0000000",
                         "D(Fixture_A)=ROTAT/ZAXIS,30.0000", "D(Fixture_A)=ROTAT/YAXIS,10.0000",
                         "D(Fixture_A)=ROTAT/XAXIS,5.0000"]
    assert frame_statements({"frame": "global"}) == []

    def turn(axis, degrees):
        c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
        i, j = [k for k in range(3) if k != axis]
        matrix = np.eye(3)
        matrix[[i, i, j, j], [i, j, i, j]] = c, -s, s, c
        return matrix if axis != 1 else matrix.T

    for yaw, pitch, roll in ((30, 10, 5), (-120, 89.9999, 40), (10, 90, 0), (0, -90, 0), (170, -45, -170)):
        placement = FreeCAD.Placement(FreeCAD.Vector(), FreeCAD.Rotation(yaw, pitch, roll))
        rotation = np.array(placement.toMatrix().A).reshape(4, 4)[:3, :3]
        a, b, c = placement.Rotation.getYawPitchRoll()   # what frame_statements writes, to 4 decimals
        assert np.allclose(turn(2, a) @ turn(1, b) @ turn(0, c), rotation, atol=1e-9)
        turns = {line.split("/")[1][0]: float(line.split(",")[1])
                 for line in frame_statements(frame_facts(placement)) if "ROTAT/" in line}
        assert all(abs(turns.get(axis, 0.0) - angle) <= 5e-5 for axis, angle in zip("ZYX", (a, b, c)))
