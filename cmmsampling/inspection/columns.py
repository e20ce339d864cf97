"""The columns of a measured-points table named by its header, as CMM software writes them.

A header names the columns in any case and order: the label (``name``, ``label``, ``id``,
``point``, ``feature``, ...), x, y, z and optionally the vector i, j, k; a unit in brackets or
after an underscore (``X [mm]``, ``x_mm``) is ignored. Reports that give each coordinate twice,
nominal and measured (``X nom``, ``X act``, ``Meas X``, ``XACT``), are read from the measured
columns; a table with nominal columns only is refused, since it holds no measurement.
"""
from __future__ import annotations

import re
from typing import Any

from ..geometry.validation import InputError

LABEL_NAMES = {"name", "label", "id", "point", "pointname", "pointid", "pointlabel", "pointno", "pointnumber",
               "feature", "featurename", "pt", "pnt", "no", "nr", "number", "ident"}
COORDINATES = ("x", "y", "z", "i", "j", "k")
VECTOR_NAMES = {"nx": "i", "ny": "j", "nz": "k"}
MEASURED_WORDS = ("measured", "actual", "meas", "act", "mea")
NOMINAL_WORDS = ("nominal", "theoretical", "theo", "target", "nom")
UNIT_WORDS = {"mm", "inch", "in", "um", "m"}


def header_columns(fields: list[str], path: str, line_number: int) -> dict[str, Any] | None:
    """{"label": column or None, "x", "y", "z": column, "i", "j", "k": column or None} from a
    header's fields, or None where the fields do not name x, y and z (not a header).
    InputError where they name only nominal coordinates."""
    found: dict[str, dict[str, int]] = {}
    for column, field in enumerate(fields):
        name, kind = _column_name(field)
        if name is not None:
            found.setdefault(name, {}).setdefault(kind, column)
    if not all(name in found for name in "xyz"):
        return None
    chosen = {name: _measured_column(found.get(name), name, path, line_number) for name in COORDINATES}
    chosen["label"] = found.get("label", {}).get("plain")
    if any(chosen[name] is None for name in "xyz"):
        return None
    if any(chosen[name] is None for name in "ijk"):
        chosen.update(i=None, j=None, k=None)
    return chosen


def _measured_column(kinds: dict[str, int] | None, name: str, path: str, line_number: int) -> int | None:
    """The column of one coordinate: its measured one, else its plain one; InputError where the
    header gives it as nominal only."""
    if not kinds:
        return None
    if "measured" in kinds or "plain" in kinds:
        return kinds.get("measured", kinds.get("plain"))
    if name in "xyz":
        raise InputError(f"{path}, line {line_number}: the columns give nominal coordinates only ({name} nominal), "
                         "no measured values; give the file the CMM wrote after measuring")
    return None


def _column_name(field: str) -> tuple[str | None, str]:
    """(what the column holds: 'label' or one of COORDINATES or None, its kind: 'measured',
    'nominal' or 'plain') of a header field."""
    text = re.sub(r"[\[(].*?[\])]", " ", field.lower())
    words = [word for word in re.findall(r"[a-z]+|\d+", text) if word not in UNIT_WORDS]
    joined = "".join(words)
    if joined in LABEL_NAMES:
        return "label", "plain"
    for kind, marks in (("measured", MEASURED_WORDS), ("nominal", NOMINAL_WORDS)):
        for mark in marks:
            rest = [word for word in words if word != mark]
            if len(rest) < len(words):
                return _coordinate("".join(rest)), kind
            if joined.startswith(mark) or joined.endswith(mark):
                return _coordinate(joined[len(mark):] if joined.startswith(mark) else joined[:-len(mark)]), kind
    return _coordinate(joined), "plain"


def _coordinate(name: str) -> str | None:
    """x, y, z, i, j or k for a column's bare name, else None."""
    name = VECTOR_NAMES.get(name, name)
    return name if name in COORDINATES else None
