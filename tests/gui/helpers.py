"""Helpers for the GUI tests: run the event loop, wait for a condition, find widgets, open and
fill the Sample face panel, interrupt its background run."""
import threading
import time

import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

import cmmsampling
from cmmsampling.gui import background, commands

SAMPLE = commands.SampleFace.NAME


def process_events(seconds):
    """Let the Qt event loop run for ``seconds``."""
    end = time.monotonic() + seconds
    while True:
        QtGui.QApplication.processEvents()
        if time.monotonic() >= end:
            return
        time.sleep(0.01)


# A wait asks whether something happens, not how soon: how soon is for the tests that time it with
# their own clock, against a bound measured in the same run (a busy CI machine, four FreeCADs on two
# cores, took more than ten times a quiet machine's time over a study's PSO rows).
PATIENCE = 10


def wait_until(condition, timeout_s, step_s=0.02):
    """Run the event loop until condition() is true; returns whether it became true.

    ``timeout_s`` is the most it takes on a quiet machine; the wait gives up after PATIENCE times that.
    """
    end = time.monotonic() + PATIENCE * timeout_s
    while time.monotonic() < end:
        QtGui.QApplication.processEvents()
        if condition():
            return True
        time.sleep(step_s)
    return bool(condition())


def main_window():
    return FreeCADGui.getMainWindow()


def widgets():
    """Every live widget of the application.

    Short-lived widgets are looked up here, not with the main window's findChild: PySide keeps
    what that returns alive with the main window's wrapper, and after Qt has deleted a widget it
    hands that stale wrapper out again for a new widget at the same address. allWidgets() can
    also hand out such a stale wrapper; those are left out (using one raises RuntimeError)."""
    return [w for w in QtGui.QApplication.allWidgets() if _alive(w)]


def _alive(widget):
    """False for a PySide wrapper whose Qt widget has been deleted."""
    try:
        widget.objectName()
    except RuntimeError:
        return False
    return True


def child(form, name):
    """The form's widget named ``name`` that the panel added in code (uic gives attributes only
    to the widgets of the .ui file)."""
    return form.findChild(QtGui.QWidget, name)


def task_form():
    """The Sample face task panel's form while it is open, else None."""
    return next((w for w in widgets() if w.objectName() == "SampleFace"), None)


# How long an open dialog's buttons may take to show (FreeCAD 1.1's Tasks overlay).
TASK_SHOWN_S = 5.0


def task_button(which):
    """The open task dialog's standard button: which = QtGui.QDialogButtonBox.Ok or .Cancel.

    The wrapper of a widget can be a stale one of another class (see :func:`widgets`); calling
    QDialogButtonBox.button() through it on a widget that is no button box reads that widget as
    one and can crash FreeCAD. Qt itself (``inherits``: the real object's meta-object) says
    which widgets are button boxes. FreeCAD 1.1 shows its Tasks dock (an overlay) a moment after
    a dialog opens: while a dialog is open and no button box is visible yet, this waits for one
    (up to TASK_SHOWN_S)."""
    found = []

    def shown():
        for box in widgets():
            if isinstance(box, QtGui.QDialogButtonBox) and box.inherits("QDialogButtonBox") and box.isVisible():
                button = box.button(which)
                if button is not None:
                    found.append(button)
                    return True
        return False

    if not shown() and FreeCADGui.Control.activeDialog():
        end = time.monotonic() + TASK_SHOWN_S
        while not shown() and time.monotonic() < end:
            process_events(0.02)
    return found[0] if found else None


def dock_text(name):
    """Plain text of a dock's text widget: 'Python console' or 'Report view'."""
    window = main_window()
    widget = window.findChild(QtGui.QPlainTextEdit, name) or window.findChild(QtGui.QTextEdit, name)
    return widget.toPlainText()


def modal_message(action, timeout_s=10):
    """Run action(), which opens a modal message box; close the box and return its text."""
    texts = []
    timer = QtCore.QTimer()
    timer.setInterval(50)

    def close_box():
        box = QtGui.QApplication.activeModalWidget()
        if isinstance(box, QtGui.QMessageBox):
            texts.append(box.text())
            box.done(0)
            timer.stop()

    timer.timeout.connect(close_box)
    timer.start()
    QtCore.QTimer.singleShot(int(timeout_s * 1000), timer.stop)
    action()
    timer.stop()
    return texts[0] if texts else None


def handle_dialog(kind, action, handle, timeout_s=10):
    """Run action(), which opens a modal dialog of class ``kind``; handle(dialog) is called with
    it open and must close it (a dialog it leaves open is rejected, as is one still open after
    timeout_s). Returns what action() returns."""
    timer = QtCore.QTimer()
    timer.setInterval(50)

    def poll():
        dialog = QtGui.QApplication.activeModalWidget()
        if isinstance(dialog, kind):
            timer.stop()
            try:
                handle(dialog)
            finally:
                if dialog.isVisible():
                    dialog.reject()

    def give_up():
        timer.stop()
        dialog = QtGui.QApplication.activeModalWidget()
        if dialog is not None:
            dialog.reject()

    timer.timeout.connect(poll)
    timer.start()
    deadline = QtCore.QTimer()   # stopped when action() returns: a later test's dialog is not its to reject
    deadline.setSingleShot(True)
    deadline.timeout.connect(give_up)
    deadline.start(int(timeout_s * 1000))
    try:
        return action()
    finally:
        timer.stop()
        deadline.stop()


def answer_dialog(action, button, timeout_s=10):
    """Run action(), which opens a modal dialog; once the dialog shows its text, press its button
    with text ``button`` and return the texts it showed."""
    seen = []
    timer = QtCore.QTimer()
    timer.setInterval(50)

    def press():
        dialog = QtGui.QApplication.activeModalWidget()
        if dialog is None or not dialog.isVisible():
            return
        shown = [label.text() for label in dialog.findChildren(QtGui.QLabel) if label.text()]
        if isinstance(dialog, QtGui.QMessageBox) and dialog.text():
            shown.append(dialog.text())
        buttons = [b for b in dialog.findChildren(QtGui.QAbstractButton)
                   if b.text().replace("&", "") == button]
        if not shown or not buttons:
            return
        seen.extend(shown)
        timer.stop()
        buttons[0].click()

    timer.timeout.connect(press)
    timer.start()
    QtCore.QTimer.singleShot(int(timeout_s * 1000), timer.stop)
    action()
    timer.stop()
    return " ".join(seen)


def texts(node):
    """The strings of every SoText2 below a coin node, in scene order."""
    from pivy import coin

    search = coin.SoSearchAction()
    search.setType(coin.SoText2.getClassTypeId())
    search.setInterest(coin.SoSearchAction.ALL)
    search.apply(node)
    paths = search.getPaths()
    return [paths[i].getTail().string.getValues()[0] for i in range(paths.getLength())]


def labels_on_screen(prefix=""):
    """The labels (SoText2) the active 3D view draws at its present zoom whose text starts with
    ``prefix``: [(text, (x, y) pixels)], found by a callback action over the view's camera and
    scene as Coin renders them (a level-of-detail node traverses only the level it picks). (The
    view's viewer is not asked for: on FreeCAD 1.1 a document whose viewer Python took closed
    with a crash.)"""
    from pivy import coin

    view = FreeCADGui.ActiveDocument.ActiveView
    scene = coin.SoSeparator()
    scene.addChild(view.getCameraNode())
    scene.addChild(view.getSceneGraph())
    width, height = view.getSize()
    found = []

    def seen(_data, action, node):
        text = node.string.getValues()[0]
        if text.startswith(prefix):
            at = FreeCAD.Vector(*action.getModelMatrix().getValue()[3][:3])
            found.append((text, tuple(view.getPointOnScreen(at))))
        return coin.SoCallbackAction.CONTINUE

    action = coin.SoCallbackAction(coin.SbViewportRegion(width, height))
    action.addPreCallback(coin.SoText2.getClassTypeId(), seen, None)
    action.apply(scene)
    scene.removeAllChildren()
    return found


def overlapping_labels(found, size):
    """Pairs of labels ``found`` (labels_on_screen) whose text boxes overlap on screen: a text
    starts at its point and is as wide as Sans at ``size`` pixels writes it, and ``size`` high."""
    font = QtGui.QFont("Sans")
    font.setPixelSize(size)
    metrics = QtGui.QFontMetrics(font)
    pairs = []
    for i, (text, (x, y)) in enumerate(found):
        for other, (x2, y2) in found[i + 1:]:
            width = metrics.horizontalAdvance(text if x <= x2 else other)
            if abs(x2 - x) < width and abs(y2 - y) < size:
                pairs.append((text, other))
    return pairs


def zoomed(factor, obj=None):
    """Fit the active view to the scene (to ``obj`` where given), then zoom it by ``factor``
    (> 1 in) and let it draw."""
    view = FreeCADGui.ActiveDocument.ActiveView
    if obj is None:
        view.fitAll()
    else:
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(obj)
        FreeCADGui.SendMsgToActiveView("ViewSelection")
        FreeCADGui.Selection.clearSelection()
    view.getCameraNode().scaleHeight(1.0 / factor)
    process_events(0.3)


def open_panel(doc, face="Face1"):
    """Select the Body's face, run Sample face, return the panel's form (a new one: the form of
    a panel closed before is deleted later, by the event loop)."""
    assert wait_until(lambda: task_form() is None, 5), "the last panel's form is still there"
    FreeCADGui.Selection.clearSelection()
    FreeCADGui.Selection.addSelection(doc.Body, face)
    FreeCADGui.runCommand(SAMPLE)
    assert wait_until(lambda: task_form() is not None, 5), commands.SampleFace().reason()
    return task_form()


def fill(form, strategy="pso", **values):
    """Set the strategy and spin/check boxes of the form by name."""
    form.strategy.setCurrentIndex(form.strategy.findData(strategy))
    for name, value in values.items():
        widget = getattr(form, name)
        if isinstance(widget, QtGui.QCheckBox):
            widget.setChecked(value)
        else:
            widget.setValue(value)


def short_result(doc):
    """A short PSO run (25 points) on the Body's face."""
    return cmmsampling.sample(doc.Body.Shape.Faces[0], 25, "pso", population=8, iterations=20, seed=1)


def running_workers():
    """The task panel's worker threads still alive."""
    return [t for t in threading.enumerate() if t.name == "cmmsampling" and t.is_alive()]


def groups(doc):
    return [o for o in doc.Objects if o.TypeId == "App::DocumentObjectGroup"]


def drawn(obj):
    """Coin nodes our view provider drew for obj: pick style, labels and lines for probe points;
    polygon offset, coloured mesh, legend (when shown) and the maximum's mark for a substitute."""
    proxy = obj.ViewObject.Proxy
    node = getattr(proxy, "annotation", None) or getattr(proxy, "coloured", None)
    return node.getNumChildren() if node is not None else 0


def interrupt_run(monkeypatch, action, at=None):
    """Make the panel's next run call action() in its worker thread: before sample() starts
    (at=None) or in the progress callback of iteration ``at``, before the panel's own callback.
    action may block (hold the run there) or raise (a fault inside the run)."""
    sample = background.sample

    def interrupted(face, progress=None, **arguments):
        if at is None:
            action()
            return sample(face, progress=progress, **arguments)

        def watched(iteration, best_mm):
            if iteration == at:
                action()
            return progress(iteration, best_mm)

        return sample(face, progress=watched, **arguments)

    monkeypatch.setattr(background, "sample", interrupted)


class Hold:
    """An action that holds a run (see :func:`interrupt_run`) or a study in its worker thread
    until released (at most limit_s)."""

    def __init__(self, limit_s=20.0):
        self.reached = threading.Event()
        self.released = threading.Event()
        self.limit_s = limit_s

    def __call__(self):
        self.reached.set()
        self.released.wait(self.limit_s)

    def release_after(self, seconds):
        """Release the run from another thread after ``seconds`` (while the GUI thread waits)."""
        threading.Timer(seconds, self.released.set).start()


def document_with(name, shapes):
    """A fixture's body: a new active document ``name`` holding a Part::Feature per (object name,
    shape) of ``shapes``, viewed isometric and fitted, nothing selected; yielded, then closed
    (its task panel closed first), also when the generator is closed early."""
    import FreeCAD

    d = FreeCAD.newDocument(name)
    for object_name, shape in shapes.items():
        d.addObject("Part::Feature", object_name).Shape = shape
    d.recompute()
    FreeCADGui.ActiveDocument.ActiveView.viewIsometric()
    FreeCADGui.SendMsgToActiveView("ViewFit")
    FreeCADGui.Selection.clearSelection()
    opened = d.Name
    try:
        yield d
    finally:
        if FreeCADGui.Control.activeDialog():
            FreeCADGui.Control.closeDialog()
        FreeCADGui.Selection.clearSelection()
        if opened in FreeCAD.listDocuments():
            FreeCAD.closeDocument(opened)
        process_events(0.1)
