"""Install the workbench with FreeCAD's Addon Manager from a git URL, then check that FreeCAD loads it.

Run inside FreeCAD 1.0 or 1.1 by scripts/test-matrix.sh (in its Debian roots)::

    HOME=<empty folder> CMMSAMPLING_REMOTE=<folder> freecadcmd tests/addon_manager_install.py

CMMSAMPLING_REMOTE holds ``cmmsampling``, a bare clone with branch ``main`` prepared for git's
plain HTTP transport, and the branch's zip archive where a git host keeps it. The folder is served
on 127.0.0.1 and the add-on installed the way the Addon Manager installs a custom repository
``http://127.0.0.1:<port>/cmmsampling`` with branch ``main``: FreeCAD 1.0 clones it with git, 1.1
downloads the zip archive (it uses git only for add-ons named in its ``force_git_in_repos``
preference). The installer is given the allow-list of Python packages this FreeCAD ships (its
fetch of the newest one from GitHub is skipped: CI may have no internet). Exit code 0 when the
add-on was installed into the user's Mod folder, its package.xml gives the Python dependencies
numpy, scipy, matplotlib and lxml (all on the allow-list) and the optional threadpoolctl and
distributed, none of them is missing,
a new ``freecadcmd``, started in the temporary folder, loads the installed copy (its Init.py
registers the DMIS export), and the copy's tests/installed_smoke.py passes there (a PSO whose
second process takes part, a document exported as DMIS and QIF, a killed worker, a 2-face plan,
and with lxml hidden QIF refused in one line and DMIS written).
"""
import functools
import http.server
import os
import subprocess
import sys
import tempfile
import threading

import addonmanager_installer
import FreeCAD
from Addon import Addon, MissingDependencies
from addonmanager_installer import AddonInstaller

NAME = "cmmsampling"
BRANCH = "main"
PYTHON_DEPENDENCIES = {"numpy", "scipy", "matplotlib", "lxml"}
OPTIONAL_DEPENDENCIES = {"threadpoolctl", "distributed"}
LOAD_CHECK = """
import os, FreeCAD, cmmsampling
print(os.path.dirname(os.path.dirname(os.path.abspath(cmmsampling.__file__))))
print("cmmsampling.document" in FreeCAD.getExportType("dmi"))
"""


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def serve(folder):
    """Serve ``folder`` on 127.0.0.1 in a daemon thread; returns the base URL."""
    server = http.server.ThreadingHTTPServer(
        ("127.0.0.1", 0), functools.partial(QuietHandler, directory=folder))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f"http://127.0.0.1:{server.server_address[1]}"


def allow_list():
    """The Python packages this FreeCAD's Addon Manager installs (its own ALLOWED_PYTHON_PACKAGES.txt)."""
    path = os.path.join(os.path.dirname(addonmanager_installer.__file__), "ALLOWED_PYTHON_PACKAGES.txt")
    with open(path, encoding="utf-8") as handle:
        return sorted({line.strip().lower() for line in handle if line.strip() and not line.startswith("#")})


def install(url):
    """Install the add-on at ``url`` as the Addon Manager does; (addon, mod folder, errors)."""
    addon = Addon(NAME, url, Addon.Status.NOT_INSTALLED, BRANCH)
    installer = AddonInstaller(addon, allow_list=allow_list())
    errors = []
    installer.failure.connect(lambda _, message: errors.append(message))
    if not installer.run():
        errors.append("AddonInstaller.run() returned False")
    return addon, installer.installation_path, errors


def missing_python_packages(addon):
    """The required Python packages the Addon Manager finds missing (1.0 and 1.1 APIs)."""
    if hasattr(MissingDependencies, "import_from_addon"):
        missing = MissingDependencies()
        missing.import_from_addon(addon, [addon])
    else:
        missing = MissingDependencies(addon, [addon])
    return missing.python_requires


def loaded_copy():
    """(folder of the cmmsampling that a new freecadcmd imports, whether Init.py ran)."""
    run = subprocess.run(["freecadcmd", "-c", LOAD_CHECK], capture_output=True, text=True,
                         cwd=tempfile.gettempdir(), timeout=120)
    lines = run.stdout.strip().splitlines()
    if run.returncode != 0 or len(lines) < 2:
        return None, f"freecadcmd failed ({run.returncode}): {run.stdout} {run.stderr}"
    return lines[-2], lines[-1] == "True"


def smoke_run(target):
    """The installed copy's own tests/installed_smoke.py in a new freecadcmd, started in the
    temporary folder: PSO on 2 processes, a document, a killed worker, a 2-face plan. A problem
    in words, or None."""
    run = subprocess.run(["freecadcmd", os.path.join(target, "tests", "installed_smoke.py")], capture_output=True,
                         text=True, cwd=tempfile.gettempdir(), timeout=600)
    if run.returncode != 0 or "smoke run passed" not in run.stdout:
        return f"the installed copy's smoke run failed ({run.returncode}): {(run.stdout + run.stderr)[-2000:]}"
    print("".join(line[:160] + "\n" for line in run.stdout.splitlines() if line.startswith("ok ")), end="")
    return None


def check():
    """The problems found, [] when the installation works."""
    url = f"{serve(os.environ['CMMSAMPLING_REMOTE'])}/{NAME}"
    addon, mod_dir, problems = install(url)
    target = os.path.join(mod_dir, NAME)
    for name in ("package.xml", "Init.py", "InitGui.py", os.path.join(NAME, "__init__.py")):
        if not os.path.isfile(os.path.join(target, name)):
            problems.append(f"{name} is missing in {target}")
    if addon.python_requires != PYTHON_DEPENDENCIES or addon.python_optional != OPTIONAL_DEPENDENCIES:
        problems.append(f"package.xml's Python dependencies read as {sorted(addon.python_requires)}, optional "
                        f"{sorted(addon.python_optional)}")
    if not PYTHON_DEPENDENCIES <= set(allow_list()):
        problems.append(f"the Addon Manager does not install {sorted(PYTHON_DEPENDENCIES - set(allow_list()))}")
    if missing_python_packages(addon):
        problems.append(f"the Addon Manager finds {missing_python_packages(addon)} missing")
    folder, init_ran = loaded_copy()
    if folder != target or init_ran is not True:
        problems.append(f"a new freecadcmd loads {folder} (expected {target}), Init.py ran: {init_ran}")
    smoke = smoke_run(target)
    if smoke:
        problems.append(smoke)
    how = "git clone" if os.path.isdir(os.path.join(target, ".git")) else "zip archive"
    print(f"FreeCAD {'.'.join(FreeCAD.Version()[:3])}: installed {url} (branch {BRANCH}) by "
          f"{how} into {target}")
    return problems


def main():
    try:
        problems = check()
    except Exception as exc:  # any failure of the Addon Manager's code is a failed check
        problems = [f"{type(exc).__name__}: {exc}"]
    for problem in problems:
        print(f"FAILED: {problem}")
    print("Addon Manager installation: " + ("FAILED" if problems else "OK"))
    sys.stdout.flush()
    os._exit(1 if problems else 0)


main()
