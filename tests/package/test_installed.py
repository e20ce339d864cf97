"""The workbench as a user installs it: linked into FreeCAD's user Mod folder of a temporary HOME,
FreeCAD started from a folder outside the checkout (tests/installed_smoke.py)."""
import os
import subprocess

from support.paths import ROOT, TESTS


def installed_home(home):
    """Link the checkout into the Mod folder FreeCAD names for a new user of ``home``; the
    environment to run FreeCAD with."""
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH",)}
    env.update(HOME=str(home), XDG_DATA_HOME=str(home / ".local" / "share"), XDG_CONFIG_HOME=str(home / ".config"))
    data = subprocess.run(["freecadcmd", "-c", "import FreeCAD; print(FreeCAD.getUserAppDataDir())"], env=env,
                          cwd=str(home), capture_output=True, text=True, timeout=120).stdout.strip().splitlines()[-1]
    mods = os.path.join(data, "Mod")
    os.makedirs(mods, exist_ok=True)
    os.symlink(ROOT, os.path.join(mods, "cmmsampling"))
    return env


def test_a_session_run_as_installed_from_another_folder(tmp_path):
    """PSO on two processes, document, export, a killed worker, a worker that cannot import and a
    2-face plan: FreeCAD exits with 0 and every step says ok."""
    home = tmp_path / "home"
    home.mkdir()
    env = installed_home(home)
    work = tmp_path / "elsewhere"
    work.mkdir()
    run = subprocess.run(["freecadcmd", os.path.join(TESTS, "installed_smoke.py")], env=env, cwd=str(work),
                         capture_output=True, text=True, timeout=600)
    output = run.stdout + run.stderr
    assert run.returncode == 0, output[-3000:]
    assert "smoke run passed" in output, output[-3000:]
    assert output.count("\nok ") >= 10, output[-3000:]
