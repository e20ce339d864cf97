"""A user's headless session with the workbench as installed: run by tests/package/test_installed.py as
``freecadcmd installed_smoke.py`` from a folder outside the checkout, with the add-on linked into a
temporary HOME's Mod folder.

It samples the reference face with the paper's PSO on 2 processes (and checks that the second
process answered and scored particles), adds the result to a document, saves, reopens and
exports it (DMIS, and QIF read back), kills the worker in the middle of a second run (the run
ends in this process, with the same points and a note), runs once more with a worker that
cannot import the package, and plans 2 faces of a box on 2 local processes; a new freecadcmd
then runs the copy's tests/without_optional_packages.py (lxml hidden: QIF refused in one line,
DMIS written). SIGPIPE is set to end the process, as FreeCAD 1.0 and 1.1
leave it, so that a write to a dead worker would kill this process on every version. Each step
prints one line starting with "ok"; any failure raises, and the process exits with 1.
"""
import os
import signal
import subprocess
import sys
import tempfile
import traceback


def check(condition, what):
    """Print "ok <what>", or raise AssertionError naming it."""
    if not condition:
        raise AssertionError(what)
    print(f"ok {what}", flush=True)


def sample_on_two_processes(cmmsampling, parallel, face):
    """The paper's PSO (shortened) with its default processes; the worker's pid and share."""
    result = cmmsampling.sample(face, 25, "pso", iterations=40, grid=30)
    worker = parallel.shared_worker()[0]
    check(worker is not None and worker.alive() and worker.pid != os.getpid(), f"worker pid {worker.pid} answered")
    check(result.settings["workers"] == 2 and result.settings["processes"] == 2, "the second process scored particles")
    check(not result.notes, "no note on the processes")
    check(os.path.dirname(os.path.dirname(os.path.abspath(cmmsampling.__file__))) != os.getcwd(),
          "the package is not imported from the current folder")
    return result


def document_round_trip(cmmsampling, result, folder):
    """Add to a document, save, reopen, export the reopened points."""
    import FreeCAD

    doc = FreeCAD.newDocument("Installed")
    group = cmmsampling.add_to_document(result, doc)
    path = os.path.join(folder, "installed.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(path)
    points = [o for o in doc.Objects if o.Name.startswith("ProbePoints")]
    check(group is not None and len(points) == 1 and len(points[0].Points) == result.n, "saved and reopened")
    message = cmmsampling.export(points[0], os.path.join(folder, "installed.dmi"))
    check(os.path.getsize(os.path.join(folder, "installed.dmi")) > 0, f"exported: {str(message).splitlines()[0]}")
    message = cmmsampling.export(points[0], os.path.join(folder, "installed.qif"))
    check(len(cmmsampling.read_points(os.path.join(folder, "installed.qif"))) == result.n,
          f"exported and read back: {str(message).splitlines()[0]}")
    FreeCAD.closeDocument(doc.Name)


def without_optional_packages(cmmsampling):
    """The copy's tests/without_optional_packages.py in a new freecadcmd: lxml, distributed and
    threadpoolctl hidden, QIF and a Dask plan refused in one line, DMIS and CSV written."""
    copy = os.path.dirname(os.path.dirname(os.path.abspath(cmmsampling.__file__)))
    run = subprocess.run(["freecadcmd", os.path.join(copy, "tests", "without_optional_packages.py")],
                         capture_output=True, text=True, timeout=300)
    output = run.stdout + run.stderr
    check(run.returncode == 0 and "without optional packages: passed" in output,
          f"without lxml, distributed and threadpoolctl: {output[-2000:] if run.returncode else 'QIF refused'}")


def worker_killed_mid_run(cmmsampling, parallel, face, expected):
    """SIGKILL to the worker during a run: the same points, a note, and this process alive."""

    def kill_at_iteration(iteration, best):
        worker = parallel.shared_worker()[0]
        if iteration == 10 and worker is not None:
            os.kill(worker.pid, signal.SIGKILL)
        return False

    result = cmmsampling.sample(cmmsampling.reference_face(), 25, "pso", iterations=40, grid=30,
                                progress=kill_at_iteration)
    check((result.uv == expected.uv).all(), "the same points after the worker was killed")
    check(any("killed by signal 9" in note for note in result.notes), f"note: {result.notes}")


def worker_cannot_import(cmmsampling, parallel, expected, folder):
    """A worker started where the package is not: the same points and a note naming the error."""
    parallel.shared_worker()[0].close()
    real = parallel.package_parent
    parallel.package_parent = lambda: folder
    try:
        result = cmmsampling.sample(cmmsampling.reference_face(), 25, "pso", iterations=40, grid=30)
    finally:
        parallel.package_parent = real
    check((result.uv == expected.uv).all(), "the same points without the worker")
    check(any("ModuleNotFoundError" in note for note in result.notes), f"note: {result.notes}")


def plan_on_two_processes(cmmsampling):
    import Part

    plan = cmmsampling.plan(Part.makeBox(50, 40, 30), n_total=32, faces=[1, 2], strategy="halton", processes=2)
    check(len(plan.placed) == 2 and not plan.notes, f"2-face plan on 2 processes: {plan.n_total} points")


def main():
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    import cmmsampling
    from cmmsampling.runtime import parallel

    face = cmmsampling.reference_face()
    with tempfile.TemporaryDirectory() as folder:
        result = sample_on_two_processes(cmmsampling, parallel, face)
        document_round_trip(cmmsampling, result, folder)
        worker_killed_mid_run(cmmsampling, parallel, face, result)
        worker_cannot_import(cmmsampling, parallel, result, folder)
        plan_on_two_processes(cmmsampling)
    without_optional_packages(cmmsampling)
    print("smoke run passed", flush=True)


try:
    main()
except BaseException:
    traceback.print_exc()
    sys.stdout.flush()
    os._exit(1)
