"""The point files byte for byte: export() of a fixed point set against files in tests/data/golden that
were read by eye when they were made (DMIS, XYZIJK, CSV; global and a local frame with ball
centres along a short path). A change in any writer shows here as a diff of the file.

After a deliberate change of a format, write the files again with
``CMMSAMPLING_WRITE_GOLDEN=1 /usr/bin/python3 -m pytest tests/formats/test_golden_files.py``, read the
diff and commit it with the change.
"""
import os

import numpy as np
import pytest
from support.faces import FreeCAD
from support.paths import DATA

import cmmsampling
from cmmsampling.formats.pointset import PointSet

GOLDEN = os.path.join(DATA, "golden")
CASES = {
    "global.dmi": {},
    "global.xyz": {},
    "global.csv": {},
    "local_ball_centres_short_path.dmi": {"probe_radius": 1.5, "order": "short_path", "name": "FIXTURE A"},
    "local_ball_centres_short_path.csv": {"probe_radius": 1.5, "order": "short_path"},
}
FRAME = FreeCAD.Placement(FreeCAD.Vector(100.0, -20.0, 5.0), FreeCAD.Rotation())


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


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_golden_files_read_back(name):
    read = cmmsampling.read_points(os.path.join(GOLDEN, name))
    source = point_set()
    assert sorted(read.labels) == source.labels
    if name.startswith("global"):
        assert np.abs(read.points - source.points[[source.labels.index(x) for x in read.labels]]).max() < 1e-6
    else:
        assert read.metadata["frame"] == "local" and read.metadata["probe_radius_mm"] == 1.5
