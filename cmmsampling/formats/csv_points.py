"""CSV point files: ``# key: value`` comments, a header, one row per point with its label, x..k,
the face parameters u, v and the deviation where known."""
import csv
import io
import re

import numpy as np

from ..geometry.validation import InputError
from .pointset import PointSet
from .registry import FileFormat
from .text import (COORDINATE_DECIMALS, PARAMETER_DECIMALS, VECTOR_DECIMALS, comment_entries, fixed,
                   metadata_comment_lines, number, parse_metadata_comments)

NAME = "CSV"
DESCRIPTION = "CSV with a header (label,x,y,z,i,j,k,u,v)"
EXTENSIONS = (".csv",)
ENCODING = "utf-8"
CSV_COMMENT = "#"
CSV_COLUMNS = ("label", "x", "y", "z", "i", "j", "k", "u", "v")
TEXT_COLUMNS = ("label", "face")
# The probe's axis at each point (ball towards head), where the run knew the part.
AXIS_COLUMNS = ("axis_i", "axis_j", "axis_k")


def write(point_set, facts, options):
    """CSV: '# key: value' comments, header label,x,y,z,i,j,k,u,v[,deviation][,face][,axis_i,axis_j,
    axis_k], one row per point (u, v empty where unknown; face: the face a plan's point lies on;
    axis: the probe's axis, ball towards head, where the run knew the part)."""
    count = len(point_set)
    columns = [np.array(point_set.labels, dtype=object)[:, None],
               fixed(point_set.points, COORDINATE_DECIMALS), fixed(point_set.normals, VECTOR_DECIMALS),
               np.full((count, 2), "") if point_set.uv is None else fixed(point_set.uv, PARAMETER_DECIMALS)]
    header = list(CSV_COLUMNS)
    if point_set.deviation is not None:
        columns.append(fixed(point_set.deviation, COORDINATE_DECIMALS)[:, None])
        header.append("deviation")
    if point_set.faces is not None:
        columns.append(np.array(point_set.faces, dtype=object)[:, None])
        header.append("face")
    if point_set.axes is not None:
        columns.append(fixed(point_set.axes, VECTOR_DECIMALS))
        header += list(AXIS_COLUMNS)
    buffer = io.StringIO()
    buffer.write("".join(f"{line}\n" for line in metadata_comment_lines(
        comment_entries(point_set, facts, options), f"{CSV_COMMENT} ")))
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(np.concatenate(columns, axis=1).tolist())
    return buffer.getvalue()


def read(text, path="<text>"):
    """PointSet from CSV: leading ``# key: value`` comment lines, a header with label,x,y,z,i,j,k and
    optionally u,v (empty where unknown), deviation (mm) and face, then one line per point with as
    many cells as the header. Cells are separated by commas, or by semicolons where the header
    has no comma; a number with a decimal comma is refused with its line."""
    lines = list(enumerate(text.splitlines(), start=1))
    lines = [(n, line) for n, line in lines if line.strip()]
    head = next((i for i, (_, line) in enumerate(lines) if not line.startswith(CSV_COMMENT)), len(lines))
    comments = [(False, line[len(CSV_COMMENT):]) for _, line in lines[:head]]
    numbered = lines[head:]
    if len(numbered) < 2:
        raise InputError(f"{path}: expected a header line and at least one point")
    rows = list(csv.reader((line for _, line in numbered), delimiter=_delimiter(numbered[0][1])))
    header = [name.strip().lower() for name in rows[0]]
    missing = [name for name in CSV_COLUMNS[:7] if name not in header]
    if missing:
        raise InputError(
            f"{path}, line {numbered[0][0]}: the header lacks the column(s) {', '.join(missing)}; "
            f"got {rows[0]}"
        )
    line_numbers = [n for n, _ in numbered[1:]]
    cells = rows[1:]
    for row, line in zip(cells, line_numbers):
        if len(row) != len(header):
            raise InputError(f"{path}, line {line}: {len(row)} cells where the header has {len(header)}; "
                             "is the row cut short, or a comma too many?")
    columns = dict(zip(header, map(list, zip(*cells))))
    numbers = {name: _column(columns[name], name, path, line_numbers) for name in header
               if name not in TEXT_COLUMNS}
    empty = np.full(len(cells), np.nan)
    return PointSet(
        labels=columns["label"],
        points=_complete(numbers, "xyz", path),
        normals=_complete(numbers, "ijk", path),
        uv=_known(np.column_stack([numbers.get(c, empty) for c in "uv"]), "u, v", path),
        deviation=_known(numbers.get("deviation", empty), "deviation", path),
        metadata=parse_metadata_comments(comments),
        faces=columns.get("face"),
        axes=np.column_stack([numbers[c] for c in AXIS_COLUMNS]) if set(AXIS_COLUMNS) <= set(numbers) else None,
    )


def _delimiter(header):
    """The header line's cell separator: ';' where it has semicolons and no commas, else ','."""
    return ";" if ";" in header and "," not in header else ","


def _complete(numbers, names, path):
    """(N, len(names)) array of the named columns; ValueError when a cell is empty."""
    for name in names:
        if np.isnan(numbers[name]).any():
            raise InputError(f"{path}: column {name} has empty cells")
    return np.column_stack([numbers[name] for name in names])


def _column(cells, name, path, line_numbers):
    """Floats of one CSV column, NaN for empty cells; ValueError naming the line of a bad cell."""
    values = np.full(len(cells), np.nan)
    for index, (cell, line) in enumerate(zip(cells, line_numbers)):
        if cell.strip():
            values[index] = number(cell, path, line, name)
    return values


def _known(values, name, path):
    """values, or None when all are NaN (unknown); ValueError when only some are."""
    missing = np.isnan(values)
    if missing.all():
        return None
    if missing.any():
        raise InputError(f"{path}: {name} given for some points only")
    return values


def recognises(first):
    """True for a header that names label, x, y, z, i, j, k (first: the file's first line that is
    no comment, lower case without blanks)."""
    return all(name in re.split(r"[,;]", first) for name in CSV_COLUMNS[:7])


FORMAT = FileFormat("csv", NAME, DESCRIPTION, EXTENSIONS, ENCODING, write, read, measured=True, recognises=recognises,
                    live=True)
