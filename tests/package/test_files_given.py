"""Files and values given where a measured or CAD file is read, each refused in one line that names
it before any work (a folder, a loop of symbolic links, a file this user may not read, a list or
bytes for a path, a coordinate of 1e308), and texts in the comparison report that the project did
not write itself escaped. Each check fails on the behaviour seen before: "no such file" for a
folder or a loop, a raw PermissionError, "cannot export a list", OCC's RuntimeError, a <script>
element in the report."""
import os
import shutil
import subprocess
import tempfile

import numpy as np
import pytest
from support.paths import ROOT
from support.toy_strategy import TOY

import cmmsampling
from cmmsampling import InputError
from cmmsampling.formats.pointset import PointSet

PYTHON = "/usr/bin/python3"


@pytest.fixture(scope="module")
def planned(reference):
    """16 Halton points on the reference face and their program, as measured (the nominals)."""
    return cmmsampling.sample(reference, 16, "halton", occ_check=False)


def test_a_folder_given_as_the_measured_file_is_named_a_folder(planned, tmp_path):
    with pytest.raises(InputError, match="is a folder, not a measured-points file; give the file's path"):
        cmmsampling.inspect(planned, str(tmp_path))


def test_a_loop_of_symbolic_links_is_named_a_loop(planned, tmp_path):
    loop = tmp_path / "part.step"
    os.symlink(loop, tmp_path / "other.step")
    os.symlink(tmp_path / "other.step", loop)
    with pytest.raises(InputError, match="symbolic links lead round in a loop"):
        cmmsampling.inspect(planned, str(loop))
    done = subprocess.run([PYTHON, "-m", "cmmsampling", "faces", str(loop)], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1] == (f"error: {loop}: its symbolic links lead round in a loop; "
                                                    "give the CAD file's real path")


def test_a_link_to_nothing_is_named_so(tmp_path):
    dangling = tmp_path / "points.csv"
    os.symlink(tmp_path / "moved.csv", dangling)
    with pytest.raises(InputError, match=r"a symbolic link to nothing \(.*moved.csv\)"):
        cmmsampling.read_points(str(dangling))


@pytest.mark.skipif(os.geteuid() != 0 or not shutil.which("setpriv"),
                    reason="reading as another user needs root and setpriv")
def test_a_file_this_user_may_not_read_is_refused_in_one_line(planned):
    """Read as the user nobody (root may read any file): a point file with no read permission."""
    folder = tempfile.mkdtemp(dir="/tmp")
    try:
        os.chmod(folder, 0o755)
        path = os.path.join(folder, "measured.csv")
        cmmsampling.export(planned, path)
        os.chmod(path, 0o200)
        home = os.path.join(folder, "home")   # FreeCAD, imported by the package, writes its settings there
        os.mkdir(home)
        os.chmod(home, 0o777)
        script = (f"import sys; sys.path.insert(0, {ROOT!r}); import cmmsampling\n"
                  f"try:\n    cmmsampling.read_points({path!r})\n"
                  "except cmmsampling.InputError as refusal:\n    print(refusal)\n")
        done = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", PYTHON, "-c", script],
                              capture_output=True, text=True, timeout=120, cwd="/tmp",
                              env={"HOME": home, "PATH": os.environ.get("PATH", "/usr/bin:/bin")})
        assert done.stdout.strip() == (f"{path}: no permission to read it; give a point file you may read "
                                       "(or change its permissions)"), done.stderr[-2000:]
    finally:
        shutil.rmtree(folder)


@pytest.mark.parametrize("given", [["measured.csv"], np.zeros((16, 3)), b"measured.csv"],
                         ids=["list", "array", "bytes"])
def test_a_path_of_another_type_is_named_by_its_type(planned, given):
    with pytest.raises(InputError, match=f"got {type(given).__name__}$"):
        cmmsampling.inspect(planned, given)


def test_a_coordinate_of_1e308_is_refused_before_the_alignment(planned):
    points = planned.points.copy()
    points[1, 0] = 1e308
    measured = PointSet(planned.labels, points, planned.normals, planned.uv, np.zeros(len(points)), {})
    with pytest.raises(InputError, match=r"point P2 lies 1e\+308 mm from the origin; check the file's numbers"):
        cmmsampling.inspect(planned, measured)


def test_the_report_escapes_a_registered_strategys_label(reference, tmp_path, monkeypatch):
    """A strategy's label comes from whoever registered it: every place the report names it
    (settings, tables, the baseline sentence) shows it as text, never as markup."""
    from dataclasses import replace

    hostile = replace(TOY, label="<script>alert(1)</script>")
    monkeypatch.setitem(cmmsampling.STRATEGIES, TOY.name, hostile)
    study = cmmsampling.compare(reference, ns=[16], strategies=[TOY.name, "uniform_parametric"],
                                grid=20, seeds=[0])
    path = cmmsampling.write_report(study, str(tmp_path))
    with open(path, encoding="utf-8") as report:
        text = report.read()
    assert "<script>" not in text
    assert text.count("&lt;script&gt;alert(1)&lt;/script&gt;") >= 2
