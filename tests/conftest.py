"""Test set-up: the checkout on sys.path, FreeCAD importable, shared fixtures.

The tests sit in one folder per room of the package (package/: the public API, the command
line, the install, the house); shared helpers live in tests/support/, data in tests/data/.
"""
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TESTS = os.path.dirname(os.path.abspath(__file__))
for folder in (ROOT, TESTS):
    if folder not in sys.path:
        sys.path.insert(0, folder)


@pytest.fixture(scope="session")
def reference():
    import cmmsampling

    return cmmsampling.reference_face()
