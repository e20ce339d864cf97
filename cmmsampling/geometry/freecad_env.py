"""Make FreeCAD's Python modules importable from a plain ``/usr/bin/python3``.

Inside FreeCAD (GUI, console or ``freecadcmd``) the modules are already on ``sys.path``;
from Debian's Python they live in FreeCAD's lib folder. :func:`prepare_freecad` (run when the
package is imported) extends ``sys.path`` and imports FreeCAD itself, about 0.06 s: importing
Part before FreeCAD crashes the interpreter. :func:`import_part` imports Part.

Imported that way, FreeCAD takes its home from the real path of FreeCAD.so
(``/usr/lib/freecad-python3/``), which has no ``Mod`` folder, so the Python halves of its built-in
modules are not found (``freecadcmd``'s home, ``/usr/lib/freecad/``, has them). FreeCAD 1.0 and
1.1's ``Part.makeCompound`` imports Part's ``PartEnums`` and crashes when it is missing (FreeCAD's
SIGSEGV handler then ends the process with exit code 1, silently): :func:`add_module_folders`
puts those folders on ``sys.path`` as FreeCAD's own start-up does.
"""
from __future__ import annotations

import importlib
import importlib.util
import os
import sys
from typing import Any

FREECAD_LIB_DIRS = ("/usr/lib/freecad-python3/lib", "/usr/lib/freecad/lib")


def add_freecad_path() -> None:
    """Append FreeCAD's lib folder to sys.path where FreeCAD is not importable already."""
    if importlib.util.find_spec("FreeCAD") is not None:
        return
    for folder in FREECAD_LIB_DIRS:
        if os.path.isdir(folder) and folder not in sys.path:
            sys.path.append(folder)


def add_module_folders(freecad: Any) -> None:
    """Append the folders of FreeCAD's built-in modules (``<resources>/Mod/<name>``) to sys.path
    where FreeCAD's home has no Mod folder (FreeCAD imported from a plain Python)."""
    if os.path.isdir(os.path.join(freecad.getHomePath(), "Mod")):
        return
    modules = os.path.join(freecad.getResourceDir(), "Mod")
    if not os.path.isdir(modules):
        return
    for name in sorted(os.listdir(modules)):
        folder = os.path.join(modules, name)
        if os.path.isdir(folder) and folder not in sys.path:
            sys.path.append(folder)


def import_freecad() -> Any:
    """Import FreeCAD (its lib folder and module folders on sys.path) and return it."""
    add_freecad_path()
    freecad = importlib.import_module("FreeCAD")
    add_module_folders(freecad)
    return freecad


def prepare_freecad() -> None:
    """Import FreeCAD with its folders on sys.path, where it is installed."""
    try:
        import_freecad()
    except ImportError:
        pass


def import_part() -> Any:
    """Return FreeCAD's ``Part`` module; ImportError naming the folders tried when it is missing."""
    try:
        import_freecad()
        return importlib.import_module("Part")
    except ImportError as exc:
        raise ImportError(
            "cmmsampling needs FreeCAD's Part module; install Debian's 'freecad' package "
            f"(looked in {', '.join(FREECAD_LIB_DIRS)})"
        ) from exc
