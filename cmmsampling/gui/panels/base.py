"""What every task panel shares (:class:`BackgroundRunPanel`): its form and buttons, a
background run polled by one timer, the time estimate, the status line."""
import FreeCAD
import FreeCADGui
import Part
from PySide import QtCore, QtGui

from ...geometry.validation import InputError
from ...strategies import sampling
from .. import icon, resource
from ..background import BackgroundCall
from ..qt_compat import flag_value, forget_when_destroyed

POLL_MS = 100
# The time estimate is made this long after the last change of a value (it builds the problem).
TIME_DELAY_MS = 400
ERROR_STYLE = "color: #b00000;"
# Narrowest input fields (px): the panel fits the default width of the combo view.
FIELD_WIDTH = 70
CHOICE_CHARACTERS = 10


def fit_narrow_dock(form):
    """Let the form shrink to the default width of FreeCAD's combo view, which clips (it never
    scrolls sideways): input fields may be FIELD_WIDTH px narrow, choice lists CHOICE_CHARACTERS
    characters wide, and a form row wraps its field below its label when both do not fit."""
    for spin in form.findChildren(QtGui.QAbstractSpinBox):
        spin.setMinimumWidth(FIELD_WIDTH)
    for choice in form.findChildren(QtGui.QComboBox):
        choice.setSizeAdjustPolicy(QtGui.QComboBox.AdjustToMinimumContentsLengthWithIcon)
        choice.setMinimumContentsLength(CHOICE_CHARACTERS)
    for layout in form.findChildren(QtGui.QFormLayout):
        layout.setRowWrapPolicy(QtGui.QFormLayout.WrapLongRows)
    form.layout().setContentsMargins(0, 0, 0, 0)


class BackgroundRunPanel:
    """A panel for a chosen face (``self.source``: (obj, "FaceK")) whose OK starts a background
    run (``self.start()``, stored in ``self.run``): its task-dialog buttons, OK labelled OK_TEXT
    with the tooltip OK_TIP and Cancel, and the face as it is now."""

    OK_TEXT = OK_TIP = ""
    # What Cancel says while a run stops (see :meth:`reject`).
    CANCELLING = ""

    def _set_up(self, ui_file, icon_file, source):
        """Load the form and its icon, keep the face, and make the timer that polls the run."""
        self.form = FreeCADGui.PySideUic.loadUi(resource(ui_file))
        self.form.setWindowIcon(QtGui.QIcon(icon(icon_file)))
        self.source = source
        self.automatic_offset = None
        self.run = None
        self.buttons = None
        self.estimate_timer = None
        self.timer = QtCore.QTimer()
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self.poll)
        fit_narrow_dock(self.form)
        forget_when_destroyed(self.form)

    def _add_time_line(self, layout, row, tip):
        """The run's time estimate: a label (``timeInfo``) inserted at ``row`` of ``layout`` (a
        form or box layout), remade in a background thread (:class:`BackgroundCall`)
        TIME_DELAY_MS after the last change of a value: connect the values' change signals to
        ``self.estimate_timer.start``. The subclass gives :meth:`estimate_call` and
        :meth:`estimate_text`."""
        self.timeInfo = QtGui.QLabel(self.form)
        self.timeInfo.setObjectName("timeInfo")
        self.timeInfo.setWordWrap(True)
        self.timeInfo.setToolTip(tip)
        if isinstance(layout, QtGui.QFormLayout):
            layout.insertRow(row, self.timeInfo)
        else:
            layout.insertWidget(row, self.timeInfo)
        self.estimate = None
        self.estimate_timer = QtCore.QTimer()
        self.estimate_timer.setSingleShot(True)
        self.estimate_timer.setInterval(TIME_DELAY_MS)
        self.estimate_timer.timeout.connect(self.start_estimate)
        self.estimate_poll = QtCore.QTimer()
        self.estimate_poll.setInterval(POLL_MS)
        self.estimate_poll.timeout.connect(self.show_estimate)

    def estimate_call(self):
        """(function, keyword arguments) whose value is the estimate, or None for none now."""
        raise NotImplementedError

    def estimate_text(self, value):
        """The time line for the estimate's value."""
        raise NotImplementedError

    def start_estimate(self):
        """Estimate the run's time in the background (again once the one under way ends);
        nothing while a run is on or for values the run would refuse (OK says why)."""
        if self.estimate is not None and self.estimate.running:
            self.estimate_timer.start()
            return
        if self.run is not None:
            return
        try:
            call = self.estimate_call()
        except (ValueError, TypeError):
            call = None
        if call is None:
            self.timeInfo.setText("")
            return
        function, arguments = call
        self.estimate = BackgroundCall("cmmsampling-estimate", function, **arguments)
        self.estimate.start()
        self.estimate_poll.start()

    def show_estimate(self):
        """Show the finished estimate; nothing for values the run would refuse."""
        if self.estimate is None or self.estimate.running:
            return
        self.estimate_poll.stop()
        estimate, self.estimate = self.estimate, None
        self.timeInfo.setText("" if estimate.error is not None else self.estimate_text(estimate.value))

    def stop_estimates(self):
        """Stop the estimate's timers, where the panel has a time line (it closes)."""
        if self.estimate_timer is not None:
            self.estimate_timer.stop()
            self.estimate_poll.stop()

    def face_edge_offset(self):
        """The chosen face's probe edge offset (mm, cmmsampling.probe_edge_offset), measured once
        per face; 0 when the face is gone or cannot be measured (the run then says why)."""
        if self.automatic_offset is None:
            face = self.source_face()
            try:
                self.automatic_offset = sampling.probe_edge_offset(face) if face is not None else 0.0
            except (ValueError, RuntimeError, Part.OCCError):
                self.automatic_offset = 0.0
        return self.automatic_offset

    def getStandardButtons(self):
        return flag_value(QtGui.QDialogButtonBox.Ok | QtGui.QDialogButtonBox.Cancel)

    @staticmethod
    def report_failure(run):
        """Put a failed run in the Report view and return its message for the panel.

        A refused input (InputError: the engine's message names what to change) is one line,
        'Not run: <message>'; anything else, 'Type: message', comes with its traceback. The
        traceback always goes to the log.
        """
        refused = isinstance(run.error, InputError)
        message = f"Not run: {run.error}" if refused else f"{type(run.error).__name__}: {run.error}"
        if refused:
            FreeCAD.Console.PrintError(f"cmmsampling: {message}\n")
            FreeCAD.Console.PrintLog(run.details)
        else:
            FreeCAD.Console.PrintError(run.details)
        return message

    def modifyStandardButtons(self, box):
        self.buttons = box
        forget_when_destroyed(box)
        ok = box.button(QtGui.QDialogButtonBox.Ok)
        ok.setText(self.OK_TEXT)
        ok.setToolTip(self.OK_TIP)
        self.update_enabled()

    def reject(self):
        """Cancel. While a run is on: ask it to stop, say what is kept (CANCELLING) and stay open;
        the run's finished part is taken when it has stopped. Otherwise close."""
        if self.run is not None:
            self.run.cancel()
            self.show_status(self.CANCELLING)
            return False
        self.timer.stop()
        self.stop_estimates()
        return True

    def accept(self):
        """Start the run unless one is under way; the panel stays open until it ends."""
        if self.run is None:
            self.start()
        return False

    def begin(self, run, total, status):
        """Start a background run: the progress bar from 0 to ``total`` steps (0: busy), the
        status line, the values disabled while it runs (``update_enabled``), the poll timer on."""
        self.run = run
        self.form.progress.setRange(0, total)
        self.form.progress.setValue(0)
        self.show_status(status)
        self.update_enabled()
        run.start()
        self.timer.start()

    def poll(self):
        """Show the run's progress (:meth:`show_progress`); once it has ended, its result
        (:meth:`finish`) or why it failed (:meth:`failed`), the values enabled again."""
        run = self.run
        if run is None:
            self.timer.stop()
            return
        self.show_progress(run)
        if run.running:
            return
        self.timer.stop()
        self.run = None
        self.update_enabled()
        if run.error is not None:
            self.failed(run)
        else:
            self.finish(run)

    def show_progress(self, run):
        """Show how far the run under way is."""
        raise NotImplementedError

    def finish(self, run):
        """Take the result of a run that ended well."""
        raise NotImplementedError

    def failed(self, run):
        """Say why the run failed (:meth:`report_failure`)."""
        self.show_status(self.report_failure(run), error=True)

    def update_enabled(self):
        """Enable the values that apply; none while a run is on."""
        raise NotImplementedError

    def show_status(self, text, error=False):
        """The status line under the progress bar, in red for an error."""
        self.form.status.setText(text)
        self.form.status.setStyleSheet(ERROR_STYLE if error else "")

    def source_face(self):
        """The chosen face as it is now, or None when it (or its object) is gone."""
        obj, name = self.source
        try:
            face = obj.getSubObject(name)
        except ReferenceError:  # the object was deleted
            return None
        return face if isinstance(face, Part.Face) else None
