"""Faulty I++ DME servers: the simulated CMM whose answers pass through a fault, to show what the
client does with the answers a real server, a bad link or a wrongly set machine may send."""
import re

from cmmsampling.cmm.server import SimulatedCMM

_TAG = re.compile(r"^(\d{5}|E\d{4}) ([A-Za-z]+)")


class FaultyCMM(SimulatedCMM):
    """The simulated CMM of a VirtualPart whose answer lines to each command go through
    ``fault(method, tag, answers, point)`` (answers: the lines the simulated server sends; point:
    the number of the point under way, 1 for the first PtMeas and the moves before it) and are
    sent as it returns them."""

    def __init__(self, part, fault, **options):
        super().__init__(part, **options)
        self.fault = fault
        self.measured = 0

    def execute(self, line, state, pending):
        answers = super().execute(line, state, pending)
        found = _TAG.match(line)
        if found is None:
            return answers
        tag, method = found.groups()
        point = self.measured + 1
        if method == "PtMeas":
            self.measured += 1
        return self.fault(method, tag, answers, point)


def at(method, point, change):
    """A fault: change(tag, answers) -> lines for method's answer at the given point, every other
    answer as the simulated server sends it."""

    def fault(said, tag, answers, under_way):
        return change(tag, answers) if said == method and under_way == point else answers

    return fault


def from_point(point, change):
    """A fault: change(tag, answers) for every PtMeas from the given point on."""

    def fault(said, tag, answers, under_way):
        return change(tag, answers) if said == "PtMeas" and under_way >= point else answers

    return fault


def report_of(answers):
    """The PtMeas data line of answers (the simulated server's)."""
    return next(line for line in answers if " # " in line)


def scaled(tag, answers, factor):
    """answers with every number of its point report multiplied by factor (IJK kept)."""
    report = report_of(answers)

    def times(found):
        name, values = found.groups()
        if name == "IJK":
            return found.group(0)
        return f"{name}({','.join(f'{float(value) * factor:.6f}' for value in values.split(','))})"

    return [re.sub(r"([A-Z]+)\(([^()]*)\)", times, line) if line == report else line for line in answers]


def held_at(point, reached, release):
    """A fault: the answer to the point's PtMeas waits until release (a threading.Event) is set;
    reached is set when the command has come, so that a signal reaches the measuring process while
    it waits for that point, whatever the machine's load."""

    def hold(tag, answers):
        reached.set()
        release.wait(60)
        return answers

    return at("PtMeas", point, hold)
