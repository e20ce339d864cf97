"""cmmsampling.sample() in a background thread, with progress and cancel for the GUI thread."""
import threading
import traceback

from ..sampling import sample


class BackgroundSampling:
    """Runs ``sample(face, progress=..., **arguments)`` in a daemon thread.

    The GUI thread polls ``iteration`` and ``best_mm`` (the swarm's best maximum deviation so
    far, mm), ``running``, then ``result`` or ``error``/``details`` (the traceback text);
    ``cancel()`` makes the progress callback ask the optimiser to stop. The thread never touches
    the document: writing the result is the GUI thread's job.
    """

    def __init__(self, face, arguments):
        self.face = face
        self.arguments = dict(arguments)
        self.iteration = 0
        self.best_mm = float("nan")
        self.result = None
        self.error = None
        self.details = ""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="cmmsampling", daemon=True)

    def start(self):
        self._thread.start()

    @property
    def running(self):
        return self._thread.is_alive()

    @property
    def cancelled(self):
        return self._stop.is_set()

    def cancel(self, wait_s):
        """Ask the run to stop and wait up to wait_s seconds; True when it has stopped."""
        self._stop.set()
        self._thread.join(wait_s)
        return not self.running

    def _progress(self, iteration, best_mm):
        self.iteration = iteration
        self.best_mm = best_mm
        return self._stop.is_set()

    def _run(self):
        try:
            self.result = sample(self.face, progress=self._progress, **self.arguments)
        except Exception as exc:  # reported to the user by the GUI thread
            self.error = exc
            self.details = traceback.format_exc()
