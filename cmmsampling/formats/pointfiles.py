"""Point files: the formats probe points are written in and read from, one module each
(:mod:`.dmis`, :mod:`.xyzijk`, :mod:`.csv_points`, :mod:`.qif`, each with its FileFormat record,
registered here), found by name or by a file's extension.

All of them hold, per point, x, y, z in mm and the unit approach vector i, j, k (out of the
material: the probe travels along -ijk). DMIS and CSV also hold labels and ``key: value``
comments with the facts of the points (source face, strategy, frame, probe radius, deviation
figures); CSV adds the face parameters u, v and each point's deviation where known.
"""
from __future__ import annotations

import os

from ..geometry.validation import InputError, check_choice
from . import csv_points, dmis, qif, xyzijk
from .files import path_of, read_text
from .pointset import PointSet
from .registry import (FORMATS, FileFormat, export_filter, extensions, register_format, require_packages,
                       unregister_format)

__all__ = ["FORMATS", "FileFormat", "READER_KEYS", "export_filter", "points_from_text", "read_points",
           "register_format", "resolve_format", "unregister_format"]

for _record in (dmis.FORMAT, xyzijk.FORMAT, csv_points.FORMAT, qif.FORMAT):
    register_format(_record)
READER_KEYS = ("format", "path", "dmis_features", "dmis_units", "xyz_units", "labels")


def resolve_format(path, format=None):
    """The format name for path: ``format`` if given, else from the extension (the registered
    formats' extensions).

    ValueError listing the formats and their extensions when neither tells; MissingPackage
    naming the package and how to install it when the format needs one this Python lacks
    (QIF: lxml).
    """
    name = _format_name(path, format)
    require_packages(FORMATS[name])
    return name


def _format_name(path, format):
    """The registered format's name given, or of path's extension (see resolve_format)."""
    if format is not None:
        return check_choice("format", str(format).lower(), list(FORMATS))
    extension = os.path.splitext(os.fspath(path))[1].lower()
    by_extension = extensions()
    if extension in by_extension:
        return by_extension[extension]
    known = "; ".join(f"{name!r} ({', '.join(record.extensions)})" for name, record in FORMATS.items())
    raise InputError(
        f"cannot tell the format of {os.fspath(path)!r} from its extension {extension!r}; "
        f"use one of these extensions or give format=: {known}"
    )


def read_points(path: str | os.PathLike, format: str | None = None) -> PointSet:
    """Read probe points from a DMIS, PC-DMIS XYZ, CSV or QIF 3.0 file (format from the extension
    unless given); QIF: the measured points of a results file, else the planned ones (:mod:`.qif.read`).

    DMIS: the FEAT/POINT,CART statements (the actual ``FA(...)`` ones of a DMIS output file when
    there are any, else the nominal ``F(...)`` ones), in mm whatever its UNITS; XYZ: labels P1..PN
    by position (``labels: by order``), INCH files converted to mm; CSV: label, x..k and, where present, u, v and deviation.
    Metadata stated in the file's comments comes back in ``metadata`` (``probe_radius_mm``, ``frame``,
    ``frame_origin_mm``, ... where stated), plus ``format`` and ``path``.
    Returns a PointSet; ValueError naming the file and line for what cannot be read, InputError
    for a file that is no regular file or holds more than a point file may
    (:func:`cmmsampling.formats.files.read_text`).
    """
    fmt = resolve_format(path_of(path, "point file"), format)
    return points_from_text(read_text(path, "point file"), os.fspath(path), fmt)


def points_from_text(text: str, path: str, format: str) -> PointSet:
    """The PointSet in a point file's text read as the registered format named ``format``; path:
    the file's, for messages and the metadata's ``path`` (``format`` there too)."""
    point_set = FORMATS[format].read(text, path)
    point_set.metadata.update({"format": format, "path": os.path.abspath(path)})
    return point_set
