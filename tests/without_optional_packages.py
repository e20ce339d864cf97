"""A user's session where FreeCAD's Python lacks the optional packages (lxml, distributed,
threadpoolctl), hidden before cmmsampling is imported: what needs them is refused in one line that
names the package and how to install it, before any file is read or written; everything else
works.

Run by tests/package/test_optional_packages.py (``python3 without_optional_packages.py``, the
checkout on PYTHONPATH) and, on an Addon Manager copy, by tests/installed_smoke.py
(``freecadcmd``). Each check prints one line starting with "ok"; any failure raises, and the
process exits with 1.
"""
import importlib
import importlib.abc
import os
import sys
import tempfile
import traceback

HIDDEN = ("lxml", "distributed", "threadpoolctl")


class Hidden(importlib.abc.MetaPathFinder):
    """Finds the HIDDEN packages nowhere, as a Python without them does."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in HIDDEN:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


def hide():
    """Hide the packages, also where FreeCAD's start-up imported one."""
    for name in [name for name in sys.modules if name.split(".")[0] in HIDDEN]:
        del sys.modules[name]
    sys.meta_path.insert(0, Hidden())


def check(condition, what):
    """Print "ok <what>", or raise AssertionError naming it."""
    if not condition:
        raise AssertionError(what)
    print(f"ok {what}", flush=True)


def refused(call, package, apt, addon_manager=True):
    """The one-line message of the MissingPackage ``call()`` raises, checked to name the package,
    the apt package and, where it installs the package, the Addon Manager."""
    from cmmsampling.runtime.packages import MissingPackage

    try:
        call()
    except MissingPackage as exc:
        message = str(exc)
    else:
        raise AssertionError(f"{call} was not refused without {package}")
    check("\n" not in message and f"Python package {package}," in message
          and ("Addon Manager" in message) == addon_manager and f"apt install {apt}" in message,
          f"refused in one line: {message}")
    return message


def qif_refused(cmmsampling, result, folder):
    """QIF written, read, inspected and opened as an MBD model: refused, no file left."""
    target = os.path.join(folder, "plan.qif")
    message = refused(lambda: cmmsampling.export(result, target), "lxml", "python3-lxml")
    check(message.startswith("QIF 3.0 files need") and "DMIS" in message and "CSV" in message,
          "the refusal names what works without lxml")
    check(not os.listdir(folder), "nothing written")
    with open(target, "w", encoding="utf-8") as handle:
        handle.write("<QIFDocument/>\n")
    refused(lambda: cmmsampling.read_points(target), "lxml", "python3-lxml")
    refused(lambda: cmmsampling.inspect(result, target, tolerance=0.1), "lxml", "python3-lxml")
    refused(lambda: cmmsampling.read_mbd(target), "lxml", "python3-lxml")
    refused(lambda: cmmsampling.read_record(target), "lxml", "python3-lxml")
    os.remove(target)


def others_work(cmmsampling, result, folder):
    """DMIS and CSV written and read back, and measured points inspected, without lxml."""
    for name in ("plan.dmi", "plan.csv"):
        path = os.path.join(folder, name)
        report = cmmsampling.export(result, path)
        check(len(cmmsampling.read_points(path)) == result.n, f"{str(report).splitlines()[0]} Read back.")
    measured = os.path.join(folder, "measured.csv")
    cmmsampling.simulate_measurement(result, measured, form_error=0.01)
    found = cmmsampling.inspect(result, measured, tolerance=0.1)
    check(len(found.deviations) == result.n, f"inspected: {found.summary().splitlines()[0]}")


def dask_refused(cmmsampling):
    """A plan on a Dask cluster, without distributed: refused before any face is run."""
    import Part

    box = Part.makeBox(20, 20, 10)
    message = refused(lambda: cmmsampling.plan(box, n_total=20, scheduler="tcp://127.0.0.1:9"), "distributed",
                      "python3-distributed", addon_manager=False)
    check(message.startswith("Plans on a Dask cluster"), "the plan's refusal names the Dask cluster")


def main():
    hide()
    import cmmsampling
    from cmmsampling.runtime.threads import blas_description

    try:
        importlib.import_module("lxml")
        importable = True
    except ImportError:
        importable = False
    check(not importable, "lxml cannot be imported")
    result = cmmsampling.sample(cmmsampling.reference_face(), 16, "halton")
    check(result.n == 16 and blas_description() == "unknown", "sampled without threadpoolctl")
    with tempfile.TemporaryDirectory() as folder:
        qif_refused(cmmsampling, result, folder)
        others_work(cmmsampling, result, folder)
    dask_refused(cmmsampling)
    check(not [name for name in sys.modules if name.split(".")[0] in HIDDEN], "no hidden package was loaded")
    print("without optional packages: passed", flush=True)


try:
    main()
except BaseException:   # any failure ends the run with 1, also under freecadcmd
    traceback.print_exc()
    sys.stdout.flush()
    os._exit(1)
sys.stdout.flush()
os._exit(0)
