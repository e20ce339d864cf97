"""A Python without the optional packages: tests/without_optional_packages.py hides lxml,
distributed and threadpoolctl before cmmsampling is imported (QIF and a Dask plan refused in one
line naming the package, DMIS and CSV written and read, points inspected); with them here, the
refusal stays silent."""
import os
import subprocess
import sys

from support.paths import ROOT, TESTS

from cmmsampling.runtime.packages import PACKAGES, available, require


def test_without_lxml_qif_is_refused_in_one_line_and_dmis_and_csv_work(tmp_path):
    env = {**os.environ, "PYTHONPATH": ROOT}
    run = subprocess.run([sys.executable, os.path.join(TESTS, "without_optional_packages.py")], cwd=str(tmp_path),
                         env=env, capture_output=True, text=True, timeout=300)
    output = run.stdout + run.stderr
    assert run.returncode == 0, output[-3000:]
    assert "without optional packages: passed" in output, output[-3000:]
    assert output.count("ok refused in one line: QIF 3.0 files need the Python package lxml") == 5, output
    assert "ok refused in one line: Plans on a Dask cluster (scheduler=) need the Python package distributed" in output


def test_a_package_that_is_here_is_not_refused():
    for module in PACKAGES:
        assert available(module), module
        require(module, "this test")
