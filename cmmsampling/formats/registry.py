"""The point-file formats' records: each format said once, in the module that reads and writes
it, and the table :data:`FORMATS` that export(), read_points(), the command line's ``--out``,
the Export panel and File > Export read.

The built-in formats are registered by :mod:`.pointfiles`; a user's module calls
:func:`register_format` with its own :class:`FileFormat`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from ..geometry.validation import InputError, InputTypeError
from ..runtime.packages import require

if TYPE_CHECKING:   # for the annotations only: the formats' modules import this one
    import numpy as np

    from .pointset import PointSet

EXPORT_TITLE = "CMM probe points"


@dataclass(frozen=True)
class WriteOptions:
    """What the writers need besides the points: the program's name (the file's name without its
    extension, or the one given; a format that names its programs cleans it to what its language
    takes, as DMIS does), approach, retract and search distances (mm), and whether to write the
    descriptive comments."""

    name: str
    approach: float
    retract: float
    search: float
    comments: bool
    probe: dict | None = None


class Writer(Protocol):
    """A format's writer: (the PointSet as written, the facts that say what its numbers mean, the
    WriteOptions) -> the file's text."""

    def __call__(self, point_set: PointSet, facts: dict[str, Any], options: WriteOptions, /) -> str: ...


class Reader(Protocol):
    """A format's reader: (the file's text, its path for messages) -> PointSet; ValueError naming
    the path and the line."""

    def __call__(self, text: str, path: str, /) -> PointSet: ...


class ResultsWriter(Protocol):
    """(an Inspection, the part's name) -> the text of a file of its results (QIF)."""

    def __call__(self, inspection: Any, part: str, /) -> str: ...


class MeasuredWriter(Protocol):
    """(the nominal PointSet, the measured points (N, 3) mm, the program's name) -> the text a
    CMM writes after measuring them (DMIS output)."""

    def __call__(self, nominal: PointSet, actual: np.ndarray, name: str, /) -> str: ...


class Unmeasured(Protocol):
    """(a PointSet read from a file of the format) -> why its points are no measurement (a
    program's planned points: what to give instead), or None for measured points."""

    def __call__(self, point_set: PointSet, /) -> str | None: ...


class Recogniser(Protocol):
    """(a file's first line that is no comment, lower case without blanks) -> whether the file
    is the format's own."""

    def __call__(self, first: str, /) -> bool: ...


@dataclass(frozen=True)
class FileFormat:
    """One point-file format.

    name: the identifier export() and read_points() take as ``format=`` (lower case); title: its
    name in messages (e.g. "DMIS"); description: one line for file dialogs and ``--help``;
    extensions: file extensions with the dot, lower case, the first the one a new file gets;
    encoding: of the file's text; write: (PointSet, facts dict, ExportOptions) -> the file's
    text; read: (text, path) -> PointSet, raising ValueError naming the path and line;
    contact_nominals: the format's points are nominal surface points whose probe radius the CMM
    takes off itself (DMIS's FEAT/POINT and PTMEAS): a probe radius is stated (ball_radius_mm),
    never added to the points; write_results: (Inspection, part name) -> the file's text, for a
    format that holds an inspection's results (QIF), else None; measured: a CMM's measured points
    are written in it and read back as a measurement (cmmsampling.simulate_measurement writes
    them, inspect reads them); write_measured: (nominal PointSet, measured points (N, 3) mm,
    program name) -> the text a CMM writes after measuring, for a format whose measured file
    differs from its planned one (DMIS output), else None (``write`` of the measured points);
    recognises: (the file's first line that is no comment, lower case without blanks) -> True
    where a file with one of its extensions is the format's own (its header), None for every
    such file (a file not recognised is read as a labelled table of measured points);
    packages: the Python modules (keys of cmmsampling.runtime.packages.PACKAGES) it needs beyond
    numpy and scipy, e.g. QIF's ("lxml",): without one, the format is refused in one line; live:
    a CMM's touches are written in it as they arrive (cmmsampling.measure rewrites the file after
    each touch with ``write``) and read back from it as measured points; unmeasured: (PointSet
    read) -> why its points are no measurement (a DMIS program's nominals, a QIF plan), or None,
    for a format that holds planned points as well as measured ones.
    """

    name: str
    title: str
    description: str
    extensions: tuple[str, ...]
    encoding: str
    write: Writer
    read: Reader
    contact_nominals: bool = False
    write_results: ResultsWriter | None = None
    measured: bool = False
    write_measured: MeasuredWriter | None = None
    recognises: Recogniser | None = None
    packages: tuple[str, ...] = ()
    live: bool = False
    unmeasured: Unmeasured | None = None

    @property
    def patterns(self) -> str:
        """Its extensions as file-dialog patterns, e.g. '*.dmi *.dmis'."""
        return " ".join("*" + extension for extension in self.extensions)

    def __post_init__(self):
        bad = [e for e in self.extensions if not (e.startswith(".") and e == e.lower() and len(e) > 1)]
        if not self.extensions or bad:
            raise InputError(f"format {self.name!r}: extensions must be lower case and start with a dot, "
                             f"e.g. ('.dmi',), got {self.extensions!r}")


FORMATS: dict[str, FileFormat] = {}


def register_format(record: FileFormat) -> FileFormat:
    """Add a FileFormat (replacing one of the same name): export(), read_points(), the command
    line and the Export panel offer it from then on. Returns the record."""
    if not isinstance(record, FileFormat):
        raise InputTypeError(f"register_format takes a cmmsampling FileFormat record, got {type(record).__name__}")
    FORMATS[record.name] = record
    return record


def unregister_format(name: str) -> None:
    """Remove the format named ``name`` (KeyError when there is none)."""
    del FORMATS[name]


def extensions() -> dict[str, str]:
    """{extension: format name} of every registered format."""
    return {extension: name for name, record in FORMATS.items() for extension in record.extensions}


def require_packages(record: FileFormat) -> None:
    """MissingPackage, in one line, when the format needs a Python package this Python cannot
    import (its ``packages``); the message names the formats that work without it."""
    for package in record.packages:
        require(package, f"{record.title} files", formats_without(package))


def formats_without(package: str) -> str:
    """The formats that need no ``package``, in words: e.g. 'DMIS, XYZIJK and CSV files'."""
    titles = [record.title for record in FORMATS.values() if package not in record.packages]
    return f"{', '.join(titles[:-1])} and {titles[-1]} files" if len(titles) > 1 else "".join(titles) + " files"


def live_records() -> list[FileFormat]:
    """The FileFormats a live run writes its touches in as they arrive (``live``)."""
    return [record for record in FORMATS.values() if record.live]


def measured_records() -> list[FileFormat]:
    """The FileFormats a measurement is written in and read back from (``measured``)."""
    return [record for record in FORMATS.values() if record.measured]


def measured_filter() -> str:
    """The file-dialog filters for measured points: every registered format's extensions (the
    readers of measured files take them all, and labelled tables of any of them), then all files."""
    patterns = " ".join(record.patterns for record in FORMATS.values())
    return f"Measured points ({patterns});;All files (*)"


def export_filter() -> str:
    """One file-dialog filter for every format, as FreeCAD's File > Export lists it, e.g.
    'CMM probe points: DMIS, XYZIJK text, CSV (*.dmi *.dmis *.xyz *.txt *.csv)'."""
    titles = ", ".join(record.title for record in FORMATS.values())
    patterns = " ".join(record.patterns for record in FORMATS.values())
    return f"{EXPORT_TITLE}: {titles} ({patterns})"
