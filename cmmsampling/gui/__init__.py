"""The FreeCAD workbench: commands, task panel, view providers and the deviation colour map.

The only part of cmmsampling that imports FreeCADGui, PySide and pivy. Importing this package
itself loads nothing from the GUI; its modules do.
"""
import os

ADDON_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def icon(name):
    """Full path of an icon in the addon's icons folder, e.g. icon('SampleFace.svg')."""
    return os.path.join(ADDON_DIR, "icons", name)


def resource(name):
    """Full path of a file in the addon's resources folder, e.g. resource('sample_face.ui')."""
    return os.path.join(ADDON_DIR, "resources", name)


def counted(count, noun):
    """'1 face', '3 faces', '2 processes': a count and its noun (English plural: + 'es' after s,
    x, ch or sh, else + 's')."""
    if count == 1:
        return f"{count} {noun}"
    return f"{count} {noun}{'es' if noun.endswith(('s', 'x', 'ch', 'sh')) else 's'}"
