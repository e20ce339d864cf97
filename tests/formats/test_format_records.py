"""A point-file format is one module with one record (tests/toy_format.py): registered, it is
written and read by export() and read_points(), offered by the command line's --out and --help,
by File > Export's filter and its hook; unregistered, it is gone."""
import ast
import pathlib
from dataclasses import replace

import numpy as np
import pytest
from support.toy_format import TOY_FORMAT

import cmmsampling
from cmmsampling import cli, document
from cmmsampling.cmm.client import link_settings
from cmmsampling.formats.pointfiles import FORMATS, export_filter, resolve_format
from cmmsampling.inspection.measured import read_measured
from cmmsampling.runtime.packages import MissingPackage

PACKAGE = pathlib.Path(cmmsampling.__file__).parent
# The formats' own modules: the records and the code that reads and writes their files.
FORMAT_HOLDERS = ("formats/dmis.py", "formats/csv_points.py", "formats/xyzijk.py", "formats/qif/")
# Format names that are also plain words of the code ("xyz": the axes), left out of the check.
WORDS = {"xyz"}


@pytest.fixture
def toy():
    """The toy format registered for one test, removed after it."""
    cmmsampling.register_format(TOY_FORMAT)
    yield TOY_FORMAT
    cmmsampling.unregister_format(TOY_FORMAT.name)


@pytest.fixture(scope="module")
def result(reference):
    return cmmsampling.sample(reference, 9, "halton", grid=16, occ_check=False)


def test_a_registered_format_is_written_and_read_back(result, toy, tmp_path):
    report = cmmsampling.export(result, tmp_path / "face.toy", order="as_optimised")
    assert report.format == "toy" and "(toy points, global frame" in str(report)
    assert (tmp_path / "face.toy").read_text().startswith("TOY 9\n")
    back = cmmsampling.read_points(tmp_path / "face.toy")
    assert list(back.labels) == [f"P{k}" for k in range(1, 10)]
    assert np.abs(back.points - result.points).max() < 1e-6
    assert back.metadata["format"] == "toy"


def test_a_registered_format_is_offered_by_the_command_line(toy, tmp_path, capsys):
    with pytest.raises(SystemExit):
        cli.build_parser().parse_args(["sample", "--help"])
    assert "toy points (.toy)" in " ".join(capsys.readouterr().out.split())
    part = str(tmp_path / "part.step")
    cmmsampling.reference_face().exportStep(part)
    out = tmp_path / "face.toy"
    assert cli.main(["sample", part, "--face", "1", "-n", "9", "--strategy", "halton",
                     "--out", str(out)]) == 0
    assert len(cmmsampling.read_points(out).points) == 9


def test_a_registered_format_is_in_file_export(result, toy, tmp_path):
    import FreeCAD

    assert "*.toy" in export_filter() and export_filter().startswith("CMM probe points: DMIS, ")
    doc = FreeCAD.newDocument("FormatRecords")
    try:
        group = cmmsampling.add_to_document(result, doc)
        document.export([group], str(tmp_path / "hook.toy"))
        assert (tmp_path / "hook.toy").read_text().startswith("TOY 9\n")
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_an_unregistered_format_is_gone_and_a_bad_record_is_refused():
    with pytest.raises(ValueError, match="cannot tell the format of 'x.toy'"):
        resolve_format("x.toy")
    assert "*.toy" not in export_filter() and "*.txt" in export_filter()
    with pytest.raises(TypeError, match="FileFormat record"):
        cmmsampling.register_format({"name": "dict"})
    with pytest.raises(ValueError, match="extensions must be lower case"):
        cmmsampling.FileFormat("bad", "bad", "bad", ("TOY",), "ascii", None, None)


def test_a_format_registered_as_measured_holds_a_simulated_measurement_read_back_by_inspect(result, tmp_path):
    from cmmsampling.formats.registry import measured_filter

    with pytest.raises(ValueError, match=r"a measurement is written as DMIS \(.dmi, .dmis, .dmo, .dms\) or CSV"):
        cmmsampling.simulate_measurement(result, tmp_path / "m.toy")
    cmmsampling.register_format(replace(TOY_FORMAT, measured=True, recognises=lambda first: first.startswith("toy")))
    try:
        assert "*.toy" in measured_filter() and measured_filter().endswith(";;All files (*)")
        measured = cmmsampling.simulate_measurement(result, tmp_path / "m.toy", form_error=0.01, seed=2)
        back = read_measured(tmp_path / "m.toy")
        assert back.metadata["format"] == "toy", "read by the format's own reader"
        np.testing.assert_allclose(back.points, measured.actual, atol=1e-6)
        (tmp_path / "table.toy").write_text("label x y z\nA 1 2 3\nB 4 5 6\nC 7 8 9\n")
        assert read_measured(tmp_path / "table.toy").metadata["format"] == "labelled text", "not the format's header"
    finally:
        cmmsampling.unregister_format(TOY_FORMAT.name)


def test_a_formats_record_says_what_live_runs_and_inspect_and_its_package_need(result, tmp_path):
    """live: a live run writes its touches in it; unmeasured: inspect refuses its planned points
    in the format's words; packages: the format is refused in one line without them."""
    with pytest.raises(ValueError, match=r"m.dmi: measured points are written as XYZIJK text \(.xyz, .txt\) or CSV"):
        link_settings("127.0.0.1:1294", tmp_path / "m.dmi", None, 5.0, None)
    planned = replace(TOY_FORMAT, live=True, unmeasured=lambda point_set: "a toy plan; give the toy results")
    cmmsampling.register_format(planned)
    try:
        assert link_settings("127.0.0.1:1294", tmp_path / "m.toy", None, 5.0, None).target.endswith("m.toy")
        cmmsampling.export(result, tmp_path / "plan.toy")
        with pytest.raises(ValueError, match=r"plan.toy: a toy plan; give the toy results$"):
            read_measured(tmp_path / "plan.toy")
        cmmsampling.register_format(replace(TOY_FORMAT, packages=("cmmsampling_no_such_package",)))
        with pytest.raises(MissingPackage) as refused:
            cmmsampling.export(result, tmp_path / "again.toy")
        assert str(refused.value).startswith("toy points files need the Python package cmmsampling_no_such_package, ")
        assert "apt install python3-cmmsampling_no_such_package" in str(refused.value)
        assert not (tmp_path / "again.toy").exists()
        with pytest.raises(MissingPackage):
            read_measured(tmp_path / "plan.toy")
    finally:
        cmmsampling.unregister_format(TOY_FORMAT.name)


def _named_formats(source):
    """The format names (but WORDS) that a module's code (not its docstrings) spells as string
    constants."""
    tree = ast.parse(source)
    docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    return sorted({node.value for node in ast.walk(tree)
                   if isinstance(node, ast.Constant) and id(node) not in docstrings
                   and node.value in set(FORMATS) - WORDS})


def test_no_module_outside_the_formats_names_a_format():
    """export(), the live run, inspect, the command line and the panels read the records."""
    found = {path.relative_to(PACKAGE).as_posix(): _named_formats(path.read_text())
             for path in sorted(PACKAGE.rglob("*.py"))}
    assert {module: names for module, names in found.items()
            if names and not module.startswith(FORMAT_HOLDERS)} == {}


def test_the_check_finds_a_named_format():
    assert _named_formats('"""Writes "dmis"."""\nx = FORMATS["qif"]\n') == ["qif"]
    assert _named_formats('"""Writes "dmis"."""\naxes = "xyz"\n') == []
