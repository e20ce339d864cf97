"""The memory estimate before a run and the refusal of a run that would not fit."""
import time

import pytest

import cmmsampling
from cmmsampling.cli import main as cli_main


def test_the_estimate_grows_with_n_and_with_the_swarm():
    sizes = [cmmsampling.memory_needed(n, "pso") for n in (100, 1000, 4000)]
    assert sizes == sorted(sizes) and sizes[0] < sizes[-1] / 4
    assert cmmsampling.memory_needed(1000, "pso", population=50) > cmmsampling.memory_needed(1000, "pso")
    assert cmmsampling.memory_needed(1000, "halton") < cmmsampling.memory_needed(1000, "pso")


def test_a_run_that_does_not_fit_is_refused_at_once_with_the_largest_n_that_fits(reference, monkeypatch):
    monkeypatch.setenv("CMMSAMPLING_MEMORY_BYTES", str(2 * 2**30))
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"n = 100000 needs about .* GiB of memory \(pso, a substitute of "
                                         r"211 x 211 poles\), more than the 2.0 GiB this machine has free; "
                                         r"at most about n = (\d+) fits") as refusal:
        cmmsampling.sample(reference, 100000, "pso")
    assert time.perf_counter() - start < 5.0
    fits = int(refusal.value.args[0].rsplit("n = ", 1)[1].split()[0])
    assert cmmsampling.memory_needed(fits, "pso") <= 0.8 * 2 * 2**30 < cmmsampling.memory_needed(fits + 1, "pso")
    assert cmmsampling.sample(reference, 16, "uniform_parametric", occ_check=False).n == 16


def test_the_command_line_refuses_a_run_that_does_not_fit_in_one_line(tmp_path, capsys, monkeypatch):
    path = str(tmp_path / "part.step")
    cmmsampling.reference_face().exportStep(path)
    monkeypatch.setenv("CMMSAMPLING_MEMORY_BYTES", str(2**30))
    assert cli_main(["sample", path, "--face", "1", "-n", "1000000"]) == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("error: n = 1000000 needs about") and "fits" in line


def test_the_estimate_counts_the_grid():
    """Measured on the reference face (N = 81, uniform parametric): 1263 MiB above the process at
    a 400 x 400 grid and 4685 MiB at 800 x 800; the estimate was 80 MiB for both."""
    default = cmmsampling.memory_needed(81, "uniform_parametric")
    assert cmmsampling.memory_needed(81, "uniform_parametric", grid=400) >= default + 1263 * 2**20
    assert 4685 * 2**20 <= cmmsampling.memory_needed(81, "uniform_parametric", grid=800) <= 1.25 * 4685 * 2**20
