"""What differs between the Qt bindings of the FreeCAD versions the workbench runs on.

FreeCAD 0.20 and 1.0 use PySide2, FreeCAD 1.1 PySide6 (both through FreeCAD's ``PySide``
module). PySide6 turns Qt's enums and flags into Python enums, which ``int()`` refuses, and
names ``QDialog.exec_`` ``exec`` (``exec_`` is deprecated there; PySide2 has only ``exec_``).
"""


def flag_value(flags):
    """The integer of a Qt enum value or flag combination, e.g. ``QDialogButtonBox.Ok |
    QDialogButtonBox.Cancel``, under PySide2 (``int()``) and PySide6 (``.value``)."""
    return int(getattr(flags, "value", flags))


def run_modal(dialog):
    """Show ``dialog`` modally and return its result code (``exec`` or, in PySide2, ``exec_``)."""
    run = getattr(dialog, "exec", None) or dialog.exec_
    return run()

