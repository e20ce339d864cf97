"""The package's type hints hold: mypy (Debian's, scripts/install-deps.sh installs it on the host)
checks every module with the settings in mypy.ini. In the quality layer: once per CI, on the host."""
import ast
import os
import pathlib
import shutil
import subprocess

import pytest
from support.paths import ROOT

pytestmark = pytest.mark.quality


def test_mypy_finds_no_type_errors_in_the_package(tmp_path):
    mypy = shutil.which("mypy")
    assert mypy, "mypy is missing: run scripts/install-deps.sh (Debian's mypy package)"
    checked = subprocess.run([mypy, "--config-file", os.path.join(ROOT, "mypy.ini"), "--cache-dir", str(tmp_path)],
                             cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert checked.returncode == 0, checked.stdout[-4000:] + checked.stderr[-2000:]
    assert "Success: no issues found" in checked.stdout


def test_mypy_sees_a_type_error(tmp_path):
    wrong = tmp_path / "wrong.py"
    wrong.write_text("from cmmsampling.formats.registry import register_format\n\nregister_format('dmis')\n")
    mypy = shutil.which("mypy")
    assert mypy, "mypy is missing: run scripts/install-deps.sh (Debian's mypy package)"
    checked = subprocess.run([mypy, "--config-file", os.path.join(ROOT, "mypy.ini"), "--cache-dir",
                              str(tmp_path / "cache"), str(wrong)], cwd=ROOT, capture_output=True, text=True,
                             timeout=600)
    assert checked.returncode == 1 and 'incompatible type "str"; expected "FileFormat"' in checked.stdout


# The rooms whose every function carries type hints (docs/architecture.md): mypy checks only
# annotated functions, so a function left bare would escape the check above.
TYPED_ROOMS = ("geometry", "runtime", "access", "fitting", "strategies", "inspection")


def bare_functions(path):
    """'file:line name' of the functions in a module (closures and methods too) with a parameter
    (but self and cls) or a return without a type hint."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    bare = []
    for node in ast.walk(tree):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        arguments = node.args.posonlyargs + node.args.args + node.args.kwonlyargs
        arguments += [a for a in (node.args.vararg, node.args.kwarg) if a is not None]
        named = [a for a in arguments if a.arg not in ("self", "cls")]
        if node.returns is None or any(a.annotation is None for a in named):
            bare.append(f"{path.name}:{node.lineno} {node.name}")
    return bare


def test_every_function_of_the_core_rooms_has_type_hints():
    package = pathlib.Path(ROOT) / "cmmsampling"
    bare = [where for room in TYPED_ROOMS for path in sorted((package / room).glob("*.py"))
            for where in bare_functions(path)]
    assert not bare, bare[:20]


def test_a_bare_function_is_found(tmp_path):
    module = tmp_path / "module.py"
    module.write_text("def typed(x: int) -> int:\n    return x\n\n\ndef bare(x, *args: int) -> int:\n    return x\n")
    assert bare_functions(module) == ["module.py:5 bare"]
