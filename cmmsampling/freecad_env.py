"""Make FreeCAD's Python modules importable from a plain ``/usr/bin/python3``.

Inside FreeCAD (GUI, console or ``freecadcmd``) the modules are already on ``sys.path``;
from Debian's Python they live in FreeCAD's lib folder, which is added once here.
"""
import importlib
import os
import sys

FREECAD_LIB_DIRS = ("/usr/lib/freecad-python3/lib", "/usr/lib/freecad/lib")


def import_part():
    """Return FreeCAD's ``Part`` module, adding FreeCAD's lib folder to ``sys.path`` if needed.

    Raises ImportError with the folders tried when FreeCAD is not installed.
    """
    try:
        return importlib.import_module("Part")
    except ImportError:
        for folder in FREECAD_LIB_DIRS:
            if os.path.isdir(folder) and folder not in sys.path:
                sys.path.append(folder)
        try:
            importlib.import_module("FreeCAD")
            return importlib.import_module("Part")
        except ImportError as exc:
            raise ImportError(
                "cmmsampling needs FreeCAD's Part module; install Debian's 'freecad' package "
                f"(looked in {', '.join(FREECAD_LIB_DIRS)})"
            ) from exc
