"""The columns of a measured-points table named by its header, as CMM software writes them.

A header names the columns in any case and order: the label (``name``, ``label``, ``id``,
``point``, ``feature``, ...), x, y, z and optionally the vector i, j, k. A coordinate's unit, in
brackets or as a word of its own (``X [inch]``, ``X (in)``, ``x_mm``, ``Z um``, any case), is read
and the values converted to mm (LENGTH_UNITS_MM); text in brackets that is neither a unit nor a
nominal or measured mark (``X [furlong]``) is refused, so that no value is read in a unit the file
did not mean; no unit: mm. Reports that give each coordinate twice,
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
# The length units a header may give a coordinate in: mm per unit (u stands for the micro sign).
LENGTH_UNITS_MM = {"mm": 1.0, "millimeter": 1.0, "millimeters": 1.0, "millimetre": 1.0, "millimetres": 1.0,
                   "cm": 10.0, "m": 1000.0, "meter": 1000.0, "meters": 1000.0, "metre": 1000.0, "metres": 1000.0,
                   "um": 1e-3, "micron": 1e-3, "microns": 1e-3, "micrometer": 1e-3, "micrometers": 1e-3,
                   "micrometre": 1e-3, "micrometres": 1e-3, "in": 25.4, "inch": 25.4, "inches": 25.4}
BRACKETS = re.compile(r"[\[(](.*?)[\])]")


def header_columns(fields: list[str], path: str, line_number: int) -> dict[str, Any] | None:
    """{"label": column or None, "x", "y", "z": column, "i", "j", "k": column or None, "units":
    {"x", "y", "z": (mm per unit, the unit as written, '' for none)}} from a header's fields, or
    None where the fields do not name x, y and z (not a header).
    InputError where they name only nominal coordinates, or a coordinate's unit this reader does
    not know."""
    found: dict[str, dict[str, int]] = {}
    for column, field in enumerate(fields):
        name, kind = _column_name(field)
        if name is not None:
            found.setdefault(name, {}).setdefault(kind, column)
    if not all(name in found for name in "xyz"):
        return None
    chosen: dict[str, Any] = {name: _measured_column(found.get(name), name, path, line_number)
                              for name in COORDINATES}
    chosen["label"] = found.get("label", {}).get("plain")
    if any(chosen[name] is None for name in "xyz"):
        return None
    if any(chosen[name] is None for name in "ijk"):
        chosen.update(i=None, j=None, k=None)
    chosen["units"] = {name: column_unit(fields[chosen[name]], path, line_number) for name in "xyz"}
    return chosen


def column_unit(field: str, path: str, line_number: int) -> tuple[float, str]:
    """(mm per unit, the unit as written or '' for none: mm) of a coordinate column's header
    field; InputError where its brackets hold a word that is no unit (LENGTH_UNITS_MM) nor a
    nominal or measured mark, or it names two units."""
    text = _plain_letters(field)
    units = [word for word in _words(BRACKETS.sub(" ", text)) if word in LENGTH_UNITS_MM]
    for inside in BRACKETS.findall(text):
        words = _words(inside)
        if all(word in LENGTH_UNITS_MM for word in words):
            units += words
        elif not all(word in MEASURED_WORDS + NOMINAL_WORDS for word in words):
            raise InputError(f"{path}, line {line_number}: column {field.strip()!r} gives its unit as "
                             f"{inside.strip()!r}, which this reader does not know; name the unit as mm, um, cm, m "
                             "or in (inch)")
    if len(set(LENGTH_UNITS_MM[unit] for unit in units)) > 1:
        raise InputError(f"{path}, line {line_number}: column {field.strip()!r} names two units ({', '.join(units)}); "
                         "give one")
    return (LENGTH_UNITS_MM[units[0]], units[0]) if units else (1.0, "")


def _plain_letters(field: str) -> str:
    """A header field in lower case, the micro sign written u."""
    return field.lower().replace("\u00b5", "u").replace("\u03bc", "u")


def _words(text: str) -> list[str]:
    """The words and numbers of a header field's text."""
    return re.findall(r"[a-z]+|\d+", text)


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
    text = _plain_letters(field)
    inside = [word for bracket in BRACKETS.findall(text) for word in _words(bracket)
              if word in MEASURED_WORDS + NOMINAL_WORDS]
    words = [word for word in _words(BRACKETS.sub(" ", text)) if word not in LENGTH_UNITS_MM] + inside
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
