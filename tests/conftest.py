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

from support.once import ONCE  # noqa: E402  (tests/support, on the path from here on)


@pytest.fixture(scope="session")
def reference():
    import cmmsampling

    return cmmsampling.reference_face()


# The quick layer (``-m quick``, seconds in all): the numeric core's and the formats' modules, to run
# while editing. They stay in the unit layer too; scripts/test.sh --quick runs them alone.
QUICK = {"fitting/test_closest_points.py", "fitting/test_edge_nodes.py", "fitting/test_fitting.py",
         "fitting/test_lattice_fit.py", "fitting/test_neighbour_searches.py", "fitting/test_peaks.py",
         "formats/test_export.py", "formats/test_format_records.py", "formats/test_golden_files.py", "formats/test_qif.py",
         "geometry/test_bspline.py", "geometry/test_congruence.py", "geometry/test_freecad_env.py",
         "geometry/test_occ_distance.py",
         "geometry/test_surface.py", "strategies/test_memory.py", "strategies/test_pso.py",
         "strategies/test_strategy_records.py", "strategies/test_swarm_screen.py"}


def pytest_collection_modifyitems(config, items):
    """Mark the tests of the QUICK modules ``quick`` and those ONCE names ``once``; refuse a name
    in ONCE that no test of its module collected here has (a renamed test would run everywhere)."""
    seen, modules = set(), set()
    for item in items:
        module = os.path.relpath(str(item.fspath), TESTS).replace(os.sep, "/")
        node = f"{module}::{item.name}"
        modules.add(module)
        if module in QUICK:
            item.add_marker(pytest.mark.quick)
        if node in ONCE:
            item.add_marker(pytest.mark.once)
            seen.add(node)
    stale = sorted(node for node in ONCE - seen if node.split("::")[0] in modules)
    if stale and not config.getoption("keyword") and not config.getoption("deselect"):
        raise pytest.UsageError(f"tests/support/once.py names tests that are not there: {stale}")


# The second line of every DMIS program cmmsampling writes.
WRITTEN_BY_US = "$$ probe points written by cmmsampling"


@pytest.fixture(scope="session", autouse=True)
def every_program_the_tests_write_passes_the_dmis_grammar(tmp_path_factory):
    """After the session: every DMIS program cmmsampling wrote in the tests' temporary folders
    passes the DMIS grammar (tests/support/dmis_syntax); the session's last test errs where
    one does not, naming the file and its first complaints."""
    yield
    from support import dmis_syntax

    failing = {}
    for folder, _, names in os.walk(tmp_path_factory.getbasetemp()):
        for name in names:
            path = os.path.join(folder, name)
            if os.path.splitext(name)[1].lower() not in (".dmi", ".dmis") or not os.path.isfile(path):
                continue
            with open(path, encoding="ascii", errors="replace") as stream:
                text = stream.read()
            if text.split("\n")[1:2] == [WRITTEN_BY_US]:
                errors = dmis_syntax.check(text)
                if errors:
                    failing[path] = errors[:3]
    assert not failing, f"DMIS programs the tests wrote fail the grammar: {failing}"
