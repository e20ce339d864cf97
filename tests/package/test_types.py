"""The package's type hints hold: mypy (Debian's, scripts/install-deps.sh installs it on the host)
checks every module with the settings in mypy.ini. In the quality layer: once per CI, on the host."""
import os
import shutil
import subprocess

import pytest
from support.paths import ROOT

pytestmark = pytest.mark.quality


def test_mypy_finds_no_type_errors_in_the_package(tmp_path):
    mypy = shutil.which("mypy")
    assert mypy, "mypy is missing: run scripts/install-deps.sh (Debian's mypy package)"
    checked = subprocess.run([mypy, "--config-file", os.path.join(ROOT, "mypy.ini"), "--cache-dir", str(tmp_path)],
                             cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert checked.returncode == 0, checked.stdout[-4000:] + checked.stderr[-2000:]
    assert "Success: no issues found" in checked.stdout


def test_mypy_sees_a_type_error(tmp_path):
    wrong = tmp_path / "wrong.py"
    wrong.write_text("from cmmsampling.formats.registry import register_format\n\nregister_format('dmis')\n")
    mypy = shutil.which("mypy")
    assert mypy, "mypy is missing: run scripts/install-deps.sh (Debian's mypy package)"
    checked = subprocess.run([mypy, "--config-file", os.path.join(ROOT, "mypy.ini"), "--cache-dir",
                              str(tmp_path / "cache"), str(wrong)], cwd=ROOT, capture_output=True, text=True,
                             timeout=600)
    assert checked.returncode == 1 and 'incompatible type "str"; expected "FileFormat"' in checked.stdout
