"""NIST's I++ DME command checker and response parser (../shared/reference/ippdme-nist), built
with g++ once per session: :func:`check_commands` and :func:`check_answers` feed them a stream and
return what they complain of."""
import atexit
import functools
import os
import shutil
import subprocess
import tempfile

from .paths import ROOT

NIST = os.path.join(os.path.dirname(ROOT), "shared", "reference", "ippdme-nist")


@functools.lru_cache(maxsize=2)
def built(folder="checker", macro="CHECKER_MAIN"):
    """The path of NIST's program in folder built with g++ (main by macro) in a temporary folder
    removed when the process ends; None where g++ or the NIST sources are missing."""
    sources = os.path.join(NIST, folder)
    if shutil.which("g++") is None or not os.path.isdir(sources):
        return None
    built_in = tempfile.mkdtemp(prefix="nist-ippdme-")
    atexit.register(shutil.rmtree, built_in, True)
    binary = os.path.join(built_in, folder)
    files = sorted(os.path.join(sources, name) for name in os.listdir(sources) if name.endswith(".cpp"))
    subprocess.run(["g++", "-O1", "-w", f"-D{macro}", "-o", binary, *files], check=True, timeout=300)
    return binary


def checker():
    """NIST's command checker, built; None where it cannot be."""
    return built("checker", "CHECKER_MAIN")


def response_parser():
    """NIST's response parser, built; None where it cannot be."""
    return built("response-parser", "PARSER_MAIN")


def check_commands(commands, folder):
    """NIST's checker's complaints (its standard error, lines) about commands (lines without
    CR LF)."""
    return _complaints(checker(), commands, os.path.join(folder, "commands.prg"))


def check_answers(answers, folder):
    """NIST's response parser's complaints (its standard error, lines) about answer lines."""
    return _complaints(response_parser(), answers, os.path.join(folder, "answers.res"))


def _complaints(program, lines, path):
    """Standard error of NIST's program fed lines as its files hold them: one a line, each
    followed by a line '\\\\', CR LF, the file closed by two lines ':'."""
    with open(path, "wb") as stream:
        stream.write("".join(f"{line}\r\n\\\\\r\n" for line in lines).encode("ascii") + b":\r\n:\r\n")
    done = subprocess.run([program], input=f"n\n{path}\nq\n", capture_output=True, text=True, timeout=60)
    return [line for line in done.stderr.splitlines() if line.strip()]
