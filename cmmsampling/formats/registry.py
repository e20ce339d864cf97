"""The point-file formats' records: each format said once, in the module that reads and writes
it, and the table :data:`FORMATS` that export(), read_points(), the command line's ``--out``,
the Export panel and File > Export read.

The built-in formats are registered by :mod:`.pointfiles`; a user's module calls
:func:`register_format` with its own :class:`FileFormat`.
"""
from dataclasses import dataclass

from ..geometry.validation import InputError, InputTypeError

EXPORT_TITLE = "CMM probe points"


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
    such file (a file not recognised is read as a labelled table of measured points).
    """

    name: str
    title: str
    description: str
    extensions: tuple
    encoding: str
    write: object
    read: object
    contact_nominals: bool = False
    write_results: object = None
    measured: bool = False
    write_measured: object = None
    recognises: object = None

    @property
    def patterns(self):
        """Its extensions as file-dialog patterns, e.g. '*.dmi *.dmis'."""
        return " ".join("*" + extension for extension in self.extensions)

    def __post_init__(self):
        bad = [e for e in self.extensions if not (e.startswith(".") and e == e.lower() and len(e) > 1)]
        if not self.extensions or bad:
            raise InputError(f"format {self.name!r}: extensions must be lower case and start with a dot, "
                             f"e.g. ('.dmi',), got {self.extensions!r}")


FORMATS = {}


def register_format(record):
    """Add a FileFormat (replacing one of the same name): export(), read_points(), the command
    line and the Export panel offer it from then on. Returns the record."""
    if not isinstance(record, FileFormat):
        raise InputTypeError(f"register_format takes a cmmsampling FileFormat record, got {type(record).__name__}")
    FORMATS[record.name] = record
    return record


def unregister_format(name):
    """Remove the format named ``name`` (KeyError when there is none)."""
    del FORMATS[name]


def extensions():
    """{extension: format name} of every registered format."""
    return {extension: name for name, record in FORMATS.items() for extension in record.extensions}


def measured_records():
    """The FileFormats a measurement is written in and read back from (``measured``)."""
    return [record for record in FORMATS.values() if record.measured]


def measured_filter():
    """The file-dialog filters for measured points: every registered format's extensions (the
    readers of measured files take them all, and labelled tables of any of them), then all files."""
    patterns = " ".join(record.patterns for record in FORMATS.values())
    return f"Measured points ({patterns});;All files (*)"


def export_filter():
    """One file-dialog filter for every format, as FreeCAD's File > Export lists it, e.g.
    'CMM probe points: DMIS, XYZIJK text, CSV (*.dmi *.dmis *.xyz *.txt *.csv)'."""
    titles = ", ".join(record.title for record in FORMATS.values())
    patterns = " ".join(record.patterns for record in FORMATS.values())
    return f"{EXPORT_TITLE}: {titles} ({patterns})"
