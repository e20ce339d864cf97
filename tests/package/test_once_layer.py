"""The once layer (tests/support/once.py): what scripts/once-candidates.py takes, and that the
list keeps to its rule."""
import collections
import importlib.util
import os

from support.once import ONCE

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def picker():
    path = os.path.join(ROOT, "scripts", "once-candidates.py")
    spec = importlib.util.spec_from_file_location("once_candidates", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_slowest_test_whose_lines_others_run_is_taken_and_its_lines_stay_run():
    ran = {"tests/a.py::test_slow": {("f", 1), ("f", 2)}, "tests/a.py::test_twin": {("f", 1), ("f", 2)},
           "tests/a.py::test_fast": {("f", 1)}, "tests/a.py::test_alone": {("f", 3)},
           "tests/document/test_d.py::test_doc": {("f", 1)}, "tests/a.py::test_cancel_run": {("f", 4)}}
    seconds = collections.Counter({"tests/a.py::test_slow": 9.0, "tests/a.py::test_twin": 8.0,
                                   "tests/a.py::test_fast": 0.1, "tests/a.py::test_alone": 5.0,
                                   "tests/document/test_d.py::test_doc": 7.0, "tests/a.py::test_cancel_run": 6.0})
    taken = picker().candidates(ran, seconds, 0.5)
    assert taken == ["tests/a.py::test_slow"], "the twin is left to run its lines; the others run lines alone, " \
        "are below the threshold or are about what a version changes"


def test_the_once_list_keeps_out_what_a_version_changes():
    sensitive = picker().version_sensitive
    headless = [node for node in ONCE if not node.startswith("gui/")]
    assert headless and not [node for node in headless if sensitive(f"tests/{node}")]
    assert all(os.path.exists(os.path.join(ROOT, "tests", node.split("::")[0])) for node in ONCE)
