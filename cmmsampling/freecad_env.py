"""Make FreeCAD's Python modules importable from a plain ``/usr/bin/python3``.

Inside FreeCAD (GUI, console or ``freecadcmd``) the modules are already on ``sys.path``;
from Debian's Python they live in FreeCAD's lib folder. :func:`prepare_freecad` (run when the
package is imported) extends ``sys.path`` and imports FreeCAD itself, about 0.06 s: importing
Part before FreeCAD crashes the interpreter. :func:`import_part` imports Part.
"""
import importlib
import importlib.util
import os
import sys

FREECAD_LIB_DIRS = ("/usr/lib/freecad-python3/lib", "/usr/lib/freecad/lib")


def add_freecad_path():
    """Append FreeCAD's lib folder to sys.path where FreeCAD is not importable already."""
    if importlib.util.find_spec("FreeCAD") is not None:
        return
    for folder in FREECAD_LIB_DIRS:
        if os.path.isdir(folder) and folder not in sys.path:
            sys.path.append(folder)


def prepare_freecad():
    """Add FreeCAD's lib folder to sys.path and import FreeCAD, where it is installed."""
    add_freecad_path()
    try:
        importlib.import_module("FreeCAD")
    except ImportError:
        pass


def import_part():
    """Return FreeCAD's ``Part`` module; ImportError naming the folders tried when it is missing."""
    add_freecad_path()
    try:
        importlib.import_module("FreeCAD")
        return importlib.import_module("Part")
    except ImportError as exc:
        raise ImportError(
            "cmmsampling needs FreeCAD's Part module; install Debian's 'freecad' package "
            f"(looked in {', '.join(FREECAD_LIB_DIRS)})"
        ) from exc
