"""The README's example from a QIF MBD model's tolerances to its results runs as written (the
model's path put in) on each of NIST's four models: no tolerance or datum typed, a results
document the schemas accept with a measurement of every characteristic planned, and the
first-article page. The same chain with known errors: tests/inspection/test_mbd_inspect.py."""
import os
import re

import pytest

import cmmsampling
from cmmsampling.formats.qif.mbd_results import read_mbd_results
from cmmsampling.formats.qif.schema import schema_errors
from support.mbd import MODELS, shared_mbd
from support.paths import ROOT

pytestmark = pytest.mark.once


def readme_mbd_example():
    """The README's code block that starts with read_mbd."""
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as handle:
        blocks = re.findall(r"```python\n(.*?)```", handle.read(), re.S)
    found = [block for block in blocks if block.startswith("mbd = cmmsampling.read_mbd(")]
    assert len(found) == 1, "the README has one example from an MBD model"
    return found[0]


@pytest.mark.parametrize("model", MODELS)
def test_the_readme_example_runs_from_the_model_to_its_results(tmp_path, monkeypatch, model):
    path = shared_mbd(f"{model}.qif")
    code = readme_mbd_example().replace('"nist_ftc_06_asme1_ap242.qif"', repr(path))
    assert repr(path) in code and "tolerance=" not in code and "datums=" not in code
    monkeypatch.chdir(tmp_path)
    names = {"cmmsampling": cmmsampling}
    exec(compile(code, "README.md", "exec"), names)
    plan, found = names["plan"], names["found"]
    assert {c.id for c in plan.characteristics} == {c.id for c in plan.model.judged()}
    assert not schema_errors((tmp_path / "results.qif").read_bytes())
    back = read_mbd_results(str(tmp_path / "results.qif"))
    assert set(back) == {c.id for c in plan.characteristics}
    assert all(value == pytest.approx(result.value) for result in found.characteristics
               for value in [back[result.id][1]])
    assert (tmp_path / "first_article.html").stat().st_size > 0 and (tmp_path / "measured.csv").stat().st_size > 0
