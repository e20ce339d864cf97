"""Measured points from what CMM software writes: the project's point files (DMIS output with its
FA(label) actuals, CSV with label,x,y,z,i,j,k, PC-DMIS XYZIJK) and plain labelled text, one point
a line: ``label x y z`` (or ``x y z``, labels P1..PN by order), the fields separated by commas,
semicolons or whitespace, optionally followed by the vector i j k. A number with a decimal comma is
refused with its line, as is a line of another length, a label given twice or no point at all.
"""
from __future__ import annotations

import os
import re

import numpy as np

from ..formats.csv_points import CSV_COLUMNS
from ..formats.files import check_readable
from ..formats.pointfiles import read_points, resolve_format
from ..formats.pointset import PointSet
from ..formats.text import number
from ..geometry.validation import InputError

# Lines that say nothing about a point: comments of CSV, DMIS and C-like exports.
COMMENT = re.compile(r"\s*(#|//|\$\$|;)")
FIELD_COUNTS = {3: "x y z", 4: "label x y z", 6: "x y z i j k", 7: "label x y z i j k"}


def read_measured(path):
    """The measured points of a file: a PointSet of contact points or ball centres (normals NaN
    where the file gives no vectors). DMIS and XYZIJK files and CSV files with the project's
    header go through :func:`cmmsampling.read_points`; any other text is read as labelled x, y, z
    lines (:func:`read_labelled_text`)."""
    path = check_readable(path, "measured-points file")
    if _project_file(path):
        return read_points(path)
    with open(path, encoding="utf-8-sig", errors="replace") as stream:
        point_set = read_labelled_text(stream.read(), os.fspath(path))
    point_set.metadata.update({"format": "labelled text", "path": os.path.abspath(path)})
    return point_set


def _project_file(path):
    """True for a file one of the project's readers takes: DMIS, XYZIJK (its header), CSV (its
    header with label,x,y,z,i,j,k)."""
    try:
        fmt = resolve_format(path, None)
    except InputError:
        return False
    with open(path, encoding="utf-8-sig", errors="replace") as stream:
        head = [line for line in stream.read(4096).splitlines() if line.strip() and not line.startswith("#")][:1]
    first = head[0].lower().replace(" ", "") if head else ""
    if fmt == "csv":
        return all(name in re.split(r"[,;]", first) for name in CSV_COLUMNS[:7])
    if fmt == "xyz":
        return first.startswith("xyzijk")
    return True


def read_labelled_text(text, path="<text>"):
    """PointSet from lines of ``[label] x y z [i j k]`` (comma, semicolon or whitespace between
    fields, comment lines skipped); InputError naming the line for a decimal comma, a line of
    another length than the first point's, a label given twice or no point at all."""
    rows, labels, width = [], [], None
    for line_number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or COMMENT.match(line):
            continue
        fields = _fields(line, path, line_number)
        if width is None:
            width = len(fields)
            if width not in FIELD_COUNTS:
                raise InputError(f"{path}, line {line_number}: {width} fields; a measured point is one of "
                                 f"{'; '.join(FIELD_COUNTS.values())}")
        elif len(fields) != width:
            raise InputError(f"{path}, line {line_number}: {len(fields)} fields where the first point has {width} "
                             f"({FIELD_COUNTS[width]})")
        labelled = width in (4, 7)
        label = fields[0].strip() if labelled else f"P{len(rows) + 1}"
        if label in labels:
            raise InputError(f"{path}, line {line_number}: point {label} is given twice; keep one measurement per "
                             "point")
        labels.append(label)
        rows.append([number(field, path, line_number, name)
                     for field, name in zip(fields[int(labelled):], ("x", "y", "z", "i", "j", "k"))])
    if not rows:
        raise InputError(f"{path}: no measured point found; write one point a line as label, x, y, z")
    data = np.array(rows)
    normals = data[:, 3:] if data.shape[1] == 6 else np.full((len(data), 3), np.nan)
    return PointSet(labels, data[:, :3], normals)


def _fields(line, path, line_number):
    """The fields of a line: split at semicolons where it has any, else at commas, else at
    whitespace; a number with a comma inside (12,5 between semicolons or blanks) is a decimal
    comma, refused."""
    if ";" in line:
        fields = [field.strip() for field in line.split(";")]
        for field in fields[1:]:
            if re.fullmatch(r"[-+]?\d*,\d+", field):
                raise InputError(f"{path}, line {line_number}: {field!r} has a decimal comma; write numbers with a "
                                 f"decimal point ({field.replace(',', '.')})")
        return [field for field in fields if field]
    tokens = line.split()
    commas = [token for token in tokens if re.fullmatch(r"[-+]?\d*,\d+", token)]
    if len(tokens) in FIELD_COUNTS and commas:
        raise InputError(f"{path}, line {line_number}: {commas[0]!r} has a decimal comma; write numbers with a "
                         f"decimal point ({commas[0].replace(',', '.')})")
    if "," in line:
        return [field.strip() for field in line.split(",")]
    return tokens
