"""The command line: the demo, and bad files, paths and values: exit code 2, one line naming the
file and what to do, no traceback (unless --debug), outputs checked before any computation."""
import os
import re

import pytest
from support.faces import Part
from support.wording import DURATION

import cmmsampling
from cmmsampling import cli
from cmmsampling.cli import main as cli_main


@pytest.fixture
def part(tmp_path):
    """A STEP file holding the reference face."""
    path = str(tmp_path / "part.step")
    cmmsampling.reference_face().exportStep(path)
    return path


@pytest.fixture
def no_sampling(monkeypatch):
    """Make any sampling fail loudly: the checks under test must come before it."""
    def refuse(*args, **kwargs):
        raise AssertionError("sampled before the outputs were checked")
    monkeypatch.setattr(cli, "sample", refuse)


def one_error_line(capsys):
    """The single line the command line printed on stderr (asserting there is only one)."""
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    return lines[0]


@pytest.mark.parametrize("content", [b"", b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');",
                                     b"not a STEP file\n"])
def test_an_unreadable_cad_file_is_named_in_one_line(tmp_path, capsys, content):
    path = tmp_path / "broken.step"
    path.write_bytes(content)
    assert cli_main(["faces", str(path)]) == 2
    line = one_error_line(capsys)
    assert str(path) in line and "cannot be read as STEP" in line and "complete" in line


def test_a_folder_named_like_a_cad_file_is_called_a_folder(tmp_path, capsys):
    folder = tmp_path / "dir.step"
    folder.mkdir()
    assert cli_main(["faces", str(folder)]) == 2
    assert "is a folder, not a CAD file" in one_error_line(capsys)


@pytest.mark.parametrize("option, name, words", [
    ("--out", "x.dmi", "takes no new files"),
    ("--fcstd", "x.FCStd", "takes no new files"),
])
def test_an_output_folder_that_takes_no_file_is_refused_before_sampling(part, capsys, no_sampling,
                                                                      option, name, words):
    assert cli_main(["sample", part, "--face", "1", option, os.path.join("/proc", name)]) == 2
    line = one_error_line(capsys)
    assert "/proc" in line and words in line


@pytest.mark.parametrize("option, target, words", [
    ("--out", "points.pdf", "unknown point-file type"),
    ("--fcstd", "result.txt", "ends in .FCStd"),
    ("--out", "missing/points.dmi", "does not exist"),
])
def test_bad_output_names_are_refused_before_sampling(tmp_path, part, capsys, no_sampling, option,
                                                     target, words):
    assert cli_main(["sample", part, "--face", "1", option, str(tmp_path / target)]) == 2
    assert words in one_error_line(capsys)


def test_an_output_that_is_a_folder_is_refused(tmp_path, part, capsys, no_sampling):
    (tmp_path / "points.csv").mkdir()
    assert cli_main(["sample", part, "--face", "1", "--out", str(tmp_path / "points.csv")]) == 2
    assert "is a folder" in one_error_line(capsys)


def test_out_of_memory_is_one_line_and_debug_shows_the_traceback(part, capsys, monkeypatch):
    def exhausted(*args, **kwargs):
        raise MemoryError()
    monkeypatch.setattr(cli, "sample", exhausted)
    assert cli_main(["sample", part, "--face", "1"]) == 2
    assert "more memory" in one_error_line(capsys)
    assert cli_main(["--debug", "sample", part, "--face", "1"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err and "MemoryError" in err


@pytest.mark.parametrize("fault", [KeyError("inner"), ValueError("a bug's own ValueError"),
                                   TypeError("a bug's own TypeError")], ids=["KeyError", "ValueError", "TypeError"])
def test_an_unexpected_fault_is_one_line_with_exit_code_1(part, capsys, monkeypatch, fault):
    """A ValueError or TypeError of a bug is no refused input (cmmsampling.InputError)."""
    def failing(*args, **kwargs):
        raise fault
    monkeypatch.setattr(cli, "sample", failing)
    assert cli_main(["sample", part, "--face", "1"]) == 1
    line = one_error_line(capsys)
    assert f"unexpected {type(fault).__name__}" in line and "--debug" in line


def test_refused_input_is_an_input_error_with_exit_code_2(part, capsys):
    with pytest.raises(cmmsampling.InputError, match="n must be at least 4, got 3"):
        cmmsampling.sample(cmmsampling.reference_face(), 3)
    with pytest.raises(cmmsampling.InputTypeError, match="expected a Part.Face, got NoneType"):
        cmmsampling.sample(None, 9)
    assert cli_main(["sample", part, "--face", "1", "-n", "3"]) == 2
    assert one_error_line(capsys) == "error: --points must be at least 4, got 3"


def test_a_cad_file_read_by_part_gives_its_faces(part, capsys):
    assert cli_main(["faces", part]) == 0
    assert "Face1" in capsys.readouterr().out and len(Part.read(part).Faces) == 1


def test_the_demo_runs_every_strategy_and_ends_with_the_time_it_took(capsys):
    settings = ["--iterations", "5", "--population", "4", "--time-limit", "1"]
    assert cli_main(["demo", "-n", "25", *settings, "--inspection", "none", "--report", "none"]) == 0
    said = capsys.readouterr().out.splitlines()
    rows = {line.split()[0] for line in said if line.split()[1:2] == ["25"]}
    assert rows == set(cmmsampling.self_contained())
    assert re.fullmatch(rf"The demo took {DURATION} on {os.cpu_count()} cores\.", said[-1]), said[-1]


def test_the_demo_measures_its_points_live_over_ipp_dme_and_inspects_them(capsys, tmp_path):
    settings = ["--iterations", "5", "--population", "4", "--time-limit", "1"]
    assert cli_main(["demo", "-n", "25", *settings, "--inspection", str(tmp_path), "--report", "none"]) == 0
    said = capsys.readouterr().out
    assert "Measured live over I++ DME: Measured 25 of 25 points over I++ DME at 127.0.0.1:" in said
    log = (tmp_path / "ippdme_session.log").read_text().splitlines()
    assert log[0] == "> 00001 StartSession()" and log[-3].endswith("EndSession()") and log[-1].endswith("%")
    live = re.search(r"profile (\d+\.\d+) mm \(the file route: (\d+\.\d+) mm\)", said)
    assert live and abs(float(live.group(1)) - float(live.group(2))) < 0.005, "the same part, probed again"
    assert cmmsampling.read_points(tmp_path / "measured_live.csv").labels[:2] == ["P1", "P2"]
