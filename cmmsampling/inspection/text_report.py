"""Point locations from a CMM's text report, PC-DMIS's legacy layout: a block per point,

    DIM LOC1= LOCATION OF POINT P1  UNITS=MM
    AX    NOMINAL      +TOL      -TOL      MEAS       DEV    OUTTOL
    X      10.0000    0.0100    0.0100   10.0021    0.0021    0.0000
    Y      ...
    Z      ...

the point's label after ``OF POINT``, its measured x, y, z in the column headed MEAS (or ACTUAL), in
the block's UNITS (MM or IN); other dimensions in the report (a circle's diameter, a plane's
flatness) are passed over.
"""
from __future__ import annotations

import re
from typing import Any

import numpy as np

from ..formats.pointset import PointSet
from ..formats.text import number
from ..geometry.validation import InputError

LOCATION = re.compile(r"\s*DIM\s+\S+\s*=\s*LOCATION\s+OF\s+POINT\s+(\S+)(?:.*?UNITS\s*=\s*(MM|IN))?", re.IGNORECASE)
AXES_HEADER = re.compile(r"\s*AX\s", re.IGNORECASE)
MEASURED_HEADINGS = ("MEAS", "ACTUAL", "MEASURED")
UNITS_MM = {"MM": 1.0, "IN": 25.4}


def is_text_report(text: str) -> bool:
    """True where text holds a point location block of a CMM text report."""
    return any(LOCATION.match(line) for line in text.splitlines()[:200])


def read_text_report(text: str, path: str = "<text>") -> PointSet:
    """PointSet of the measured point locations of a text report (module docstring); InputError
    naming the line where a block's x, y or z or its MEAS column is missing."""
    labels: list[str]
    rows: list[list[float]]
    block: dict[str, Any] | None
    labels, rows, block = [], [], None
    for line_number, line in enumerate(text.splitlines(), start=1):
        found = LOCATION.match(line)
        if found is not None:
            block = _close(block, labels, rows, path)
            block = {"label": found.group(1), "scale": UNITS_MM[(found.group(2) or "MM").upper()],
                     "line": line_number, "column": None, "values": {}}
            continue
        if block is None:
            continue
        fields = line.split()
        if AXES_HEADER.match(line):
            headings = [field.upper() for field in fields]
            block["column"] = next((headings.index(h) for h in MEASURED_HEADINGS if h in headings), None)
        elif fields and fields[0].upper() in ("X", "Y", "Z") and block["column"] is not None:
            if len(fields) <= block["column"]:
                raise InputError(f"{path}, line {line_number}: {fields[0]} has no measured value in the MEAS column")
            block["values"][fields[0].upper()] = number(fields[block["column"]], path, line_number, fields[0].lower())
    _close(block, labels, rows, path)
    if not rows:
        raise InputError(f"{path}: no point location (DIM ... LOCATION OF POINT) with measured X, Y and Z found")
    return PointSet(labels, np.array(rows), np.full((len(rows), 3), np.nan), metadata={"format": "text report"})


def _close(block: dict[str, Any] | None, labels: list[str], rows: list[list[float]],
           path: str) -> dict[str, Any] | None:
    """Take a finished block's point into labels and rows; InputError where it lacks x, y or z."""
    if block is not None:
        missing = [axis for axis in "XYZ" if axis not in block["values"]]
        if missing:
            raise InputError(f"{path}, line {block['line']}: point {block['label']} has no measured "
                             f"{', '.join(missing)} (a MEAS column under AX, rows X, Y, Z)")
        if block["label"] in labels:
            raise InputError(f"{path}, line {block['line']}: point {block['label']} is given twice; keep one "
                             "measurement per point")
        labels.append(block["label"])
        rows.append([block["values"][axis] * block["scale"] for axis in "XYZ"])
    return None
