"""package.xml as the Addon Manager reads it: the fields its index and installer need, read by
FreeCAD's own metadata reader (App.Metadata), the version and date of CHANGELOG.md's newest entry,
and Python dependencies that cover every package the workbench imports, each one the Addon
Manager can install (its allow-list) or said not to be (cmmsampling.runtime.packages)."""
import ast
import os
import re
import sys
import xml.etree.ElementTree as ET

import pytest
from support.paths import ROOT

from cmmsampling.runtime.packages import PACKAGES

import FreeCAD  # noqa: E402 (importable once cmmsampling is imported)

PACKAGE_XML = os.path.join(ROOT, "package.xml")
NS = {"p": "https://wiki.freecad.org/Package_Metadata"}
# What FreeCAD itself brings: its modules and the Qt and Coin bindings it ships with.
FREECAD_MODULES = {"FreeCAD", "FreeCADGui", "Part", "WebGui", "PySide", "PySide2", "PySide6", "pivy"}
# Packages every feature needs, which a FreeCAD installation brings.
CORE = {"numpy", "scipy"}
ALLOW_LIST = os.path.join(FreeCAD.getResourceDir(), "Mod", "AddonManager", "ALLOWED_PYTHON_PACKAGES.txt")


@pytest.fixture(scope="module")
def root():
    return ET.parse(PACKAGE_XML).getroot()


def newest_change():
    """(version, date) of CHANGELOG.md's first '## <version> (<date>)' heading."""
    with open(os.path.join(ROOT, "CHANGELOG.md"), encoding="utf-8") as handle:
        found = re.search(r"^## (\d+\.\d+\.\d+) \((\d{4}-\d{2}-\d{2})\)$", handle.read(), re.M)
    assert found, "CHANGELOG.md has no '## x.y.z (yyyy-mm-dd)' entry"
    return found.group(1), found.group(2)


def imported_packages():
    """The top-level names of every module the workbench imports (package, Init.py, InitGui.py)
    that is neither the standard library's, FreeCAD's nor its own."""
    files = [os.path.join(ROOT, "Init.py"), os.path.join(ROOT, "InitGui.py")]
    for folder, _, names in os.walk(os.path.join(ROOT, "cmmsampling")):
        files += [os.path.join(folder, name) for name in names if name.endswith(".py")]
    found = set()
    for path in files:
        with open(path, encoding="utf-8") as handle:
            tree = ast.parse(handle.read(), path)
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found |= {alias.name.split(".")[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
    return found - set(sys.stdlib_module_names) - FREECAD_MODULES - {"cmmsampling", "__main__"}


def declared(root, optional):
    """The Python packages package.xml declares, required or optional."""
    return {element.text for element in root.findall("p:depend", NS)
            if element.get("type") == "python" and (element.get("optional") == "true") == optional}


def test_freecads_own_reader_finds_the_workbench_and_its_version():
    metadata = FreeCAD.Metadata(PACKAGE_XML)
    assert metadata.Name == "CMM Sampling"
    assert metadata.Version == newest_change()[0]
    assert metadata.supportsCurrentFreeCAD()
    workbenches = metadata.Content["workbench"]
    assert [(w.Classname, w.Subdirectory) for w in workbenches] == [("CMMSamplingWorkbench", "./")]
    with open(os.path.join(ROOT, "InitGui.py"), encoding="utf-8") as handle:
        classes = {node.name for node in ast.walk(ast.parse(handle.read())) if isinstance(node, ast.ClassDef)}
    assert workbenches[0].Classname in classes
    for icon in (metadata.Icon, workbenches[0].Icon):
        assert icon.endswith(".svg") and os.path.isfile(os.path.join(ROOT, icon)), icon


def test_the_fields_the_addon_index_needs(root):
    repository = root.findall("p:url[@type='repository']", NS)
    assert len(repository) == 1 and repository[0].get("branch") == "main"
    assert re.fullmatch(r"https://\S+", repository[0].text)
    readme = root.findall("p:url[@type='readme']", NS)
    assert len(readme) == 1 and readme[0].text.startswith(repository[0].text + "/") and "README.md" in readme[0].text
    assert root.findtext("p:date", namespaces=NS) == newest_change()[1]
    assert root.findtext("p:version", namespaces=NS) == newest_change()[0]
    licence = root.find("p:license", NS)
    assert licence.text == "LGPL-2.1-or-later" and os.path.isfile(os.path.join(ROOT, licence.get("file")))
    assert "@" in root.find("p:maintainer", NS).get("email")
    assert root.findtext("p:freecadmin", namespaces=NS) == "0.20.0"
    assert root.findtext("p:content/p:workbench/p:freecadmin", namespaces=NS) == "0.20.0"
    for word in ("CMM", "QIF", "DMIS", "I++ DME", "datums", "ISO 1101"):
        assert word in root.findtext("p:description", namespaces=NS), word


def test_the_declared_python_packages_cover_what_the_workbench_imports(root):
    required, optional = declared(root, False), declared(root, True)
    assert not required & optional
    assert required == CORE | {p.pip for p in PACKAGES.values() if not p.optional}
    assert optional == {p.pip for p in PACKAGES.values() if p.optional}
    pip_of = {**{name: name for name in CORE}, **{module: p.pip for module, p in PACKAGES.items()}}
    imported = imported_packages()
    assert {"numpy", "scipy", "matplotlib", "lxml"} <= imported
    assert imported <= set(pip_of), sorted(imported - set(pip_of))
    assert {pip_of[module] for module in imported} == required | optional


def test_the_addon_manager_installs_what_it_is_said_to():
    if not os.path.isfile(ALLOW_LIST):
        pytest.skip(f"this FreeCAD has no Addon Manager allow-list ({ALLOW_LIST})")
    with open(ALLOW_LIST, encoding="utf-8") as handle:
        allowed = {line.strip().lower() for line in handle if line.strip() and not line.startswith("#")}
    assert CORE <= allowed
    for package in PACKAGES.values():
        assert (package.pip in allowed) == package.addon_manager, package
        assert package.addon_manager or package.optional, f"{package.pip}: required but not installable"
