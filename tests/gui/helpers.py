"""Qt helpers for the GUI tests: run the event loop, wait for a condition, find widgets."""
import time

import FreeCADGui
from PySide import QtCore, QtGui


def process_events(seconds):
    """Let the Qt event loop run for ``seconds``."""
    end = time.monotonic() + seconds
    while True:
        QtGui.QApplication.processEvents()
        if time.monotonic() >= end:
            return
        time.sleep(0.01)


def wait_until(condition, timeout_s, step_s=0.02):
    """Run the event loop until condition() is true; returns whether it became true."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        QtGui.QApplication.processEvents()
        if condition():
            return True
        time.sleep(step_s)
    return bool(condition())


def main_window():
    return FreeCADGui.getMainWindow()


def task_form():
    """The Sample face task panel's form while it is open, else None."""
    return main_window().findChild(QtGui.QWidget, "SampleFace")


def task_button(which):
    """The open task dialog's standard button: which = QtGui.QDialogButtonBox.Ok or .Cancel."""
    for box in main_window().findChildren(QtGui.QDialogButtonBox):
        button = box.button(which)
        if button is not None and box.isVisible():
            return button
    return None


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


def texts(node):
    """The strings of every SoText2 below a coin node, in scene order."""
    from pivy import coin

    search = coin.SoSearchAction()
    search.setType(coin.SoText2.getClassTypeId())
    search.setInterest(coin.SoSearchAction.ALL)
    search.apply(node)
    paths = search.getPaths()
    return [paths[i].getTail().string.getValues()[0] for i in range(paths.getLength())]
