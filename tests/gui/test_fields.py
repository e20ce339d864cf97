"""The panels' binder between widgets and the API's argument names (gui/panels/fields.py)."""
from PySide import QtGui

from cmmsampling.gui.panels.fields import Fields, add_choice


def make_fields(parent):
    yes, no = QtGui.QRadioButton(parent), QtGui.QRadioButton(parent)
    choice = QtGui.QComboBox(parent)
    add_choice(choice, "pso", "PSO", "the swarm")
    add_choice(choice, "halton", "Halton", "a sequence")
    count = QtGui.QSpinBox(parent)
    count.setRange(0, 1000)
    offset = QtGui.QDoubleSpinBox(parent)
    offset.setRange(-1.0, 10.0)
    fields = Fields({"by_tolerance": (yes, no), "strategy": choice, "n": count, "edge_offset": offset,
                     "auto_poles": QtGui.QCheckBox(parent), "ns": QtGui.QLineEdit(parent)})
    return fields, choice


def test_fields_read_back_what_they_show_by_argument_name():
    parent = QtGui.QWidget()
    fields, choice = make_fields(parent)
    values = {"by_tolerance": False, "strategy": "halton", "n": 49, "edge_offset": 1.5, "auto_poles": True,
              "ns": "25, 49"}
    fields.show(values)
    assert fields.values() == values and choice.currentText() == "Halton"
    fields.show({"by_tolerance": True, "n": 81})
    assert fields.values() == {**values, "by_tolerance": True, "n": 81}


def test_fields_ignore_unknown_names_and_choices():
    parent = QtGui.QWidget()
    fields, _ = make_fields(parent)
    fields.show({"strategy": "halton"})
    fields.show({"strategy": "spiral", "no_such_field": 3})
    assert fields.values()["strategy"] == "halton" and "no_such_field" not in fields.values()
