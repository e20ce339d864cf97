"""Run the GUI tests inside FreeCAD's GUI: ``freecad tests/gui/run_gui_tests.py``.

Started by scripts/run-gui-tests.sh (under xvfb-run); pytest arguments come in the environment
variable CMMSAMPLING_PYTEST_ARGS. FreeCAD exits with pytest's exit code.
"""
import os
import shlex
import sys

from PySide import QtCore

GUI_TESTS = os.path.join(os.environ["CMMSAMPLING_ROOT"], "tests", "gui")


def run():
    import pytest

    sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    os.chdir(os.environ.get("CMMSAMPLING_START_FOLDER", os.path.expanduser("~")))
    arguments = shlex.split(os.environ.get("CMMSAMPLING_PYTEST_ARGS", ""))
    code = pytest.main(["-q", "-p", "no:cacheprovider", GUI_TESTS] + arguments)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(int(code))


QtCore.QTimer.singleShot(0, run)
