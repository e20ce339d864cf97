"""FreeCAD imported from a plain Python (the README's ``/usr/bin/python3`` route)."""
import subprocess
import sys

from support.paths import ROOT

COMPOUND = """
import sys
sys.path.insert(0, sys.argv[1])
import cmmsampling
import PartEnums
import FreeCAD, Part
compound = Part.makeCompound([Part.Vertex(FreeCAD.Vector(1, 2, 3)), Part.Vertex(FreeCAD.Vector(4, 5, 6))])
print(len(compound.Vertexes))
"""


def test_part_finds_its_python_half_and_makes_compounds():
    """FreeCAD 1.x's Part.makeCompound imports Part's PartEnums and crashes the process (exit code
    1, no message) when FreeCAD's module folders are not on sys.path; importing cmmsampling puts
    them there. Run in a fresh interpreter: a crash must fail this test, not end the run."""
    run = subprocess.run([sys.executable, "-c", COMPOUND, ROOT], capture_output=True, text=True,
                         timeout=120)
    assert (run.returncode, run.stdout.strip()) == (0, "2"), run.stderr
