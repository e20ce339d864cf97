"""How long FreeCAD's GUI takes to reopen a document of this workbench's results, and how long it
stays frozen meanwhile.

The document holds a sampled face (the reference face, 81 Halton points), a 4-face plan of the
datum block with the probe's reach (64 points) and an inspection of that plan's simulated
measurement: 28 objects with 5 coloured substitutes. It is made and saved in a FreeCAD GUI under
Xvfb, closed, and opened again there: the time until ``openDocument`` returns, the time until the
event loop is idle again (each substitute coloured once the document has loaded), the longest
gap of a 50 ms heartbeat timer over both (the freeze a user sees) and how many colour meshes were
tessellated. Before the colour meshes were cached and drawn once after loading, the same kind of
document froze FreeCAD 36 to 41 s.
Run: /usr/bin/python3 benchmarks/reopen.py   (needs xvfb-run and the freecad GUI)
"""
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GUI_SCRIPT = r"""
import json, os, sys, time
sys.path.insert(0, os.environ["CMM_ROOT"])
import FreeCAD, FreeCADGui
from PySide import QtCore, QtGui
import cmmsampling
from cmmsampling.geometry.blocks import datum_block
from cmmsampling.document.object_types import is_substitute_surface
from cmmsampling.gui import view_providers


def settle(seconds):
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        QtGui.QApplication.processEvents()
        time.sleep(0.01)


def make(path):
    doc = FreeCAD.newDocument("Reopen")
    face = doc.addObject("Part::Feature", "Face")
    face.Shape = cmmsampling.reference_face()
    block = doc.addObject("Part::Feature", "Block")
    block.Shape = datum_block()
    doc.recompute()
    sampled = cmmsampling.sample(face.Shape.Faces[0], 81, "halton", occ_check=False)
    cmmsampling.add_to_document(sampled, doc, source=(face, "Face1"), hide_others=False)
    plan = cmmsampling.plan(block.Shape, n_total=64, strategy="uniform_parametric", faces=[3, 2, 4, 6],
                            probe=cmmsampling.Probe(), processes=1)
    group = cmmsampling.add_plan_to_document(plan, doc, block, hide_others=False)
    measured = os.path.join(os.path.dirname(path), "measured.csv")
    cmmsampling.simulate_measurement(group, measured, form_error=0.02, noise=0.001, seed=7)
    inspection = cmmsampling.inspect(group, measured, tolerance=0.05)
    cmmsampling.add_inspection_to_document(inspection, doc, source=group)
    settle(1.0)
    count = len(doc.Objects)
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    settle(0.5)
    return count


def reopen(path):
    tessellated = []
    original = view_providers.face_tessellation
    view_providers.face_tessellation = lambda face: tessellated.append(1) or original(face)
    beats = []
    heart = QtCore.QTimer()
    heart.timeout.connect(lambda: beats.append(time.perf_counter()))
    heart.start(50)
    started = time.perf_counter()
    beats.append(started)
    doc = FreeCAD.openDocument(path)
    opened = time.perf_counter() - started
    settle(3.0)
    heart.stop()
    gaps = [b - a for a, b in zip(beats[:-1], beats[1:])]
    substitutes = sum(1 for obj in doc.Objects if is_substitute_surface(obj))
    FreeCAD.closeDocument(doc.Name)
    settle(0.5)
    return {"open_s": opened, "freeze_s": max(gaps), "tessellations": len(tessellated), "substitutes": substitutes}


out = os.environ["CMM_OUT"]
try:
    path = os.path.join(os.path.dirname(out), "reopen.FCStd")
    figures = {"objects": make(path)}
    figures.update(reopen(path))
    figures.update({"again_" + key: value for key, value in reopen(path).items()})
except Exception as exc:
    import traceback
    figures = {"error": traceback.format_exc()}
with open(out, "w") as handle:
    json.dump(figures, handle)
QtCore.QTimer.singleShot(0, FreeCADGui.getMainWindow().close)
"""


def main():
    with tempfile.TemporaryDirectory() as folder:
        script, out = os.path.join(folder, "reopen_gui.py"), os.path.join(folder, "figures.json")
        with open(script, "w") as handle:
            handle.write(GUI_SCRIPT)
        env = dict(os.environ, CMM_ROOT=ROOT, CMM_OUT=out, HOME=folder, QTWEBENGINE_DISABLE_SANDBOX="1")
        ran = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "freecad", script], env=env,
                             capture_output=True, text=True, timeout=900, check=False, cwd=folder)
        if not os.path.isfile(out):
            sys.exit(f"FreeCAD wrote no figures (exit {ran.returncode}):\n{ran.stdout[-2000:]}\n{ran.stderr[-2000:]}")
        with open(out) as handle:
            figures = json.load(handle)
    if "error" in figures:
        sys.exit(figures["error"])
    for run in ("", "again_"):
        print(f"{'second ' if run else ''}reopen of a document of {figures['objects']} objects: openDocument "
              f"returned in {figures[run + 'open_s']:.2f} s; the GUI's longest freeze {figures[run + 'freeze_s']:.2f} s; "
              f"{figures[run + 'tessellations']} colour meshes tessellated for {figures[run + 'substitutes']} "
              "substitutes")


if __name__ == "__main__":
    main()
