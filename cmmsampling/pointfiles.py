"""Point files: the DMIS, PC-DMIS XYZ and CSV formats of probe points, and reading them back.

All three hold, per point, x, y, z in mm and the unit approach vector i, j, k (out of the
material: the probe travels along -ijk). DMIS and CSV also hold labels and ``key: value``
comments with the facts of the points (source face, strategy, frame, probe radius, deviation
figures); CSV adds the face parameters u, v and each point's deviation where known.
"""
import csv
import json
import os
import re

import numpy as np

from .pointset import PointSet
from .validation import check_choice

FORMATS = {
    "dmis": "DMIS 5.2 input program (FEAT/POINT, MEAS/POINT, PTMEAS)",
    "xyz": "PC-DMIS XYZIJK text (x,y,z,i,j,k per line)",
    "csv": "CSV with a header (label,x,y,z,i,j,k,u,v[,deviation])",
}
EXTENSIONS = {".dmi": "dmis", ".dmis": "dmis", ".xyz": "xyz", ".txt": "xyz", ".csv": "csv"}

DMIS_COMMENT = "$$"
DMIS_COMMENT_CONTINUED = "$$+"
DMIS_CONTINUATION = "$"
CSV_COMMENT = "#"
CSV_COLUMNS = ("label", "x", "y", "z", "i", "j", "k", "u", "v")
XYZ_UNITS = {"METRIC": 1.0, "INCH": 25.4}
READER_KEYS = ("format", "path", "dmis_features", "xyz_units")
METADATA_ENTRY = re.compile(r"\s*([A-Za-z][A-Za-z0-9_]*):(.*)\Z", re.DOTALL)
DMIS_FEATURE_POINT = re.compile(r"(FA?)\(([^()]*)\)=FEAT/POINT,([A-Z]+),(.*)\Z", re.IGNORECASE)


def resolve_format(path, format=None):
    """The format name for path: ``format`` if given, else from the extension (see EXTENSIONS).

    ValueError listing the formats and their extensions when neither tells.
    """
    if format is not None:
        return check_choice("format", str(format).lower(), list(FORMATS))
    extension = os.path.splitext(os.fspath(path))[1].lower()
    if extension in EXTENSIONS:
        return EXTENSIONS[extension]
    known = "; ".join(
        f"{name!r} ({', '.join(e for e, f in EXTENSIONS.items() if f == name)})" for name in FORMATS
    )
    raise ValueError(
        f"cannot tell the format of {os.fspath(path)!r} from its extension {extension!r}; "
        f"use one of these extensions or give format=: {known}"
    )


def metadata_value_text(value):
    """One line of text for a metadata value: strings as they are, anything else as JSON."""
    if isinstance(value, str):
        return " ".join(value.splitlines())
    return json.dumps(value, default=_json_default)


def parse_metadata_value(text):
    """The value of a metadata comment: JSON where it parses, else the text itself."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def metadata_comment_lines(entries, prefix, continuation=None, width=None):
    """Comment lines ``<prefix>key: value`` for (key, text) pairs.

    With a width (characters), longer lines break before a space (or hard at the width) and go
    on in lines that start with ``continuation``; concatenating the pieces gives the text back.
    """
    lines = []
    for key, text in entries:
        line = f"{prefix}{key}: {text}"
        if width is None:
            lines.append(line)
        else:
            lines.extend(_wrapped(line, width, continuation, len(prefix) + len(key) + 2))
    return lines


def _wrapped(line, width, continuation, start):
    """Pieces of line no longer than width; no break before ``start``; later pieces after continuation."""
    pieces = []
    while len(line) > width:
        cut = line.rfind(" ", start + 1, width)
        if cut <= start:
            cut = width
        pieces.append(line[:cut])
        line = continuation + line[cut:]
        start = len(continuation)
    return pieces + [line]


def parse_metadata_comments(comments):
    """Metadata from comment bodies: (continued, text) pairs, in file order -> dict.

    A ``key: value`` body starts an entry, a continued body is appended to the entry before it,
    any other body ends it.
    """
    entries = []
    open_entry = False
    for continued, text in comments:
        if continued and open_entry:
            entries[-1][1] += text
            continue
        match = METADATA_ENTRY.match(text)
        open_entry = match is not None
        if open_entry:
            entries.append([match[1], match[2]])
    return {key: parse_metadata_value(_one_space_off(text)) for key, text in entries}


def _one_space_off(text):
    """text without the one space that follows 'key:'."""
    return text[1:] if text.startswith(" ") else text


def _json_default(value):
    """JSON for numpy scalars and arrays; their repr for anything else."""
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    return repr(value)


def read_points(path, format=None):
    """Read probe points from a DMIS, PC-DMIS XYZ or CSV file (format from the extension unless given).

    DMIS: the FEAT/POINT,CART statements (the actual ``FA(...)`` ones of a DMIS output file when
    there are any, else the nominal ``F(...)`` ones); XYZ: labels P1..PN by position, INCH files
    converted to mm; CSV: label, x..k and, where present, u, v and deviation.
    Metadata stated in the file's comments comes back in ``metadata`` (``probe_radius_mm``, ``frame``,
    ``frame_origin_mm``, ... where stated), plus ``format`` and ``path``.
    Returns a PointSet; ValueError naming the file and line for what cannot be read.
    """
    fmt = resolve_format(path, format)
    with open(path, encoding="utf-8", errors="replace", newline="") as stream:
        text = stream.read()
    point_set = READERS[fmt](text, os.fspath(path))
    point_set.metadata.update({"format": fmt, "path": os.path.abspath(path)})
    return point_set


def read_dmis(text, path="<text>"):
    """PointSet from DMIS text: FEAT/POINT,CART statements, metadata from ``$$ key: value`` comments."""
    statements, comments = dmis_statements(text)
    found = {"F": {}, "FA": {}}
    for number, statement in statements:
        match = DMIS_FEATURE_POINT.match(_without_blanks(statement))
        if match is None:
            continue
        kind, label, system, fields = match.groups()
        if system.upper() != "CART":
            raise ValueError(f"{path}, line {number}: only Cartesian points (CART) can be read, got {system}")
        found[kind.upper()][label] = _numbers(fields.split(","), 6, path, number)
    points = found["FA"] or found["F"]
    if not points:
        raise ValueError(f"{path}: no F(label)=FEAT/POINT,CART,x,y,z,i,j,k statement found")
    metadata = parse_metadata_comments(comments)
    metadata["dmis_features"] = "actual" if found["FA"] else "nominal"
    data = np.array(list(points.values()))
    return PointSet(list(points), data[:, :3], data[:, 3:], metadata=metadata)


def dmis_statements(text):
    """Logical DMIS statements and comments of text.

    Returns ([(line number, statement)], [(continued, comment body)]): a line ending in ``$`` goes
    on in the next one; ``$$`` starts a comment (``$$+`` a continued one) to the end of the line.
    """
    statements, comments = [], []
    pending, first = "", None
    for number, line in enumerate(text.splitlines(), start=1):
        code, comment = _split_comment(line)
        if comment is not None:
            continued = comment.startswith("+")
            comments.append((continued, comment[1:] if continued else comment))
        code = code.rstrip()
        if not code:
            continue
        first = first or number
        if code.endswith(DMIS_CONTINUATION):
            pending += code[:-1]
            continue
        statements.append((first, pending + code))
        pending, first = "", None
    return statements, comments


def _split_comment(line):
    """(code, comment body after '$$' or None) of one DMIS line; '$$' inside quotes is text."""
    quoted = False
    for index, character in enumerate(line):
        if character == "'":
            quoted = not quoted
        elif not quoted and line.startswith(DMIS_COMMENT, index):
            return line[:index], line[index + len(DMIS_COMMENT):]
    return line, None


def _without_blanks(statement):
    """The statement without blanks (DMIS ignores them outside text strings)."""
    return re.sub(r"\s+", "", statement)


def read_xyz(text, path="<text>"):
    """PointSet from PC-DMIS XYZIJK text: header ``XYZIJK    METRIC`` (or INCH), then x,y,z,i,j,k lines."""
    lines = text.splitlines()
    header = lines[0].split() if lines else []
    if len(header) not in (1, 2) or header[0].upper() != "XYZIJK":
        raise ValueError(f"{path}, line 1: expected the header 'XYZIJK    METRIC' (or INCH), got {lines[:1]}")
    units = header[1].upper() if len(header) == 2 else "METRIC"
    if units not in XYZ_UNITS:
        raise ValueError(f"{path}, line 1: units must be METRIC or INCH, got {header[1]!r}")
    rows = [
        _numbers(re.split(r"[,\s]+", line.strip()), 6, path, number)
        for number, line in enumerate(lines[1:], start=2) if line.strip()
    ]
    if not rows:
        raise ValueError(f"{path}: no points after the header")
    data = np.array(rows)
    labels = [f"P{index + 1}" for index in range(len(data))]
    return PointSet(labels, data[:, :3] * XYZ_UNITS[units], data[:, 3:], metadata={"xyz_units": units})


def read_csv(text, path="<text>"):
    """PointSet from CSV: leading ``# key: value`` comment lines, a header with label,x,y,z,i,j,k and
    optionally u,v (empty where unknown) and deviation (mm), then one line per point."""
    lines = list(enumerate(text.splitlines(), start=1))
    lines = [(n, line) for n, line in lines if line.strip()]
    head = next((i for i, (_, line) in enumerate(lines) if not line.startswith(CSV_COMMENT)), len(lines))
    comments = [(False, line[len(CSV_COMMENT):]) for _, line in lines[:head]]
    numbered = lines[head:]
    if len(numbered) < 2:
        raise ValueError(f"{path}: expected a header line and at least one point")
    rows = list(csv.reader(line for _, line in numbered))
    header = [name.strip().lower() for name in rows[0]]
    missing = [name for name in CSV_COLUMNS[:7] if name not in header]
    if missing:
        raise ValueError(
            f"{path}, line {numbered[0][0]}: the header lacks the column(s) {', '.join(missing)}; "
            f"got {rows[0]}"
        )
    cells = [row + [""] * (len(header) - len(row)) for row in rows[1:]]
    columns = dict(zip(header, map(list, zip(*cells))))
    line_numbers = [n for n, _ in numbered[1:]]
    numbers = {name: _column(columns[name], name, path, line_numbers) for name in header if name != "label"}
    empty = np.full(len(cells), np.nan)
    return PointSet(
        labels=columns["label"],
        points=_complete(numbers, "xyz", path),
        normals=_complete(numbers, "ijk", path),
        uv=_known(np.column_stack([numbers.get(c, empty) for c in "uv"]), "u, v", path),
        deviation=_known(numbers.get("deviation", empty), "deviation", path),
        metadata=parse_metadata_comments(comments),
    )


def _complete(numbers, names, path):
    """(N, len(names)) array of the named columns; ValueError when a cell is empty."""
    for name in names:
        if np.isnan(numbers[name]).any():
            raise ValueError(f"{path}: column {name} has empty cells")
    return np.column_stack([numbers[name] for name in names])


def _column(cells, name, path, line_numbers):
    """Floats of one CSV column, NaN for empty cells; ValueError naming the line of a bad cell."""
    values = np.full(len(cells), np.nan)
    for index, (cell, line) in enumerate(zip(cells, line_numbers)):
        if cell.strip():
            values[index] = _number(cell, path, line, name)
    return values


def _known(values, name, path):
    """values, or None when all are NaN (unknown); ValueError when only some are."""
    missing = np.isnan(values)
    if missing.all():
        return None
    if missing.any():
        raise ValueError(f"{path}: {name} given for some points only")
    return values


def _numbers(fields, count, path, line):
    """count floats from text fields; ValueError naming the line otherwise."""
    if len(fields) != count:
        raise ValueError(f"{path}, line {line}: expected {count} numbers (x,y,z,i,j,k), got {len(fields)}")
    return [_number(field, path, line) for field in fields]


def _number(text, path, line, name="value"):
    """One finite float; ValueError naming the line otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{path}, line {line}: {name} {text.strip()!r} is not a number") from None
    if not np.isfinite(value):
        raise ValueError(f"{path}, line {line}: {name} {text.strip()!r} is not a finite number")
    return value


READERS = {"dmis": read_dmis, "xyz": read_xyz, "csv": read_csv}
