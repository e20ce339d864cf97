"""Background jobs for the GUI thread: cmmsampling.sample() in a daemon thread, with progress and
cancel, any one call (:class:`BackgroundCall`, the time estimates), and the
:class:`BackgroundTask` base that other long jobs (the comparison) share."""
import threading
import time
import traceback

from ..strategies.sampling import sample


class BackgroundTask:
    """A job run once by ``_work()`` in a daemon thread named ``name``.

    The GUI thread polls ``running``, then the job's results or ``error``/``details`` (the
    traceback text); ``cancelled`` is set by the subclass's ``cancel``, which its progress
    callback reports to the job. The thread never touches the document.
    """

    def __init__(self, name):
        self.error = None
        self.details = ""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self):
        self._thread.start()

    @property
    def running(self):
        return self._thread.is_alive()

    @property
    def cancelled(self):
        return self._stop.is_set()

    def _work(self):
        """The job itself, run in the thread; subclasses store its results on self."""
        raise NotImplementedError

    def _run(self):
        try:
            self._work()
        except Exception as exc:  # reported to the user by the GUI thread
            self.error = exc
            self.details = traceback.format_exc()


class BackgroundCall(BackgroundTask):
    """Runs ``function(*args, **kwargs)`` once in a daemon thread named ``name`` (an estimate
    that would hold up the GUI); the GUI thread polls ``running``, then ``value`` or ``error``."""

    def __init__(self, name, function, *args, **kwargs):
        super().__init__(name)
        self.call = (function, args, kwargs)
        self.value = None

    def _work(self):
        function, args, kwargs = self.call
        self.value = function(*args, **kwargs)


class BackgroundSampling(BackgroundTask):
    """Runs ``sample(face, progress=..., **arguments)`` in a daemon thread.

    The GUI thread polls ``iteration`` and ``best_mm`` (the swarm's best maximum deviation so
    far, mm), ``running``, then ``result`` or ``error``/``details`` (the traceback text);
    ``cancel()`` makes the progress callback ask the optimiser to stop. The thread never touches
    the document: writing the result is the GUI thread's job.
    """

    def __init__(self, face, arguments):
        super().__init__("cmmsampling")
        self.face = face
        self.arguments = dict(arguments)
        self.iteration = 0
        self.best_mm = float("nan")
        self.result = None

    def cancel(self, wait_s):
        """Ask the run to stop and wait up to wait_s seconds; True when it has stopped."""
        self._stop.set()
        self._thread.join(wait_s)
        return not self.running

    def _progress(self, iteration, best_mm):
        self.iteration = iteration
        if not best_mm >= self.best_mm:   # the best so far: it never rises (NaN before the first)
            self.best_mm = best_mm
        return self.cancelled

    def _work(self):
        self.result = sample(self.face, progress=self._progress, **self.arguments)


def behind_progress(job, title, name, label, poll_s=0.05):
    """Run a BackgroundTask whose ``cancel()`` takes no argument behind a window-modal progress
    dialog (object name ``name``, window title ``title``) with Cancel, its text ``label()`` as
    the job goes; returns whether the user pressed Cancel, once the job has ended."""
    import FreeCADGui
    from PySide import QtCore, QtGui

    dialog = QtGui.QProgressDialog(label(), "Cancel", 0, 0, FreeCADGui.getMainWindow())
    dialog.setObjectName(name)
    dialog.setWindowTitle(title)
    dialog.setWindowModality(QtCore.Qt.WindowModal)
    dialog.setMinimumDuration(0)
    dialog.show()
    job.start()
    try:
        while job.running:
            QtGui.QApplication.processEvents()
            if dialog.wasCanceled():
                job.cancel()
            dialog.setLabelText(label())
            time.sleep(poll_s)
        QtGui.QApplication.processEvents()
        return dialog.wasCanceled()
    finally:
        dialog.close()
        dialog.deleteLater()
