"""What the command line prints as it runs: one-line progress displays on stderr and the table
of results."""
import sys
import time

from ..strategies.sampling import STRATEGIES, baseline


class TerminalProgress:
    """A one-line progress display on stderr for an optimiser: a bar when ``total`` is known."""

    def __init__(self, label, total=None, unit="step", stream=sys.stderr, every_s=0.2):
        self.label, self.total, self.unit, self.stream, self.every_s = label, total, unit, stream, every_s
        self._last = 0.0

    def __call__(self, iteration, best):
        now = time.monotonic()
        last = self.total is not None and iteration == self.total
        if now - self._last >= self.every_s or last:
            self._last = now
            if self.total:
                done = int(30 * iteration / self.total)
                where = f"[{'#' * done}{'.' * (30 - done)}] {iteration}/{self.total}"
            else:
                where = f"{self.unit} {iteration}"
            self.stream.write(f"\r{self.label} {where} best max {best:.4f} mm ")
            if last:
                self.stream.write("\n")
            self.stream.flush()
        return False

    def finish(self):
        """End the progress line."""
        self.stream.write("\n")
        self.stream.flush()


class StudyProgress(TerminalProgress):
    """Progress of a study on stderr: runs done of all, with what runs now."""

    def __init__(self):
        super().__init__("study")

    def __call__(self, done, total, message):
        now = time.monotonic()
        if now - self._last >= self.every_s:
            self._last = now
            self.stream.write(f"\rstudy {done}/{total} {message[:60]:<60}")
            self.stream.flush()
        return False


class FaceProgress(TerminalProgress):
    """Progress of a plan on stderr: the plan's tally (faces done, points so far, time left) and
    the last face's line."""

    def __init__(self):
        super().__init__("plan")
        self.last_line = ""

    def __call__(self, done, total, message):
        line, _, tally = message.partition("\n")
        self.last_line = line or self.last_line
        self.stream.write(f"\rplan: {tally} | {self.last_line[:40]:<40}")
        self.stream.flush()
        return False


def format_table(results):
    """Fixed-width table of results: strategy, max/mean/RMS (mm), ratio to uniform, time (s)."""
    reference = baseline()
    uniform = next((r.deviation.maximum for r in results if r.strategy == reference), None)
    # the ratio column is headed by the baseline label's first word: "x uniform"
    lines = [f"{'strategy':<20} {'N':>4} {'max mm':>9} {'mean mm':>9} {'RMS mm':>9} "
             f"{'OCC max':>9} {'x ' + STRATEGIES[reference].label.split()[0]:>9} {'time s':>8}"]
    for r in results:
        d = r.deviation
        ratio = d.maximum / uniform if uniform else float("nan")
        lines.append(f"{r.strategy:<20} {r.n:>4} {d.maximum:>9.4f} {d.mean:>9.4f} {d.rms:>9.4f} "
                     f"{d.occ_maximum:>9.4f} {ratio:>9.3f} {r.timings['total_s']:>8.2f}")
    return "\n".join(lines)
