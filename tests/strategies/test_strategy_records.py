"""The strategy records: a strategy added as one record reaches sample(), compare(), the report and
the command line; nothing outside the records names a strategy."""
import ast
import pathlib

import numpy as np
import pytest

import cmmsampling
from cmmsampling import cli
from cmmsampling.study.figures import label
from cmmsampling.study import compare
from support.toy_strategy import TOY

PACKAGE = pathlib.Path(cmmsampling.__file__).parent
# The modules that hold the records and the strategies' own code.
# The records and the shared defaults (the default strategy, the best one, the starts of a search).
RECORD_HOLDERS = {"strategies/settings.py", "strategies/blind.py", "strategies/optimal.py", "strategies/pso.py",
                  "strategies/part_error.py"}


@pytest.fixture
def toy():
    """The toy strategy registered for one test, removed after it."""
    cmmsampling.register_strategy(TOY)
    yield TOY
    cmmsampling.unregister_strategy(TOY.name)


def test_a_registered_strategy_runs_in_sample_and_compare(reference, toy):
    result = cmmsampling.sample(reference, 16, "mirrored_halton", grid=20, occ_check=False, flips=3)
    plain = cmmsampling.sample(reference, 16, "halton", grid=20, occ_check=False)
    assert np.allclose(result.uv[:, 1], plain.uv[:, 1]) and not np.allclose(result.uv, plain.uv)
    with pytest.raises(ValueError, match="flips must be a whole number"):
        cmmsampling.sample(reference, 16, "mirrored_halton", flips=-1)
    study = compare(reference, ns=(16,), strategies=("uniform_parametric", "mirrored_halton"), seeds=(0, 1),
                    options={"mirrored_halton": {"flips": 2}}, grid=20, workers=1)
    assert [(r.strategy, r.seed) for r in study.rows] == [
        ("uniform_parametric", 0), ("mirrored_halton", 0), ("mirrored_halton", 1)]
    assert study.settings["seeded"] == ["mirrored_halton"]
    assert study.settings["options"] == {"mirrored_halton": {"flips": 2}}
    assert label("mirrored_halton") == "mirrored Halton"


def test_a_registered_strategy_is_offered_by_the_command_line(toy, capsys):
    with pytest.raises(SystemExit):
        cli.build_parser().parse_args(["sample", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "mirrored_halton: Halton's points mirrored" in text
    assert "--flips FLIPS" in text and "how often the toy mirrors" in text
    args = cli.build_parser().parse_args(["sample", "x.step", "--face", "1", "--strategy", "mirrored_halton",
                                          "--flips", "4"])
    assert cli.strategy_options(args.strategy, args) == {"flips": 4}


def test_an_unregistered_strategy_is_gone_and_a_non_record_is_refused(reference):
    with pytest.raises(ValueError, match="unknown strategy .mirrored_halton."):
        cmmsampling.sample(reference, 16, "mirrored_halton")
    with pytest.raises(TypeError, match="Strategy record"):
        cmmsampling.register_strategy({"name": "dict"})


def _named_strategies(source):
    """The strategy names that a module's code (not its docstrings) spells as string constants."""
    tree = ast.parse(source)
    docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    return sorted({node.value for node in ast.walk(tree)
                   if isinstance(node, ast.Constant) and id(node) not in docstrings
                   and node.value in cmmsampling.STRATEGIES})


def test_no_module_outside_the_records_names_a_strategy():
    """compare(), the report, the command line and the panels read the records."""
    found = {str(path.relative_to(PACKAGE)): _named_strategies(path.read_text())
             for path in sorted(PACKAGE.rglob("*.py")) if path.relative_to(PACKAGE).as_posix() not in RECORD_HOLDERS}
    assert {module: names for module, names in found.items() if names} == {}


def test_the_check_finds_a_named_strategy():
    assert _named_strategies('"""Uses "pso"."""\nx = {"pso": 1}\n') == ["pso"]
    assert _named_strategies('"""Uses "pso"."""\n') == []
