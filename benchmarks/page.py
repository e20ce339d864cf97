"""Run one benchmark and write what it printed to a page of docs/benchmarks/, with the machine
and the moment it was measured on.

    /usr/bin/python3 benchmarks/page.py NAME "TITLE" COMMAND [ARG ...]

The benchmark's output also goes to this terminal as it comes. The page (NAME.md) is written
only when the command succeeds, through a temporary file, so a failed or interrupted benchmark
leaves the earlier page as it was. Exit code: the command's.
"""
import datetime
import os
import platform
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAGES = os.path.join(ROOT, "docs", "benchmarks")
INDEX = "README.md"


def machine():
    """One line on this machine: processor model, cores, memory (GiB), load average now."""
    with open("/proc/cpuinfo") as info:
        model = next((line.split(":", 1)[1].strip() for line in info if line.startswith("model name")), "?")
    with open("/proc/meminfo") as info:
        memory = int(next(line for line in info if line.startswith("MemTotal")).split()[1]) / 2 ** 20
    load = ", ".join(f"{value:.2f}" for value in os.getloadavg())
    return f"{model}, {os.cpu_count()} cores, {memory:.0f} GiB; load average {load} before the run"


def versions():
    """FreeCAD's, numpy's and scipy's versions as this Python imports them, and the BLAS numpy
    calls with the kernels it chose for this processor (OpenBLAS falls back to old generic ones
    on a processor it does not know, which makes the many small solves of a swarm slower), one line."""
    probe = ("import sys; sys.path.insert(0, sys.argv[1]); import cmmsampling, FreeCAD, numpy, scipy; "
             "from cmmsampling.runtime.threads import blas_description; "
             "print('FreeCAD ' + '.'.join(FreeCAD.Version()[:3]) + ', numpy ' + numpy.__version__ "
             "+ ', scipy ' + scipy.__version__ + '; BLAS ' + blas_description())")
    found = subprocess.run([sys.executable, "-c", probe, ROOT],
                           capture_output=True, text=True)
    return found.stdout.strip().splitlines()[-1] if found.returncode == 0 and found.stdout.strip() else "versions unknown"


def run(command):
    """(exit code, printed text, seconds) of ``command``, echoing its output line by line."""
    start = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    for line in process.stdout:
        sys.stdout.write(line)
        sys.stdout.flush()
        lines.append(line)
    return process.wait(), "".join(lines), time.perf_counter() - start


def page(title, command, text, seconds, header):
    """The page's Markdown."""
    shown = " ".join(os.path.relpath(part, ROOT) if os.path.isabs(part) and part.startswith(ROOT) else part
                     for part in command)
    return (f"# {title}\n\n"
            f"Written by `bash benchmarks/run.sh` (never by hand): `{shown}`.\n\n"
            f"- measured {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}, {seconds:.0f} s in all\n"
            f"- {header}\n"
            f"- Python {platform.python_version()}, {versions()}\n\n"
            f"```\n{text.rstrip()}\n```\n")


def write(path, text):
    """Write ``text`` to ``path`` through a temporary file beside it."""
    with open(path + ".part", "w") as out:
        out.write(text)
    os.replace(path + ".part", path)


def index():
    """The Markdown of docs/benchmarks/README.md: every page with its title."""
    rows = []
    for name in sorted(os.listdir(PAGES)):
        if name.endswith(".md") and name != INDEX:
            with open(os.path.join(PAGES, name)) as text:
                rows.append(f"- [{text.readline().lstrip('# ').strip()}]({name})")
    return ("# Benchmarks\n\nEach page is written by the benchmark that measures it, through "
            "`bash benchmarks/run.sh`; none is edited by hand.\n\n" + "\n".join(rows) + "\n")


def main():
    name, title, command = sys.argv[1], sys.argv[2], sys.argv[3:]
    header = machine()
    code, text, seconds = run(command)
    if code != 0:
        print(f"{name}: the benchmark failed (exit code {code}); docs/benchmarks/{name}.md left as it was")
        return code
    path = os.path.join(PAGES, f"{name}.md")
    os.makedirs(PAGES, exist_ok=True)
    write(path, page(title, command, text, seconds, header))
    write(os.path.join(PAGES, INDEX), index())
    print(f"wrote {os.path.relpath(path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
