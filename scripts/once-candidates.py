"""The unit tests the FreeCAD roots may skip (tests/support/once.py): slow, outside what a version
changes most, and every line of cmmsampling they run is run by a test the roots keep.

Inputs, made with Debian's python3-pytest-cov (not needed otherwise):
    /usr/bin/python3 -m pytest -q -p no:cacheprovider tests -m "not slow and not quality" \\
        --durations=0 > durations.log
    /usr/bin/python3 -m pytest -q -p no:cacheprovider tests -m "not slow and not quality" \\
        --cov=cmmsampling --cov-context=test --cov-report=
    /usr/bin/python3 scripts/once-candidates.py .coverage durations.log 0.5
Prints the candidates, slowest first (seconds, node id), and on stderr what they save; the slowest
go first, each taken only where every line it runs is still run by a test not taken.
"""
import collections
import re
import sys

# What a FreeCAD version changes most: OCC's answers on given faces, the shared CAD files,
# documents, files, processes, Cancel, the command line and the install.
VERSION_ROOMS = ("tests/fitting/test_delivered_deviation.py", "tests/fitting/test_geometric_deviation.py",
                 "tests/fitting/test_trimmed_substitute.py", "tests/fitting/test_stretched_substitute.py",
                 "tests/geometry/", "tests/package/test_sweep.py", "tests/package/test_real_parts.py",
                 "tests/package/test_installed.py", "tests/package/test_command_line.py", "tests/document/",
                 "tests/formats/", "tests/gui/", "tests/runtime/", "tests/runtime/test_jobs.py", "tests/cmm/")
VERSION_WORDS = ("dask", "cancel", "process", "worker", "hand", "script", "command_line", "installed")


def durations(log: str) -> collections.Counter:
    """{node id: seconds of its setup, call and teardown} from pytest's --durations=0 output."""
    seconds: collections.Counter = collections.Counter()
    with open(log) as lines:
        for line in lines:
            found = re.match(r"([\d.]+)s (call|setup|teardown)\s+(\S+)", line)
            if found:
                seconds[found.group(3)] += float(found.group(1))
    return seconds


def lines_by_test(database: str) -> dict:
    """{node id: the (file, line) pairs of cmmsampling it ran} from a coverage file with test contexts."""
    import coverage

    data = coverage.CoverageData(database)
    data.read()
    ran = collections.defaultdict(set)
    for name in data.measured_files():
        for number, contexts in data.contexts_by_lineno(name).items():
            for context in filter(None, contexts):
                ran[context.rsplit("|", 1)[0]].add((name, number))
    return ran


def version_sensitive(node: str) -> bool:
    """Whether a test is about what a FreeCAD version changes most (its room or its name says)."""
    return node.startswith(VERSION_ROOMS) or any(word in node.split("::")[1].lower() for word in VERSION_WORDS)


def candidates(ran: dict, seconds: collections.Counter, threshold_s: float) -> list:
    """The tests of at least threshold_s seconds, slowest first, each taken where every line it
    runs is still run by a test not taken."""
    runs = collections.Counter()
    for covered in ran.values():
        runs.update(covered)
    taken = []
    for node in sorted(ran, key=lambda node: -seconds.get(node, 0.0)):
        if seconds.get(node, 0.0) >= threshold_s and not version_sensitive(node) \
                and all(runs[line] >= 2 for line in ran[node]):
            taken.append(node)
            runs.subtract(ran[node])
    return taken


def main(database: str, log: str, threshold_s: str) -> None:
    seconds, ran = durations(log), lines_by_test(database)
    taken = candidates(ran, seconds, float(threshold_s))
    saved = sum(seconds[node] for node in taken)
    print(f"{len(taken)} of {len(ran)} tests, {saved:.0f} of {sum(seconds.get(n, 0.0) for n in ran):.0f} s",
          file=sys.stderr)
    for node in taken:
        print(f"{seconds[node]:6.1f} {node}")


if __name__ == "__main__":
    main(*sys.argv[1:])
