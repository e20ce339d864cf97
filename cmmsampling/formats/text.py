"""What the point-file formats share: numbers in fixed notation, numbers parsed with the line
they came from, and the ``key: value`` comments that carry a point set's facts (source face,
strategy, frame, probe radius, deviation figures)."""
import json
import re

import numpy as np

from ..geometry.validation import InputError

COORDINATE_DECIMALS = 7
VECTOR_DECIMALS = 9
PARAMETER_DECIMALS = 10
# A number written with a decimal comma (12,5), which point files refuse.
DECIMAL_COMMA = re.compile(r"\s*[-+]?\d*,\d+\s*")
METADATA_ENTRY = re.compile(r"\s*([A-Za-z][A-Za-z0-9_]*):(.*)\Z", re.DOTALL)


def fixed(values, decimals):
    """values (any shape) as text in fixed notation with decimals digits, never '-0.000': same shape, str."""
    return np.char.mod(f"%.{decimals}f", np.round(np.asarray(values, dtype=float), decimals) + 0.0)


def numbers(fields, count, path, line):
    """count floats from text fields; ValueError naming the line otherwise."""
    if len(fields) != count:
        raise InputError(f"{path}, line {line}: expected {count} numbers (x,y,z,i,j,k), got {len(fields)}")
    return [number(field, path, line) for field in fields]


def number(text, path, line, name="value"):
    """One finite float; ValueError naming the line otherwise."""
    try:
        value = float(text)
    except ValueError:
        if DECIMAL_COMMA.fullmatch(text):
            raise InputError(f"{path}, line {line}: {name} {text.strip()!r} has a decimal comma; write numbers "
                             f"with a decimal point ({text.strip().replace(',', '.')})") from None
        raise InputError(f"{path}, line {line}: {name} {text.strip()!r} is not a number") from None
    if not np.isfinite(value):
        raise InputError(f"{path}, line {line}: {name} {text.strip()!r} is not a finite number")
    return value


def comment_entries(point_set, facts, options):
    """(key, text) pairs of the comments: the facts always, the point set's metadata when asked."""
    entries = {"count": len(point_set), "units": "mm", **facts}
    if options.comments:
        entries.update(point_set.metadata)
    return [(_comment_key(key), metadata_value_text(value)) for key, value in entries.items()]


def _comment_key(key):
    """key made of letters, digits and '_', starting with a letter."""
    clean = re.sub(r"[^A-Za-z0-9_]", "_", str(key))
    return clean if clean[:1].isalpha() else f"key_{clean}"


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
            lines.extend(wrapped(line, width, continuation, len(prefix) + len(key) + 2))
    return lines


def wrapped(line, width, continuation, start):
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
