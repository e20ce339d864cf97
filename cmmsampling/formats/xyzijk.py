"""PC-DMIS XYZIJK text: a header, then x,y,z,i,j,k per line (no labels, no comments)."""
import re

import numpy as np

from ..geometry.validation import InputError
from .pointset import PointSet
from .registry import FileFormat
from .text import COORDINATE_DECIMALS, VECTOR_DECIMALS, fixed, numbers

NAME = "XYZIJK text"
DESCRIPTION = "PC-DMIS XYZIJK text (x,y,z,i,j,k per line)"
EXTENSIONS = (".xyz", ".txt")
ENCODING = "ascii"
XYZ_HEADER = "XYZIJK    METRIC"
XYZ_UNITS = {"METRIC": 1.0, "INCH": 25.4}


def write(point_set, facts, options):
    """PC-DMIS XYZIJK text: 'XYZIJK' in columns 1-6, 'METRIC' in 11-16, then x,y,z,i,j,k per line."""
    rows = np.concatenate(
        [fixed(point_set.points, COORDINATE_DECIMALS), fixed(point_set.normals, VECTOR_DECIMALS)], axis=1
    )
    return "\n".join([XYZ_HEADER] + [",".join(row) for row in rows.tolist()]) + "\n"


def read(text, path="<text>"):
    """PointSet from PC-DMIS XYZIJK text: header ``XYZIJK    METRIC`` (or INCH), then x,y,z,i,j,k lines."""
    lines = text.splitlines()
    header = lines[0].split() if lines else []
    if len(header) not in (1, 2) or header[0].upper() != "XYZIJK":
        raise InputError(f"{path}, line 1: expected the header 'XYZIJK    METRIC' (or INCH), got {lines[:1]}")
    units = header[1].upper() if len(header) == 2 else "METRIC"
    if units not in XYZ_UNITS:
        raise InputError(f"{path}, line 1: units must be METRIC or INCH, got {header[1]!r}")
    rows = [
        numbers(re.split(r"[,\s]+", line.strip()), 6, path, number)
        for number, line in enumerate(lines[1:], start=2) if line.strip()
    ]
    if not rows:
        raise InputError(f"{path}: no points after the header")
    data = np.array(rows)
    labels = [f"P{index + 1}" for index in range(len(data))]
    return PointSet(labels, data[:, :3] * XYZ_UNITS[units], data[:, 3:],
                    metadata={"xyz_units": units, "labels": "by order"})


def recognises(first):
    """True for the XYZIJK header (first: the file's first line that is no comment, lower case
    without blanks)."""
    return first.startswith("xyzijk")


FORMAT = FileFormat("xyz", NAME, DESCRIPTION, EXTENSIONS, ENCODING, write, read, recognises=recognises, live=True)
