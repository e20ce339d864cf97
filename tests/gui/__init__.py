"""Tests that run inside the FreeCAD GUI (see scripts/run-gui-tests.sh)."""
