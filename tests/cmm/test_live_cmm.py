"""A live CMM over I++ DME: the client measures a face's and a part's plan on the simulated
server (the virtual CMM of simulate_measurement behind the protocol, on 127.0.0.1), the
inspection of what it measured is the file route's, NIST's command checker passes every command
stream it sends, and a Cancel, a lost connection, an I++ error or a silent server leave a
consistent file of the points measured and an ended session."""
import socket

import numpy as np
import pytest
from support.dropping_server import serve_then_drop
from support.faces import walled_part
from support.ippdme import check_answers, check_commands, checker, response_parser

import cmmsampling
from cmmsampling.access.probe import Probe
from cmmsampling.cmm.client import MeasurementStopped, measure
from cmmsampling.cmm.server import SimulatedCMM, VirtualPart
from cmmsampling.geometry.validation import InputError

MISPLACED = {"rz": 0.6, "ry": -0.3, "x": 1.2, "y": -0.8}


@pytest.fixture(scope="module")
def result(reference):
    return cmmsampling.sample(reference, 16, "halton", grid=16, occ_check=False)


@pytest.fixture(scope="module")
def walled():
    """A base with a wall, its two upward faces planned with a 2 mm ball (a collision-free path)."""
    part, upward = walled_part()
    plan = cmmsampling.plan(part, tolerance=0.5, strategy="uniform_parametric", faces=upward, probe=Probe(),
                            processes=1, grid=20, n_max=30)
    return part, plan


def nist_passes(commands, tmp_path, log=None):
    """Assert NIST's checker finds nothing in commands, and its response parser nothing in the
    answers of the session's log (skipped without g++ or ../shared)."""
    if checker() is None or response_parser() is None:
        pytest.skip("g++ or ../shared/reference/ippdme-nist is missing")
    assert check_commands(commands, str(tmp_path)) == []
    if log is not None:
        answers = [line[2:] for line in log.read_text().splitlines() if line.startswith("< ")]
        assert answers and check_answers(answers, str(tmp_path)) == []


def test_a_face_measured_live_is_judged_as_the_file_route_judges_it(result, tmp_path):
    with cmmsampling.SimulatedCMM.measuring(result, form_error=0.02, misplacement=MISPLACED, seed=2,
                                            tools={"Probe1": 1.5}) as cmm:
        run = measure(result, cmm.address, tmp_path / "live.csv", log=tmp_path / "session.log")
    assert run.labels == result.labels and not run.missing and run.radius == 1.5 and run.tool == "Probe1"
    assert str(run).startswith("Measured 16 of 16 points over I++ DME at 127.0.0.1:")
    live = cmmsampling.inspect(result, run, tolerance=0.05)
    cmmsampling.simulate_measurement(result, tmp_path / "file.csv", form_error=0.02, misplacement=MISPLACED, seed=2)
    filed = cmmsampling.inspect(result, tmp_path / "file.csv", tolerance=0.05)
    assert np.abs(live.deviations - filed.deviations).max() < 1e-5, "the I++ numbers' 6 decimals"
    assert live.passed is filed.passed and abs(live.profile - filed.profile) < 2e-5
    assert [line.split(" ", 1)[1] for line in run.commands[:6]] == [
        "StartSession()", "IsHomed()", "Home()", "EnumTools()", 'ChangeTool("Probe1")',
        "OnPtMeasReport(X(),Y(),Z(),IJK(),ER())"]
    assert run.commands[-1].endswith("EndSession()") and sum("PtMeas(" in c for c in run.commands) == 16
    assert "< 00004 # \"Probe1\"" in (tmp_path / "session.log").read_text()
    nist_passes(run.commands, tmp_path, tmp_path / "session.log")


def test_a_plan_goes_along_its_probe_path_and_is_inspected(walled, tmp_path):
    part, plan = walled
    with SimulatedCMM(VirtualPart.of(plan, form_error=0.01, seed=1), tools={"Ball2": 1.0, "Ball3": 1.5},
                      homed=True) as cmm:
        run = measure(plan, cmm.address, tmp_path / "part.csv", tool="Ball2")
    assert len(run.labels) == plan.n_total and run.radius == 1.0
    assert "Home()" not in " ".join(run.commands), "a homed machine is not homed again"
    from cmmsampling.access.probe_moves import probe_moves

    moves = probe_moves(plan)
    gotos = [c for c in run.commands if " GoTo(" in c]
    assert len(gotos) == sum(len(leaving) + len(arriving) for leaving, arriving in moves.travel_pairs()[:-1])
    found = cmmsampling.inspect(plan, run, part=part, tolerance=0.05)
    assert found.passed and found.profile < 0.025 and not found.notes
    in_nists_world = [c.replace('"Ball2"', '"Probe1"') for c in run.commands]
    in_nists_world.insert(2, "99999 Home()")   # its machine starts unhomed, this one was homed
    nist_passes(in_nists_world, tmp_path)


def test_cancel_during_a_move_aborts_it_and_keeps_the_points_measured(result, tmp_path):
    asked = []

    def progress(message):
        asked.append(message)
        return "point 11 of 16" in asked and message is None

    with SimulatedCMM(VirtualPart.of(result), move_s=0.05) as cmm:
        run = measure(result, cmm.address, tmp_path / "part.csv", progress=progress, log=tmp_path / "session.log")
        received = list(cmm.commands)
    assert run.cancelled and len(run.labels) == 10 and run.missing == result.labels[10:]
    assert "Not measured (cancelled): P11, P12" in str(run)
    methods = [c.split(" ", 1)[1] for c in run.commands]
    assert methods[-3:] == ["AbortE()", "ClearAllErrors()", "EndSession()"] and received[-1].endswith("EndSession()")
    assert run.commands[-3].startswith("E"), "AbortE goes on the fast queue"
    back = cmmsampling.read_points(run)
    assert back.labels == result.labels[:10] and back.metadata["not_measured"].split() == result.labels[10:]
    found = cmmsampling.inspect(result, run)
    assert found.notes == ["6 planned points were not measured: P11, P12, P13, P14, P15, P16"]
    assert "Error(2, 0006," in (tmp_path / "session.log").read_text(), "the aborted move's answer"
    nist_passes(run.commands, tmp_path, tmp_path / "session.log")


def test_cancel_between_points_ends_the_session_without_an_abort(result, tmp_path):
    with SimulatedCMM(VirtualPart.of(result), homed=True) as cmm:
        run = measure(result, cmm.address, tmp_path / "p.csv", progress=lambda m: m == "point 3 of 16")
    assert run.cancelled and len(run.labels) == 2 and "AbortE()" not in " ".join(run.commands)
    assert run.commands[-1].endswith("EndSession()")


def test_an_ipp_error_is_named_and_the_points_before_it_are_kept(result, tmp_path):
    far = VirtualPart.of(result, misplacement={"z": 30.0})
    with SimulatedCMM(far) as cmm:
        with pytest.raises(MeasurementStopped, match=r"I\+\+ error 1006 \(severity 2\): Surface not found") as caught:
            measure(result, cmm.address, tmp_path / "p.csv", log=tmp_path / "error.log")
    run = caught.value.run
    assert run.labels == [] and run.missing == result.labels and run.commands[-1].endswith("EndSession()")
    assert "ClearAllErrors()" in run.commands[-2] and not (tmp_path / "p.csv").exists()
    nist_passes(run.commands, tmp_path, tmp_path / "error.log")
    with SimulatedCMM(VirtualPart.of(result)) as cmm:
        with pytest.raises(MeasurementStopped, match="the CMM has no tool 'Star'; it lists Probe1") as caught:
            measure(result, cmm.address, tmp_path / "q.csv", tool="Star")
    assert caught.value.run.commands[-1].endswith("EndSession()")
    nist_passes(caught.value.run.commands, tmp_path)


def test_a_lost_connection_keeps_the_points_measured(result, tmp_path):
    with pytest.raises(MeasurementStopped, match="the CMM closed the connection during|the connection to the CMM was "
                                                 "lost during") as caught:
        measure(result, serve_then_drop(4 + 2 * 3), tmp_path / "p.csv")
    assert len(caught.value.run.labels) == 2 and (tmp_path / "p.csv").exists()


def test_a_silent_server_is_a_named_time_out(result, tmp_path):
    with pytest.raises(MeasurementStopped, match=r"no answer from the CMM to 00001 StartSession\(\) within 0.5 s"):
        measure(result, serve_then_drop(1, answers=False), tmp_path / "p.csv", timeout_s=0.5)
    assert not (tmp_path / "p.csv").exists(), "nothing measured, nothing written"


@pytest.mark.parametrize("server, out, message", [
    ("localhost:http", "m.csv", r"give the I\+\+ DME server as 'host:port'"),
    ("127.0.0.1:1294", "m.dmi", r"measured points are written as XYZIJK text \(.xyz, .txt\) or CSV \(.csv\)"),
])
def test_bad_arguments_are_refused_before_connecting(result, tmp_path, server, out, message):
    with pytest.raises(InputError, match=message):
        measure(result, server, tmp_path / out)


def test_an_unreachable_server_is_named(result, tmp_path):
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    port = closed.getsockname()[1]
    closed.close()
    with pytest.raises(MeasurementStopped, match=f"cannot reach the I\\+\\+ DME server at 127.0.0.1:{port}"):
        measure(result, f"127.0.0.1:{port}", tmp_path / "m.csv")
