"""The package's rooms and the one-way imports between them, read from the code itself.

geometry <- runtime (process plumbing) <- access <- fitting <- strategies <- formats <- planning <- the hall
(the package's face, measurement, the rooms inspection/, cmm/ (a live CMM), study/ and document/, cli) <- gui:
a module imports from its own room or from rooms below it,
and no modules import each other in a circle, not even through imports only the type checker reads.
The arrows allowed up are FreeCAD's pattern for document objects: the document layer attaches
view providers when the GUI is up.
"""
import ast
import os

import pytest
from support.paths import ROOT

PACKAGE = os.path.join(ROOT, "cmmsampling")
ROOMS = ("geometry", "runtime", "access", "fitting", "strategies", "formats", "planning", "hall", "gui")
HALL = ("__init__", "measurement", "inspection", "cmm", "study", "document", "cli", "__main__")
ALLOWED_UP = {("document.objects", "gui.view_providers"), ("document.inspections", "gui.inspection_view")}


def modules():
    """{dotted name inside the package: path} of every module."""
    found = {}
    for folder, _, names in os.walk(PACKAGE):
        for name in names:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                parts = os.path.relpath(path, PACKAGE)[:-3].split(os.sep)
                found[".".join(parts)] = path
    return found


def type_only(tree):
    """The import statements of a module's ``if TYPE_CHECKING:`` blocks (read by the type checker
    alone, never run)."""
    return {id(node) for block in ast.walk(tree)
            if isinstance(block, ast.If) and isinstance(block.test, ast.Name) and block.test.id == "TYPE_CHECKING"
            for statement in block.body for node in ast.walk(statement)}


def imports(name, path, run_only=False):
    """The package's modules that module ``name`` imports (at the top or inside functions);
    run_only: leave out the imports only the type checker reads."""
    known = modules()
    package = name.split(".")[:-1]
    found = set()
    tree = ast.parse(open(path, encoding="utf-8").read())
    skipped = type_only(tree) if run_only else set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[:len(package) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                candidate = f"{target}.{alias.name}".strip(".")
                found.add(candidate if candidate in known else (target or "__init__"))
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("cmmsampling"):
            found.add(node.module.partition(".")[2] or "__init__")
    return {module if module in known else f"{module}.__init__" for module in found} - {name}


def room(module):
    """The room of a module: its folder, or 'hall' for the package's own top level."""
    first = module.split(".")[0]
    return "hall" if first in HALL else first


def level(module):
    """(room's rank, rank inside the hall) of a module: lower is further down the house."""
    first = module.split(".")[0]
    return ROOMS.index(room(module)), HALL.index(first) if first in HALL else 0


GRAPH = {name: imports(name, path) for name, path in modules().items()}
# What runs, without the imports only the type checker reads.
RUN_GRAPH = {name: imports(name, path, run_only=True) for name, path in modules().items()}


def test_every_module_lives_in_a_room():
    assert all(room(module) in ROOMS for module in GRAPH), sorted(GRAPH)
    assert {room(module) for module in GRAPH} == set(ROOMS)


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_no_import_runs_up_the_house(module):
    up = [target for target in GRAPH[module]
          if level(target) > level(module) and (module, target) not in ALLOWED_UP]
    assert not up, f"{module} ({room(module)}) imports from higher up: {up}"


def circle(graph):
    """A circle of imports in graph ({module: the modules it imports}) as 'a -> b -> a', or None;
    the arrows allowed up do not count."""
    state = {}

    def visit(module, trail):
        state[module] = "open"
        for target in graph[module]:
            if (module, target) in ALLOWED_UP:
                continue
            if state.get(target) == "open":
                return " -> ".join(trail[trail.index(target):] + [target])
            if target not in state:
                found = visit(target, trail + [target])
                if found:
                    return found
        state[module] = "done"
        return None

    for module in sorted(graph):
        if module not in state:
            found = visit(module, [module])
            if found:
                return found
    return None


def test_no_modules_import_each_other_in_a_circle():
    assert circle(GRAPH) is None


def test_the_checker_sees_an_arrow_up_and_a_circle():
    assert level("gui.commands") > level("document") > level("study") > level("formats.dmis")
    assert "document.object_types" in GRAPH["gui.view_providers"]
    assert not {"document.objects", "document.results"} & GRAPH["gui.view_providers"]
    assert "gui.view_providers" in GRAPH["document.objects"]
    assert "geometry.surface" in GRAPH["fitting.occ_surface"]
    # A type-only import is an arrow: series states what it reads of an Inspection as a Protocol
    # of its own instead of importing judge, and the strategies take Progress from the registry.
    with_type_only = {"judge": {"series"}, "series": {"judge"}, "plain": set()}
    assert circle(with_type_only) == "judge -> series -> judge"
    assert "inspection.series" in RUN_GRAPH["inspection.result"] and "inspection.judge" not in GRAPH["inspection.series"]
    assert "strategies.registry" in GRAPH["strategies.pso"] and "strategies.sampling" not in GRAPH["strategies.pso"]
