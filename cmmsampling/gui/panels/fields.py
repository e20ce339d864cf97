"""The panels' fields: the values they show by the API's argument names (:class:`Fields`), the
choices and "auto" spin boxes they share, and the arguments made from them."""
from PySide import QtCore, QtGui

from ...access.probe import PROBES

# The value shown as "auto" (the spin box's minimum) of the minimum spacing (sample's
# min_spacing=None) and of the edge offset (cmmsampling.probe_edge_offset of the face).
AUTO = -0.5


def spacing_argument(value):
    """sample()'s min_spacing (mm) for the panel's value: None ("auto") below zero."""
    return None if value < 0 else value


def edge_offset_argument(value, automatic):
    """sample()'s edge_offset (mm) for the panel's value: ``automatic`` (the face's probe edge
    offset, mm) below zero ("auto")."""
    return automatic if value < 0 else value


def detached(arguments):
    """sample()'s arguments for a worker thread: the part (part=) copied, so that the thread never
    shares the document's shape (OCC meshes it while testing the probe's reach)."""
    return {**arguments, **({"part": arguments["part"].copy()} if "part" in arguments else {})}


def add_choice(choice, name, label, tip):
    """Add an entry showing ``label`` that holds ``name``, with the tooltip ``tip``."""
    choice.addItem(label, name)
    choice.setItemData(choice.count() - 1, tip, QtCore.Qt.ToolTipRole)


def add_checkable(listing, text, data, tip):
    """Add an unchecked line showing ``text`` to the QListWidget ``listing``, holding ``data``
    (its UserRole), with the tooltip ``tip``; returns the item."""
    item = QtGui.QListWidgetItem(text, listing)
    item.setData(QtCore.Qt.UserRole, data)
    item.setFlags(item.flags() | QtCore.Qt.ItemIsUserCheckable)
    item.setCheckState(QtCore.Qt.Unchecked)
    item.setToolTip(tip)
    return item


def add_inspections(listing, objects, empty):
    """A checkable line per measured-points object of objects (its group's label, its label and
    point count; tooltip: its measured file) in the QListWidget ``listing``, holding its Name;
    the line ``empty`` (not checkable) where there is none."""
    for obj in objects:
        group = obj.getParentGroup()
        where = f"{group.Label}: " if group is not None else ""
        add_checkable(listing, f"{where}{obj.Label} ({len(obj.Labels)} points)", obj.Name,
                      obj.MeasuredFile or obj.Label)
    if not objects:
        QtGui.QListWidgetItem(empty, listing)


def checked_data(listing):
    """The data of the checked lines of the QListWidget ``listing``, in its order."""
    items = (listing.item(row) for row in range(listing.count()))
    return [item.data(QtCore.Qt.UserRole) for item in items if item.checkState() == QtCore.Qt.Checked]


def head_steps(probe):
    """How the probe's head turns, in words: "in 7.5 deg steps", or "continuously"."""
    return "continuously" if probe.index_step is None else f"in {probe.index_step:g} deg steps"


def probe_choice(parent, none_tip, outcome, tip):
    """A choice of the probe whose reach is judged (object name "probe"): "not judged" (tooltip
    ``none_tip``) or a preset of cmmsampling.PROBES, each entry holding its name (tooltip: what it
    reaches, then ``outcome``); ``tip``: the choice's own tooltip."""
    choice = QtGui.QComboBox(parent)
    choice.setObjectName("probe")
    add_choice(choice, "", "not judged", none_tip)
    for name, probe in PROBES.items():
        add_choice(choice, name, name, f"Keep to what this probe reaches on the part, stylus tilted up to "
                   f"{probe.max_tilt:g} deg {head_steps(probe)}; {outcome}")
    choice.setToolTip(tip)
    return choice


def snap_to_auto(widget, value):
    """Show a negative value, which means automatic, as "auto" (the widget's minimum)."""
    if AUTO < value < 0:
        widget.setValue(AUTO)


class Fields:
    """A panel's values by the API's argument names, read from and shown in its widgets.

    widgets: {name: widget}; a check box or radio button holds a bool, a pair of radio buttons
    (yes, no) a bool too, a spin box its number, a choice the name its entry holds (not the label
    it shows), a line edit its text.
    """

    def __init__(self, widgets):
        self.widgets = dict(widgets)

    def values(self):
        """{name: value} of every field, in the order they were given."""
        return {name: read_field(widget) for name, widget in self.widgets.items()}

    def show(self, values):
        """Show values by name; names without a field and choices without that entry are ignored."""
        for name, value in values.items():
            if name in self.widgets:
                show_field(self.widgets[name], value)


def read_field(widget):
    """The value a field holds (see :class:`Fields`)."""
    if isinstance(widget, tuple):
        return widget[0].isChecked()
    if isinstance(widget, QtGui.QAbstractButton):
        return widget.isChecked()
    if isinstance(widget, QtGui.QComboBox):
        return widget.currentData()
    if isinstance(widget, QtGui.QLineEdit):
        return widget.text()
    return widget.value()


def show_field(widget, value):
    """Show a value in a field (see :class:`Fields`)."""
    if isinstance(widget, tuple):
        widget[0 if value else 1].setChecked(True)
    elif isinstance(widget, QtGui.QAbstractButton):
        widget.setChecked(bool(value))
    elif isinstance(widget, QtGui.QComboBox):
        index = widget.findData(str(value))
        if index >= 0:
            widget.setCurrentIndex(index)
    elif isinstance(widget, QtGui.QLineEdit):
        widget.setText(str(value))
        widget.setCursorPosition(0)
    else:
        widget.setValue(value)
