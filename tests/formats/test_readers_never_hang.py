"""Readers that never hang (issue 76): a path that is no regular file (a named pipe, a device) is
refused before it is opened, by read_points, inspect and ``python -m cmmsampling faces``; every
point file goes through one capped read (100 MB, the stated size checked first and never trusted
alone); a QIF document whose counts, id lists or number lists disagree with its data, or that
lxml's schema check cannot judge, is refused in one line naming the element.

Each test fails on the code before, without hanging: the readers blocked on a pipe (the calls run
here in a thread that is fed end-of-file after WAIT_S, or in a subprocess with a timeout), read
/dev/zero until memory ran out (a subprocess with its address space limited), read a point file of
any size, took a QIF count or a broken id list as it came (32 points of 16) and let numpy's and
lxml's raw errors through."""
import os
import re
import resource
import subprocess
import threading
import time

import pytest
from support.paths import ROOT

import cmmsampling
from cmmsampling import InputError
from cmmsampling.formats.qif import schema

PYTHON = "/usr/bin/python3"
# How long a reader may take before the test counts it as blocked (s).
WAIT_S = 10
# The size cap of every point file (cmmsampling.formats.files.POINT_FILES) and of a CAD file
# (CAD_FILES), bytes.
POINT_CAP = 100 * 2 ** 20
CAD_CAP = 2 ** 30
POINT_EXTENSIONS = [".csv", ".qif", ".dmi", ".xyz"]
NOT_REGULAR = "is {what}, not a {kind}; give a regular file's path (save what it delivers to a file first)"
CORRECT = "; correct the file or export it again"


def refusal(call, pipe):
    """The message of the InputError call() raises, run in a thread; the test fails where the call
    still blocks after WAIT_S (the pipe is then given end-of-file until the call ends, so that no
    thread is left behind)."""
    outcome = []
    thread = threading.Thread(target=lambda: outcome.append(raised(call)), daemon=True)
    thread.start()
    thread.join(WAIT_S)
    blocked = thread.is_alive()
    deadline = time.monotonic() + 60
    while thread.is_alive() and time.monotonic() < deadline:
        try:
            os.close(os.open(pipe, os.O_WRONLY | os.O_NONBLOCK))
        except OSError:   # no reader waits on the pipe at this moment
            pass
        thread.join(0.1)
    assert not blocked, f"the reader blocked on the named pipe {pipe}"
    assert isinstance(outcome[0], InputError), outcome
    return str(outcome[0])


def raised(call):
    """The exception call() raises (None where it returns)."""
    try:
        call()
    except Exception as exc:
        return exc
    return None


def limited_memory():
    """In the child process: at most 1.5 GB of address space (FreeCAD's modules take 0.4 GB), so
    that a reader that reads without end fails with MemoryError and takes no one's memory."""
    resource.setrlimit(resource.RLIMIT_AS, (3 * 2 ** 29, 3 * 2 ** 29))


def run_python(code):
    """The stdout of Python code run from the checkout in a subprocess with limited memory and
    a timeout."""
    done = subprocess.run([PYTHON, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                          preexec_fn=limited_memory)
    return done.stdout.strip()


def faces(path):
    """(exit code, the last line on stderr) of ``python -m cmmsampling faces path``, with a timeout."""
    done = subprocess.run([PYTHON, "-m", "cmmsampling", "faces", str(path)], cwd=ROOT, capture_output=True,
                          text=True, timeout=60)
    return done.returncode, done.stderr.strip().splitlines()[-1]


def sparse(path, size):
    """A file of size bytes that takes no disk (a hole)."""
    with open(path, "wb") as stream:
        stream.truncate(size)
    return path


@pytest.mark.parametrize("extension", POINT_EXTENSIONS)
def test_read_points_refuses_a_named_pipe_before_opening_it(tmp_path, extension):
    pipe = tmp_path / f"points{extension}"
    os.mkfifo(pipe)
    message = refusal(lambda: cmmsampling.read_points(pipe), pipe)
    assert message == f"{pipe}: " + NOT_REGULAR.format(what="a named pipe (FIFO)", kind="point file")


@pytest.mark.parametrize("extension", POINT_EXTENSIONS + [".txt"])
def test_inspect_refuses_a_named_pipe_as_the_measured_file(reference, tmp_path, extension):
    pipe = tmp_path / f"measured{extension}"
    os.mkfifo(pipe)
    message = refusal(lambda: cmmsampling.inspect(reference, pipe), pipe)
    assert message == f"{pipe}: " + NOT_REGULAR.format(what="a named pipe (FIFO)", kind="measured-points file")


def test_the_command_line_refuses_a_named_pipe_as_the_cad_file(tmp_path):
    pipe = tmp_path / "part.step"
    os.mkfifo(pipe)
    code, line = faces(pipe)
    assert code == 2 and line == f"error: {pipe}: " + NOT_REGULAR.format(what="a named pipe (FIFO)",
                                                                         kind="CAD file")


@pytest.mark.parametrize("call, kind", [("cmmsampling.read_points('/dev/zero', format='csv')", "point file"),
                                        ("cmmsampling.inspect(cmmsampling.reference_face(), '/dev/zero')",
                                         "measured-points file")])
def test_a_device_is_refused_before_it_is_read(call, kind):
    """/dev/zero states a size of 0 and never ends."""
    code = f"import cmmsampling\ntry:\n    {call}\nexcept Exception as exc:\n    print(type(exc).__name__, exc)"
    assert run_python(code) == "InputError /dev/zero: " + NOT_REGULAR.format(what="a character device", kind=kind)


@pytest.mark.parametrize("extension", POINT_EXTENSIONS)
def test_a_point_file_over_the_cap_is_refused_before_it_is_read(reference, tmp_path, extension):
    """One byte over the cap, by read_points and as a measured file (a sparse file: no disk used)."""
    from cmmsampling.formats import files

    path = sparse(tmp_path / f"huge{extension}", POINT_CAP + 1)
    refused = ("is more than a {kind} may hold (100 MB, about a million points); split the file by face or part "
               "and read each piece")
    with pytest.raises(InputError) as caught:
        cmmsampling.read_points(path)
    assert str(caught.value) == f"{path}: {POINT_CAP + 1} bytes " + refused.format(kind="point file")
    with pytest.raises(InputError) as caught:
        cmmsampling.inspect(reference, path)
    assert str(caught.value) == f"{path}: {POINT_CAP + 1} bytes " + refused.format(kind="measured-points file")
    assert files.POINT_FILES.most == POINT_CAP


def test_the_read_stops_at_the_cap_where_a_file_states_less_than_it_holds(monkeypatch):
    """/proc/self/maps states 0 bytes and holds kilobytes: the read takes at most cap + 1 bytes."""
    from cmmsampling.formats import files

    monkeypatch.setattr(files, "POINT_FILES", files.SizeLimit(100, "a test's cap", "give less"))
    with pytest.raises(InputError) as caught:
        cmmsampling.read_points("/proc/self/maps", format="csv")
    assert str(caught.value) == ("/proc/self/maps: holds more than a point file may (100 bytes, a test's cap) "
                                 "though it states 0 bytes; give less")


def test_a_cad_file_over_its_cap_is_refused_before_occ_reads_it(tmp_path):
    path = sparse(tmp_path / "assembly.step", CAD_CAP + 2 ** 20)
    code, line = faces(path)
    assert code == 2 and line == (f"error: {path}: 1025 MB is more than a CAD file may hold (1024 MB, OCC takes some "
                                  "ten times that in memory); export the part alone, not its whole assembly")


@pytest.fixture(scope="module")
def qif_files(reference, tmp_path_factory):
    """The texts of a QIF results file of 16 points (its two point sets: as read and aligned) and
    of a QIF plan of them, as the project writes them."""
    folder = tmp_path_factory.mktemp("qif")
    result = cmmsampling.sample(reference, 16, "halton", grid=16, occ_check=False)
    inspection = cmmsampling.inspect(result, cmmsampling.PointSet.from_result(result), tolerance=0.01)
    cmmsampling.export(inspection, folder / "results.qif", label="plate.step")
    cmmsampling.export(result, folder / "plan.qif")
    return {name: (folder / f"{name}.qif").read_text() for name in ("results", "plan")}


def first_set(text):
    """(its id, the span of its Points' numbers, the span of its Ids' text) of the first
    MeasuredPointSet of a results document."""
    match = re.search(r'<MeasuredPointSet id="(\d+)" count="16">.*?<Points>([^<]*)</Points>.*?<Ids>([^<]*)</Ids>',
                      text, re.DOTALL)
    return match.group(1), match.span(2), match.span(3)


def edit_ids(text, change, which=0):
    """The text with the Ids list of its which-th MeasuredPointSet (0: the first) changed by
    change(list of ids) -> list of ids."""
    spans = [m.span(1) for m in re.finditer(r"<MeasuredPointSet .*?<Ids>([^<]*)</Ids>", text, re.DOTALL)]
    start, end = spans[which]
    return text[:start] + " ".join(change(text[start:end].split())) + text[end:]


def drop_a_number(text):
    """The first point set's Points with its last number dropped (47 numbers for 16 points)."""
    _, (start, end), _ = first_set(text)
    return text[:start] + " ".join(text[start:end].split()[:-1]) + text[end:]


def with_entity(text):
    """A DOCTYPE declaring an internal entity, used for the part's name."""
    text = text.replace("?>\n", '?>\n<!DOCTYPE QIFDocument [<!ENTITY part "plate.step">]>\n', 1)
    return text.replace("<Name>plate.step</Name>", "<Name>&part;</Name>", 1)


# (what the file holds, the edit of the results file, the refusal after the file's path)
QIF_CASES = [
    ("a count of 99 on a set of 16 points", lambda t: t.replace('count="16">', 'count="99">', 1),
     'MeasuredPointSet id="{set}" says count="99" but its Points hold 16 points (48 numbers)' + CORRECT),
    ("an id list one short", lambda t: edit_ids(t, lambda ids: ids[:-1]),
     'the MeasurePointNominalIds of MeasuredPointSet id="{set}" say n="16" but list 15 ids' + CORRECT),
    ("an id list one short, its n too", lambda t: edit_ids(t, lambda ids: ids[:-1]).replace(
        '<MeasurePointNominalIds n="16">', '<MeasurePointNominalIds n="15">', 1),
     "the MeasurePointNominalIds of MeasuredPointSet id=\"{set}\" list 15 ids for the set's 16 points" + CORRECT),
    ("an id twice", lambda t: edit_ids(t, lambda ids: ids[:-1] + ids[:1]),
     'the MeasurePointNominalIds of MeasuredPointSet id="{set}" list id {first} twice' + CORRECT),
    ("an id of no element", lambda t: edit_ids(t, lambda ids: ids[:-1] + ["9999"]),
     'the MeasurePointNominalIds of MeasuredPointSet id="{set}" list id 9999, which no element of the file has'
     + CORRECT),
    ("two sets sharing 15 planned points", lambda t: edit_ids(t, lambda ids: ids[:-1] + ["1"], which=1),
     'MeasuredPointSet id="{set}" and MeasuredPointSet id="{second}" both measure the planned point {first} but '
     "list different planned points; keep one point set per planned point"),
    ("47 numbers for 16 points", drop_a_number,
     'the Points of MeasuredPointSet id="{set}" hold 47 numbers, not a multiple of 3 (x y z a point)' + CORRECT),
    ("an internal entity", with_entity,
     "line {line} uses the XML entity &part; (declared in its DOCTYPE), which the QIF 3.0 schema check does not "
     "expand; write the entity's text in its place, or export the file again"),
    ("point labels that are no JSON", lambda t: re.sub(r'name="pointLabels" value="[^"]*"',
                                                       'name="pointLabels" value="[oops"', t, count=1),
     'the pointLabels attribute of PointDefinedSurfaceFeatureItem id="{item}" is no JSON list of labels' + CORRECT),
]


@pytest.mark.parametrize("case, edit, refused", QIF_CASES, ids=[case[0] for case in QIF_CASES])
def test_a_qif_file_whose_data_disagree_is_refused_naming_the_element(reference, qif_files, tmp_path, case, edit,
                                                                     refused):
    text = edit(qif_files["results"])
    path = tmp_path / "edited.qif"
    path.write_text(text)
    set_id, _, (start, end) = first_set(qif_files["results"])
    facts = {"set": set_id, "second": str(int(set_id) + 1), "first": qif_files["results"][start:end].split()[0],
             "item": re.search(r'<PointDefinedSurfaceFeatureItem id="(\d+)"', text).group(1),
             "line": text[:text.find("&part;")].count("\n") + 1}
    for read in (cmmsampling.read_points, lambda p: cmmsampling.inspect(reference, p)):
        with pytest.raises(InputError) as caught:
            read(path)
        assert str(caught.value) == f"{path}: " + refused.format(**facts)


def test_an_id_list_in_another_order_reads_the_points_once(qif_files, tmp_path):
    """The aligned set lists the same planned points in reverse: they are the as-read set's, read
    once (16 points, not 32)."""
    path = tmp_path / "reordered.qif"
    path.write_text(edit_ids(qif_files["results"], lambda ids: ids[::-1], which=1))
    again = cmmsampling.read_points(path)
    assert len(again) == 16 and again.labels == [f"P{i}" for i in range(1, 17)]


def test_a_plans_defining_points_that_disagree_with_their_n_are_refused(qif_files, tmp_path):
    path = tmp_path / "plan.qif"
    path.write_text(qif_files["plan"].replace('<DefiningPoints n="16">', '<DefiningPoints n="15">', 1))
    nominal = re.search(r'<PointDefinedSurfaceFeatureNominal id="(\d+)"', qif_files["plan"]).group(1)
    with pytest.raises(InputError) as caught:
        cmmsampling.read_points(path)
    assert str(caught.value) == (f'{path}: the DefiningPoints of PointDefinedSurfaceFeatureNominal id="{nominal}" say '
                                 'n="15" but hold 16 DefiningPoint elements' + CORRECT)


def test_a_word_that_is_no_number_is_named_where_the_schemas_let_it_through(qif_files, tmp_path, monkeypatch):
    """The schemas passing the file (as a laxer check might): the reader's own checks name the
    word, not numpy."""
    monkeypatch.setattr("cmmsampling.formats.qif.read.schema_errors", lambda text: [])
    text = qif_files["results"]
    set_id, (start, end), _ = first_set(text)
    path = tmp_path / "word.qif"
    path.write_text(text[:start] + "abc" + text[start + text[start:end].index(" "):])
    with pytest.raises(InputError) as caught:
        cmmsampling.read_points(path)
    assert str(caught.value) == f"{path}: the Points of MeasuredPointSet id=\"{set_id}\": 'abc' is no number" + CORRECT


def test_a_failure_inside_lxmls_schema_check_is_named(qif_files, tmp_path, monkeypatch):
    """lxml's validator failing inside (as it did on an entity) is one line, not lxml's error."""
    from lxml import etree

    class Failing:
        def validate(self, document):
            raise etree.XMLSchemaValidateError("Internal error in XML Schema validation.")

    monkeypatch.setattr(schema, "qif_schema", Failing)
    path = tmp_path / "results.qif"
    path.write_text(qif_files["results"])
    with pytest.raises(InputError) as caught:
        cmmsampling.read_points(path)
    assert str(caught.value) == (f"{path}: lxml's QIF 3.0 schema check failed inside (Internal error in XML Schema "
                                 "validation.); export the file again")
