"""What differs between the Qt bindings of the FreeCAD versions the workbench runs on, and a
guard against PySide handing out the wrapper of a deleted widget; and what the dialogs share (asked,
browse_row).

FreeCAD 0.20 and 1.0 use PySide2, FreeCAD 1.1 PySide6 (both through FreeCAD's ``PySide``
module). PySide6 turns Qt's enums and flags into Python enums, which ``int()`` refuses, and
names ``QDialog.exec_`` ``exec`` (``exec_`` is deprecated there; PySide2 has only ``exec_``).
"""
import functools
import importlib

from PySide import QtCore, QtGui


def flag_value(flags):
    """The integer of a Qt enum value or flag combination, e.g. ``QDialogButtonBox.Ok |
    QDialogButtonBox.Cancel``, under PySide2 (``int()``) and PySide6 (``.value``)."""
    return int(getattr(flags, "value", flags))


def run_modal(dialog):
    """Show ``dialog`` modally and return its result code (``exec`` or, in PySide2, ``exec_``)."""
    run = getattr(dialog, "exec", None) or dialog.exec_
    return run()


def asked(dialog, answer):
    """Run ``dialog`` modally; when accepted, save its ``stored()`` values for the next use
    (cmmsampling.document.settings) and return ``answer(dialog)``, else None. The dialog is
    deleted either way."""
    from ..document import settings

    try:
        if run_modal(dialog) != QtGui.QDialog.Accepted:
            return None
        settings.save(dialog.stored())
        return answer(dialog)
    finally:
        dialog.deleteLater()


def browse_row(dialog, field, tip=""):
    """A row of a dialog's form: the path ``field`` (a QLineEdit) and a *Browse...* button (object
    name "browse", tooltip ``tip``) that calls ``dialog.browse()``. Returns the row's layout."""
    browse = QtGui.QPushButton("Browse...", dialog)
    browse.setObjectName("browse")
    if tip:
        browse.setToolTip(tip)
    browse.clicked.connect(dialog.browse)
    row = QtGui.QHBoxLayout()
    row.addWidget(field)
    row.addWidget(browse)
    return row


def shiboken():
    """The shiboken module of the PySide that FreeCAD uses (shiboken2 or shiboken6)."""
    binding = QtCore.QObject.__module__.split(".")[0]
    return importlib.import_module("shiboken" + binding[len("PySide"):])


def forget_when_destroyed(widget):
    """Invalidate PySide's wrapper of ``widget`` and of its children when Qt deletes the widget.

    FreeCAD deletes a task panel's form and its button box in C++ when the panel closes. On
    FreeCAD 1.0 and 1.1 PySide's wrapper of the form stays alive and valid after that (held by a
    reference Python's garbage collector cannot see; 0.20 invalidates it). Until it is
    invalidated PySide hands such a wrapper, of the old class and with the old children as
    attributes, to a new widget made at the same address: on 1.0 the next panel's
    ``form.strategy`` was then a deleted QComboBox, or a QWidget.
    """
    widget.destroyed.connect(functools.partial(_invalidate, widget))


def _invalidate(widget, *_):
    """Invalidate the wrapper of a widget being deleted (shiboken does its children's too)."""
    shiboken().invalidate(widget)
