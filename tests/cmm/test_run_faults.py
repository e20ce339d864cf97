"""A live run keeps every touch whatever ends it: faulty I++ DME servers (the simulated CMM with
a fault in its answers), a progress callback that raises, Ctrl-C and kill -9 of the measuring
process. The points measured before are in the output file (rewritten after each point), the
transcript is written as it goes, the session is ended where the link allows, and answers the
specification allows (warnings, unsolicited errors) or forbids (inches, 1e308, a 10 MB line)
are named in one line."""
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from support.faulty_cmm import FaultyCMM, at, from_point, held_at, report_of, scaled
from support.paths import ROOT

import cmmsampling
from cmmsampling.cmm.client import MeasurementStopped, measure, server_address
from cmmsampling.cmm.server import SimulatedCMM, VirtualPart
from cmmsampling.formats.files import ExportError
from cmmsampling.geometry.validation import InputError

PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable


@pytest.fixture(scope="module")
def result(reference):
    return cmmsampling.sample(reference, 16, "halton", grid=16, occ_check=False)


def faulty(result, fault, **options):
    """The FaultyCMM of result's part (a small form error) with the fault."""
    return FaultyCMM(VirtualPart.of(result, form_error=0.01, seed=3), fault, **options)


def kept(path, count):
    """Assert the file at path reads back with the first count labels P1.. measured; the PointSet."""
    points = cmmsampling.read_points(path)
    assert len(points) == count and np.isfinite(points.points).all()
    return points


def stopped(result, fault, tmp_path, match, **options):
    """The MeasurementStopped of a run against the faulty server (its message matching match)."""
    with faulty(result, fault) as cmm:
        with pytest.raises(MeasurementStopped, match=match) as caught:
            measure(result, cmm.address, tmp_path / "p.csv", log=tmp_path / "run.log", **options)
    assert caught.value.run.commands[-1].endswith("EndSession()"), "the session is ended"
    return caught.value


# -- the files: checked before connecting, written as the points arrive --------------------------

@pytest.mark.parametrize("where", ["missing-folder/run.log", "a-folder"])
def test_a_log_that_cannot_be_written_is_refused_before_connecting(result, tmp_path, where):
    (tmp_path / "a-folder").mkdir()
    with SimulatedCMM(VirtualPart.of(result)) as cmm:
        with pytest.raises(ExportError, match="does not exist|is a folder"):
            measure(result, cmm.address, tmp_path / "p.csv", log=tmp_path / where)
        assert cmm.connections == 0 and not (tmp_path / "p.csv").exists()


def test_each_point_is_on_disk_when_the_next_one_is_asked_for(result, tmp_path):
    seen = []

    def progress(message):
        if message and message.startswith("point "):
            written = (tmp_path / "p.csv").exists() and len(cmmsampling.read_points(tmp_path / "p.csv"))
            logged = (tmp_path / "run.log").read_text().count(" PtMeas(") if (tmp_path / "run.log").exists() else 0
            seen.append((written or 0, logged))

    with SimulatedCMM(VirtualPart.of(result)) as cmm:
        measure(result, cmm.address, tmp_path / "p.csv", log=tmp_path / "run.log", progress=progress)
    assert seen == [(k, k) for k in range(16)]
    assert cmmsampling.read_points(tmp_path / "p.csv").metadata["run_end"] == "all points measured"


def _measuring_process(result, tmp_path, server):
    """A process measuring result's points (exported to planned.csv) into p.csv with a log. It
    takes Ctrl-C as a terminal's Python does, also where the tests run as a background job (whose
    SIGINT a non-interactive shell ignores, and Python then leaves ignored)."""
    cmmsampling.export(result, tmp_path / "planned.csv")
    script = (f"import signal, sys\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
              f"sys.path.insert(0, {ROOT!r})\nimport cmmsampling\n"
              f"cmmsampling.measure(cmmsampling.read_points({str(tmp_path / 'planned.csv')!r}), {server!r}, "
              f"{str(tmp_path / 'p.csv')!r}, log={str(tmp_path / 'run.log')!r})\n")
    return subprocess.Popen([PYTHON, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _signalled_while_held(result, tmp_path, point, signum):
    """Run a measuring process against a CMM that holds the point's answer, send it signum while it
    waits for that answer, and return (its return code, its stderr, the CMM)."""
    reached, release = threading.Event(), threading.Event()
    with faulty(result, held_at(point, reached, release)) as cmm:
        process = _measuring_process(result, tmp_path, cmm.address)
        try:
            assert reached.wait(60), f"the measuring process never asked for point {point}: {process.poll()}"
            process.send_signal(signum)
        finally:
            release.set()
            _, err = process.communicate(timeout=60)
    return process.returncode, err, cmm


def test_kill_9_leaves_the_points_measured_before_it_for_inspect(result, tmp_path):
    returncode, _, _ = _signalled_while_held(result, tmp_path, 10, signal.SIGKILL)
    assert returncode == -signal.SIGKILL
    points = cmmsampling.read_points(tmp_path / "p.csv")
    assert len(points) == 9 and points.metadata["run_end"] == "in progress"
    assert points.labels == result.labels[:9]
    log = (tmp_path / "run.log").read_text()
    last = log.splitlines()[-1]
    assert log.count(" # X(") == 9 and last.startswith("> ") and " PtMeas(" in last, \
        "the transcript up to the command under way"
    found = cmmsampling.inspect(result, tmp_path / "p.csv", tolerance=0.1)
    assert len(found.labels) == 9 and found.profile < 0.05


def test_ctrl_c_keeps_the_points_and_ends_the_session(result, tmp_path):
    returncode, err, cmm = _signalled_while_held(result, tmp_path, 3, signal.SIGINT)
    assert returncode != 0 and "KeyboardInterrupt" in err
    assert "cmmsampling: Measured 2 of 16" in err, "the run is named in the exception's note"
    points = cmmsampling.read_points(tmp_path / "p.csv")
    assert len(points) == 2 and points.metadata["run_end"] == "stopped: interrupted (Ctrl-C)"
    assert cmm.commands[-1].endswith("EndSession()")


@pytest.mark.parametrize("raised, expected", [(ValueError("bad"), MeasurementStopped), (KeyboardInterrupt(), KeyboardInterrupt)])
def test_a_progress_callback_that_raises_keeps_the_points(result, tmp_path, raised, expected):
    def progress(message):
        if message == "point 4 of 16":
            raise raised

    with SimulatedCMM(VirtualPart.of(result)) as cmm:
        with pytest.raises(expected) as caught:
            measure(result, cmm.address, tmp_path / "p.csv", progress=progress)
    kept(tmp_path / "p.csv", 3)
    assert cmm.commands[-1].endswith("EndSession()")
    if expected is MeasurementStopped:
        assert str(caught.value).startswith("the progress callback raised ValueError: 'bad'; Measured 3 of 16")
        assert caught.value.__cause__ is raised


# -- answers the client cannot use -----------------------------------------------------------

def _wrong_tag(tag, answers):
    return [line.replace(f"{tag} #", "00999 #") for line in answers]


def _after_end(tag, answers):
    return [line for line in answers if " # " not in line] + [report_of(answers)]


def _no_vector(tag, answers):
    report = report_of(answers)
    return [line.split(", IJK(")[0] if line == report else line for line in answers]


@pytest.mark.parametrize("change, match", [
    (_wrong_tag, r"with 0 point reports where one with X, Y, Z, IJK, ER was asked for .*got 'no data'"),
    (_after_end, "with 0 point reports"),
    (_no_vector, r"with 0 point reports .*got \"\{'X': \("),
])
def test_an_answer_without_its_point_is_named_and_the_points_before_are_kept(result, tmp_path, change, match):
    stop = stopped(result, at("PtMeas", 4, change), tmp_path, match)
    assert stop.run.labels == result.labels[:3]
    kept(tmp_path / "p.csv", 3)
    assert cmmsampling.read_points(tmp_path / "p.csv").metadata["run_end"].startswith("stopped: the CMM answered")


def test_a_point_out_of_range_is_refused_naming_it(result, tmp_path):
    def huge(tag, answers):
        report = report_of(answers)
        return [f"{tag} # X(1e308), Y(2), Z(3), IJK(0,0,1), ER(1)" if line == report else line for line in answers]

    stop = stopped(result, at("PtMeas", 2, huge), tmp_path, r"reported X\(1e\+308\), Y\(2\).* outside the machine volume")
    kept(tmp_path / "p.csv", 1)
    assert "inf" not in (tmp_path / "p.csv").read_text()
    assert len(str(stop)) < 700


def test_a_stated_machine_volume_is_kept(result, tmp_path):
    stopped(result, lambda *fault: fault[2], tmp_path, r"outside the machine volume \[-1.0, -1.0, -1.0\]",
            volume=((-1, -1, -1), (1, 1, 1)))
    with pytest.raises(InputError, match="give the machine volume as"):
        measure(result, "127.0.0.1:1", tmp_path / "q.csv", volume=((0, 0, 0), (0, 1, 1)))


def test_a_server_speaking_inches_is_refused_at_its_second_point(result, tmp_path):
    stop = stopped(result, from_point(1, lambda tag, answers: scaled(tag, answers, 1 / 25.4)), tmp_path,
                   r"the CMM's point P2 lies .* mm from point P1 where the plan has .* is the CMM set to inches")
    kept(tmp_path / "p.csv", 1)
    assert stop.run.labels == ["P1"]


def test_a_ball_radius_in_inches_is_refused_against_the_plans_probe(tmp_path):
    from support.faces import walled_part

    from cmmsampling.access.probe import Probe

    part, upward = walled_part()
    plan = cmmsampling.plan(part, tolerance=0.5, strategy="uniform_parametric", faces=upward, probe=Probe(),
                            processes=1, grid=20, n_max=30)
    with FaultyCMM(VirtualPart.of(plan), lambda *fault: fault[2], tools={"Ball2": 0.03937}, homed=True) as cmm:
        with pytest.raises(MeasurementStopped, match=r"ball radius ER\(0.03937\) for point \S+ where the tool's is "
                                                      r"1 mm; I\+\+ DME speaks millimetres: is the CMM set to inches"):
            measure(plan, cmm.address, tmp_path / "p.csv")
    assert not (tmp_path / "p.csv").exists()


def test_a_ten_megabyte_line_is_refused_in_a_short_message(result, tmp_path):
    def flood(tag, answers):
        return [f"{tag} &", f"{tag} # X({'1' * 10_000_000})", f"{tag} %"]

    stop = stopped(result, at("PtMeas", 3, flood), tmp_path, "a line of more than 65536 characters")
    assert len(str(stop)) < 1000
    kept(tmp_path / "p.csv", 2)
    assert max(len(line) for line in (tmp_path / "run.log").read_text().splitlines()) <= 65536 + 2


# -- errors as the specification has them ----------------------------------------------------

@pytest.mark.parametrize("severity, code, text", [(1, 504, "Argument out of range"), (0, 0, "Buffer full")])
def test_a_warning_is_kept_and_the_run_goes_on(result, tmp_path, severity, code, text):
    def warn(tag, answers):
        return answers[:-1] + [f'{tag} ! Error({severity}, {code:04d}, "GoTo", "{text}")', answers[-1]]

    said = []
    with faulty(result, at("GoTo", 2, warn)) as cmm:
        run = measure(result, cmm.address, tmp_path / "p.csv", log=tmp_path / "run.log", progress=said.append)
    assert len(run.labels) == 16 and not run.missing
    assert len(run.warnings) == 1 and run.warnings[0].startswith("the CMM answered 00009 GoTo(")
    assert run.warnings[0].endswith(f"with I++ error {code:04d} (severity {severity}): {text}")
    assert f"warning: {run.warnings[0]}" in said and "Warnings (1): the CMM answered 00009 GoTo(" in str(run)
    assert f"! warning: {run.warnings[0]}" in (tmp_path / "run.log").read_text()


def test_an_unsolicited_error_stops_the_run_at_once_with_the_cmms_text(result, tmp_path):
    def emergency(tag, answers):
        return [f"{tag} &", 'E0000 ! Error(3, 0500, "HealthCheck", "Emergency stop")']

    started = time.monotonic()
    stop = stopped(result, at("PtMeas", 3, emergency), tmp_path,
                   r"^the CMM reported an unsolicited I\+\+ error 0500 \(severity 3\) during 00012 PtMeas\(.*\): "
                   "Emergency stop; Measured 2 of 16", timeout_s=30)
    assert time.monotonic() - started < 15, "not the 30 s time-out"
    assert " AbortE()" in " ".join(stop.run.commands), "the running PtMeas is aborted"
    kept(tmp_path / "p.csv", 2)


def test_an_error_without_its_end_is_named_at_once(result, tmp_path):
    def no_end(tag, answers):
        return [f"{tag} &", f'{tag} ! Error(2, 1006, "PtMeas", "Surface not found")']

    started = time.monotonic()
    stopped(result, at("PtMeas", 2, no_end), tmp_path,
            r"^the CMM answered 00010 PtMeas\(.*\) with I\+\+ error 1006 \(severity 2\): Surface not found;",
            timeout_s=30)
    assert time.monotonic() - started < 15
    kept(tmp_path / "p.csv", 1)


# -- the server's address ----------------------------------------------------------------------

@pytest.mark.parametrize("given, expected", [("[::1]:1294", ("::1", 1294)), ("[::1]", ("::1", 1294)),
                                             ("cmm.local:5000", ("cmm.local", 5000)), (" 10.0.0.2 ", ("10.0.0.2", 1294))])
def test_server_addresses_are_understood(given, expected):
    assert server_address(given) == expected


@pytest.mark.parametrize("given, match", [(None, r"no I\+\+ DME server given \(None\)"), ("", "no I\\+\\+ DME server"),
                                          ("::1:1294", "write an IPv6 address in brackets"),
                                          ("[::1]:http", "give the I\\+\\+ DME server as 'host:port'")])
def test_bad_server_addresses_are_refused_before_connecting(result, tmp_path, given, match):
    with pytest.raises(InputError, match=match):
        measure(result, given, tmp_path / "p.csv")


def test_a_server_on_ipv6_is_reached(result, tmp_path):
    try:
        listener = socket.socket(socket.AF_INET6)
        listener.bind(("::1", 0))
    except OSError:
        pytest.skip("no IPv6 loopback here")
    listener.listen(1)

    def answer_once():
        connection, _ = listener.accept()
        line = connection.makefile("rb").readline().decode().split(" ")[0]
        connection.sendall(f"{line} &\r\n".encode())
        connection.close()
        listener.close()

    threading.Thread(target=answer_once, daemon=True).start()
    with pytest.raises(MeasurementStopped, match=r"the CMM closed the connection during 00001 StartSession\(\); "
                                                 r"Measured 0 of 16 points over I\+\+ DME at \[::1\]:"):
        measure(result, f"[::1]:{listener.getsockname()[1]}", tmp_path / "p.csv")


def test_the_nist_programs_built_for_a_test_session_are_removed_after_it(tmp_path):
    script = (f"import sys\nsys.path.insert(0, {os.path.join(ROOT, 'tests')!r})\n"
              "from support.ippdme import checker\nprint(checker())\n")
    done = subprocess.run([PYTHON, "-c", script], capture_output=True, text=True, timeout=300)
    built = done.stdout.strip()
    if built == "None":
        pytest.skip("g++ or ../shared/reference/ippdme-nist is missing")
    assert done.returncode == 0 and os.path.basename(os.path.dirname(built)).startswith("nist-ippdme-")
    assert not os.path.exists(os.path.dirname(built))
