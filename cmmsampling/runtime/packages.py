"""The Python packages some features need beyond numpy and scipy, and the one-line refusal of a
feature whose package this FreeCAD's Python cannot import.

``package.xml`` declares each of them for the Addon Manager (tests/package/test_package_xml.py
holds the two lists together); the rest of the workbench works without them.
"""
from __future__ import annotations

import functools
import importlib
import sys
from dataclasses import dataclass

from ..geometry.validation import InputError


@dataclass(frozen=True)
class Package:
    """One Python package beyond numpy and scipy: module, the name a user imports; pip, its name
    on PyPI and in package.xml; debian, the Debian and Ubuntu package that holds it; addon_manager:
    whether the Addon Manager installs it (its allow-list of Python packages names it);
    optional: declared optional in package.xml (a feature's speed or reach, not the workbench)."""

    module: str
    pip: str
    debian: str
    addon_manager: bool
    optional: bool


PACKAGES = {package.module: package for package in (
    Package("lxml", "lxml", "python3-lxml", addon_manager=True, optional=False),
    Package("matplotlib", "matplotlib", "python3-matplotlib", addon_manager=True, optional=False),
    Package("distributed", "distributed", "python3-distributed", addon_manager=False, optional=True),
    Package("threadpoolctl", "threadpoolctl", "python3-threadpoolctl", addon_manager=False, optional=True),
)}


class MissingPackage(InputError):
    """A feature needs a Python package that cannot be imported; the message names the package
    and how to install it."""


@functools.lru_cache(maxsize=None)
def available(module: str) -> bool:
    """Whether this Python imports ``module`` (tried once per process)."""
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


def require(module: str, feature: str, without: str = "") -> None:
    """MissingPackage unless ``module`` (a key of PACKAGES, or a user's format's: named as on
    PyPI and Debian's python3-<module>) can be imported. feature: what needs
    it, the message's first words (e.g. "QIF files"); without: what works without it (e.g. "CSV,
    XYZ and DMIS files"), said after the fix."""
    if available(module):
        return
    package = PACKAGES.get(module, Package(module, module, f"python3-{module}", addon_manager=False, optional=True))
    python = f"{sys.version_info.major}.{sys.version_info.minor}"
    tail = f"; {without} work without it" if without else ""
    manager = "the Addon Manager (it installs CMM Sampling's dependencies) or " if package.addon_manager else ""
    raise MissingPackage(f"{feature} need the Python package {package.pip}, which FreeCAD's Python {python} cannot "
                         f"import: install it with {manager}the system's package (Debian, Ubuntu: apt install "
                         f"{package.debian}; elsewhere: pip install {package.pip}){tail}")
