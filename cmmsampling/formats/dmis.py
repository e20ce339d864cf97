"""DMIS 5.2 input programs: writing probe points as FEAT/POINT, MEAS/POINT, PTMEAS statements (with
a probe path: the sensors as SNSDEF/PROBE,INDEX,POL and SNSLCT, and GOTO moves between the
points) and reading the points (nominal ``F(...)`` or measured ``FA(...)``) and the ``$$ key: value`` comments
back; the DMIS rules for labels, program names and line lengths."""
from __future__ import annotations

import re

import numpy as np

from ..access.probe import head_angles
from ..geometry.validation import InputError
from . import dmis_datums
from .frames import placement_from_metadata
from .pointset import PointSet
from .registry import FileFormat
from .text import (COORDINATE_DECIMALS, VECTOR_DECIMALS, comment_entries, fixed, metadata_comment_lines, numbers,
                   parse_metadata_comments, wrapped)

NAME = "DMIS"
DESCRIPTION = "DMIS 5.2 input program (FEAT/POINT, MEAS/POINT, PTMEAS)"
EXTENSIONS = (".dmi", ".dmis", ".dmo", ".dms")
ENCODING = "ascii"
DMIS_VERSION = "05.2"
DMIS_LINE_LIMIT = 80
DMIS_LABEL = re.compile(r"[A-Za-z0-9_.-]{1,64}\Z")
DMIS_LABEL_RULE = "1 to 64 characters of A-Z, a-z, 0-9, '-', '_' and '.'"
DMIS_NAME_LIMIT = DMIS_LINE_LIMIT - len(f"DMISMN/'',{DMIS_VERSION}")
LABEL_LIMIT = 64
DMIS_COMMENT = "$$"
DMIS_COMMENT_CONTINUED = "$$+"
DMIS_CONTINUATION = "$"
ANGLE_DECIMALS = 4
# The vector of an SNSDEF: a vertical head on the quill, the stylus pointing down (-Z) at A = 0,
# as NIST's DMIS test program writes it for a vertical CMM (its SNSDEF and SNSMNT ZVEC).
HEAD_MOUNTING = (0.0, 0.0, -1.0)
# The sensor of a program without a probe path: the probe vertical (head angles A0 B0).
VERTICAL_SENSOR = "A0B0"
DMIS_FEATURE_POINT = re.compile(r"(FA?)\(([^()]*)\)=FEAT/POINT,([A-Z]+),(.*)\Z", re.IGNORECASE)
# The output device the program writes its results to, and the part alignment it assumes (no
# datums planned: the operator sets the part's frame before the automatic run).
OUTPUT_DEVICE = "RESULTS"
ALIGNMENT_ASSUMED = ["$$ part alignment: the part's frame must be set (aligned to the CAD model's",
                     "$$+ coordinates) before this program runs; it measures no datum features"]
DATUMS_MEASURED = ["$$ part alignment: the datum features are measured first, in the frame the",
                   "$$+ operator set (the part on the CAD model's coordinates to within the search",
                   "$$+ distance); the frame they set is then the CAD model's for the rest"]
# Any feature's definition, a MEAS block's start and a probed point.
OTHER_FEATURE = re.compile(r"(FA?)\(([^()]*)\)=FEAT/([A-Z]+)", re.IGNORECASE)
MEAS_BLOCK = re.compile(r"MEAS/([A-Z]+),FA?\(([^()]*)\)", re.IGNORECASE)
PTMEAS = re.compile(r"PTMEAS/([A-Z]+),(.*)\Z", re.IGNORECASE)
# A statement that means a point feature but is not written as DMIS_FEATURE_POINT reads it.
POINT_LIKE = re.compile(r"FEAT\W*POINT", re.IGNORECASE)
# UNITS/<length>,<angle>[,<temperature>]: the length units DMIS names, in mm (angles do not enter
# a point's x, y, z, i, j, k).
UNITS_STATEMENT = re.compile(r"UNITS/([A-Z]+)(?:,([A-Z]+))?", re.IGNORECASE)
LENGTH_UNITS_MM = {"MM": 1.0, "CM": 10.0, "METER": 1000.0, "INCH": 25.4, "FEET": 304.8}


def write(point_set, facts, options):
    """A DMIS 5.2 input program measuring each point once: the sensors (SNSDEF, one per head
    orientation of a probe path, else the vertical VERTICAL_SENSOR; options.probe: the probe as a
    dict of cmmsampling.Probe's fields) selected before their points (SNSLCT), FEAT/POINT,
    MEAS/POINT, PTMEAS, ENDMES, then OUTPUT/FA(label) of the measured point to the output file the program opens
    (DEVICE/STOR '<name>.dmo', OPEN ... OUTPUT; CLOSE before ENDFIL), which the CMM fills with
    FA(label)=FEAT/POINT actuals (what :func:`read` takes back). Without datums the part's frame
    is stated as set by the operator before the run (ALIGNMENT_ASSUMED); a plan's datums and
    profile tolerance are written as :mod:`cmmsampling.formats.dmis_datums` says."""
    check_dmis_labels(point_set.labels)
    xyz = fixed(point_set.points, COORDINATE_DECIMALS)
    ijk = fixed(point_set.normals, VECTOR_DECIMALS)
    entries = [(key, text.encode("ascii", "backslashreplace").decode("ascii"))
               for key, text in comment_entries(point_set, facts, options)]
    name = dmis_program_name(options.name)
    lines = [f"DMISMN/'{name}',{DMIS_VERSION}", f"{DMIS_COMMENT} probe points written by cmmsampling"]
    lines += metadata_comment_lines(entries, f"{DMIS_COMMENT} ", DMIS_COMMENT_CONTINUED, DMIS_LINE_LIMIT)
    path = point_set.travel is not None
    sensors = sensor_labels(point_set) if path else [VERTICAL_SENSOR] * len(point_set)
    groups = dmis_datums.datum_groups(point_set)
    lines += ["UNITS/MM,ANGDEC", "MODE/AUTO,PROG,MAN" if path else "MODE/PROG,MAN"]
    lines += DATUMS_MEASURED if groups else ALIGNMENT_ASSUMED
    lines += frame_statements(facts)
    lines += [f"DID({OUTPUT_DEVICE})=DEVICE/STOR,'{name[:DMIS_NAME_LIMIT - 4]}.dmo'",
              f"OPEN/DID({OUTPUT_DEVICE}),FDATA,DMIS,OUTPUT"]
    distances = {"APPRCH": options.approach, "RETRCT": options.retract, "SEARCH": options.search}
    lines += [f"SNSET/{word},{fixed(value, COORDINATE_DECIMALS).item()}" for word, value in distances.items()]
    lines += sensor_definitions(sensors, options.probe or {})
    lines += _measured_lines(point_set, xyz, ijk, sensors, groups)
    lines += [f"CLOSE/DID({OUTPUT_DEVICE})", "ENDFIL"]
    return "\n".join(wrapped_comments(without_repeated_gotos(lines))) + "\n"


def wrapped_comments(lines):
    """The lines with each comment longer than a DMIS line broken before a space into pieces
    that go on in ``$$+`` lines (joined, they give the comment back)."""
    kept = []
    for line in lines:
        if not line.startswith(DMIS_COMMENT):
            kept.append(line)
            continue
        start = len(DMIS_COMMENT_CONTINUED if line.startswith(DMIS_COMMENT_CONTINUED) else DMIS_COMMENT)
        kept += wrapped(line, DMIS_LINE_LIMIT, DMIS_COMMENT_CONTINUED, start)
    return kept


def _measured_lines(point_set, xyz, ijk, sensors, groups):
    """The points' statements in order: the datum points (each datum's feature and DATDEF after
    its points), the frame they set and their OUTPUTs; then the profile tolerances and the other
    points, each face's profile reported after its last point (cmmsampling.formats.dmis_datums)."""
    labels = list(point_set.labels)
    datum_rows = np.concatenate([group.rows for group in groups]) if groups else np.empty(0, dtype=int)
    others = np.setdiff1d(np.arange(len(labels)), datum_rows)
    if len(datum_rows) and not np.array_equal(datum_rows, np.arange(len(datum_rows))):
        raise InputError("a program with datums measures the datum points first; give them first, each datum's "
                         "together, primary first")
    lines, selected = [], None
    for group in groups:
        for index in group.rows:
            point_lines, selected = _point_lines(point_set, index, xyz, ijk, sensors, selected, output=False)
            lines += point_lines
        lines += dmis_datums.datum_feature_lines(group, labels, dmis_statement)
    lines += dmis_datums.frame_lines(groups, dmis_statement)
    lines += [f"OUTPUT/FA({labels[index]})" for index in datum_rows]
    faces = _toleranced_faces(point_set, others)
    tolerance = point_set.metadata.get("tolerance_mm")
    if faces and tolerance is not None:
        lines += dmis_datums.tolerance_lines(list(faces), float(tolerance), groups, dmis_statement)
    for index in others:
        point_lines, selected = _point_lines(point_set, index, xyz, ijk, sensors, selected, output=True)
        lines += point_lines
        face = point_set.faces[index] if point_set.faces is not None else None
        if tolerance is not None and face in faces and faces[face][-1] == index:
            lines += dmis_datums.profile_lines(face, [labels[k] for k in faces[face]], dmis_statement)
    if point_set.travel is not None:
        lines += goto_lines(point_set.travel[-1][0])
    return lines


def _toleranced_faces(point_set, rows):
    """{face: its point indices in order} of the points at rows that name their face ({} where
    the points name none)."""
    if point_set.faces is None:
        return {}
    faces = {}
    for index in rows:
        faces.setdefault(point_set.faces[index], []).append(int(index))
    return faces


def _point_lines(point_set, index, xyz, ijk, sensors, selected, output):
    """(lines, sensor selected after them) of one point: the travel before it and its sensor
    where it changes, FEAT/POINT, MEAS/POINT, PTMEAS, ENDMES and, with output, its OUTPUT."""
    leaving, arriving = point_set.travel[index] if point_set.travel is not None else ((), ())
    lines = goto_lines(leaving)
    if sensors[index] != selected:
        selected = sensors[index]
        lines.append(f"SNSLCT/S({selected})")
    lines += goto_lines(arriving)
    label, position, vector = point_set.labels[index], xyz[index].tolist(), ijk[index].tolist()
    lines += dmis_statement([f"F({label})=FEAT/POINT", "CART", *position], vector)
    lines += dmis_statement(["MEAS/POINT", f"F({label})", "1"])
    lines += dmis_statement(["PTMEAS/CART", *position], vector)
    lines += ["ENDMES"] + ([f"OUTPUT/FA({label})"] if output else [])
    return lines, selected


def frame_statements(facts):
    """The local frame the points are written in (facts: cmmsampling.formats.frames.frame_facts),
    as DMIS datum statements from the part's CAD (global) frame: D(name)=TRANS/XORIG,x,YORIG,y,
    ZORIG,z moves the origin to the frame's (mm, in the CAD frame), then D(name)=ROTAT/ZAXIS,a,
    ROTAT/YAXIS,b, ROTAT/XAXIS,c turn it about its own current axes (degrees, right-handed: the
    frame's rotation is Rz(a) Ry(b) Rx(c), FreeCAD's yaw, pitch and roll); rotations of 0 are left
    out. [] for global points."""
    placement = placement_from_metadata(facts)
    if placement is None:
        return []
    label = sanitise_labels([facts.get("frame_name") or "LOCAL"])[0]
    frame = np.array(placement.toMatrix().A, dtype=float).reshape(4, 4)
    return [f"{DMIS_COMMENT} the local frame, from the part's CAD frame: TRANS, then ROTAT about Z, Y, X",
            *dmis_datums.placement_statements(label, frame, dmis_statement)]


def without_repeated_gotos(lines):
    """The lines without a GOTO that repeats the line just before it (a move to where the probe
    already is, where one move ends and the next begins; the GOTOs on either side of a sensor
    change stay)."""
    kept = []
    for line in lines:
        if line.startswith("GOTO/") and kept and kept[-1] == line:
            continue
        kept.append(line)
    return kept


def sensor_labels(point_set):
    """The sensor of each point of a probe path, named by its head angles: 'A30B-90' (A from
    the vertical, B about it, degrees to 0.0001; cmmsampling.access.probe.head_angles)."""
    angles = np.round(head_angles(point_set.axes), ANGLE_DECIMALS) + 0.0
    return [f"A{a:g}B{b:g}" for a, b in angles.tolist()]


def sensor_definitions(sensors, probe):
    """SNSDEF statements, one per sensor in the order first used, in DMIS's meaning for an
    indexed head: S(name)=SNSDEF/PROBE,INDEX,POL,A,B,i,j,k,len,dia with the head angles A, B,
    the head's mounting vector i,j,k (HEAD_MOUNTING: a vertical head on the quill, whatever the
    angles), len the distance from the head's pivot to the ball centre (the probe body's and
    the stylus's lengths) and dia the ball diameter (mm; probe: the run's Probe as a dict)."""
    lines, seen = [], set()
    reach = probe.get("stylus_length", 0.0) + probe.get("body_length", 0.0)
    length = fixed(reach, COORDINATE_DECIMALS).item()
    diameter = fixed(probe.get("ball_diameter", 0.0), COORDINATE_DECIMALS).item()
    mounting = fixed(np.array(HEAD_MOUNTING), VECTOR_DECIMALS).tolist()
    for name in sensors:
        if name in seen:
            continue
        seen.add(name)
        a, b = name[1:].split("B")
        lines += dmis_statement([f"S({name})=SNSDEF/PROBE", "INDEX", "POL", fixed(float(a), ANGLE_DECIMALS).item(),
                                 fixed(float(b), ANGLE_DECIMALS).item()],
                                mounting + [length, diameter])
    return lines


def goto_lines(positions):
    """GOTO/x,y,z statements to ball-centre positions (M, 3), mm."""
    return [f"GOTO/{','.join(fixed(p, COORDINATE_DECIMALS).tolist())}" for p in np.asarray(positions).reshape(-1, 3)]


def read(text, path="<text>"):
    """PointSet from DMIS text: FEAT/POINT,CART statements and the PTMEAS/CART points measuring
    another feature (labelled <feature>_P1.., nominal), in mm whatever UNITS says (MM, CM, METER,
    INCH, FEET; each statement in the units in force where it stands), metadata from ``$$ key:
    value`` comments (``dmis_units``: the length units of the last UNITS, where one was given;
    ``dmis_other_features``: the features that are not points, named). A program of actual
    ``FA(...)`` points gives those; one with no point at all is refused, naming what it holds."""
    statements, comments = dmis_statements(text)
    found = {"F": {}, "FA": {}}
    scale, units, measuring, others = 1.0, None, None, []
    for number, statement in statements:
        compact = _without_blanks(statement)
        given = UNITS_STATEMENT.match(compact)
        if given is not None:
            scale, units = _units(given, path, number)
            continue
        measuring = _measure_block(compact, measuring)
        if measuring is not None and measuring[1] != "POINT" and PTMEAS.match(compact):
            label = f"{measuring[0]}_P{sum(key.startswith(measuring[0] + '_P') for key in found['F']) + 1}"
            found["F"][label] = _point(PTMEAS.match(compact).groups(), scale, path, number)
            continue
        other = OTHER_FEATURE.match(compact)
        if other is not None and other.group(3).upper() != "POINT":
            others.append(f"{other.group(1).upper()}({other.group(2)}) {other.group(3).upper()}")
            continue
        match = DMIS_FEATURE_POINT.match(compact)
        if match is None:
            if POINT_LIKE.search(statement):
                raise InputError(f"{path}, line {number}: a point statement that cannot be read "
                                 f"({statement.strip()[:60]}); write it as F(label)=FEAT/POINT,CART,x,y,z,i,j,k")
            continue
        kind, label, system, fields = match.groups()
        if label in found[kind.upper()]:
            raise InputError(f"{path}, line {number}: {kind.upper()}({label}) is given twice; give each point "
                             "its own label")
        found[kind.upper()][label] = _point((system, fields), scale, path, number)
    points = found["FA"] or found["F"]
    if not points:
        held = f"; it holds {', '.join(others)}" if others else ""
        raise InputError(f"{path}: no point to read (F(label)=FEAT/POINT,CART,x,y,z,i,j,k or PTMEAS/CART){held}")
    metadata = parse_metadata_comments(comments)
    metadata["dmis_features"] = "actual" if found["FA"] else "nominal"
    if units is not None:
        metadata["dmis_units"] = units
    if others:
        metadata["dmis_other_features"] = ", ".join(others)
    data = np.array(list(points.values()))
    return PointSet(list(points), data[:, :3], data[:, 3:], metadata=metadata)


def _units(given, path, number):
    """(mm per unit, unit name) of a UNITS statement's match; InputError for another length unit."""
    units = given.group(1).upper()
    if units not in LENGTH_UNITS_MM:
        raise InputError(f"{path}, line {number}: UNITS/{given.group(1)} is not a DMIS length unit this "
                         f"reader knows ({', '.join(LENGTH_UNITS_MM)})")
    return LENGTH_UNITS_MM[units], units


def _measure_block(compact, measuring):
    """(feature label, feature type) of the MEAS block a statement opens or stands in; None after
    ENDMES or outside one."""
    opened = MEAS_BLOCK.match(compact)
    if opened is not None:
        return opened.group(2), opened.group(1).upper()
    return None if compact.upper() == "ENDMES" else measuring


def _point(groups, scale, path, number):
    """[x, y, z (mm), i, j, k] of a point's (coordinate system, fields); InputError unless CART."""
    system, fields = groups
    if system.upper() != "CART":
        raise InputError(f"{path}, line {number}: only Cartesian points (CART) can be read, got {system}")
    values = numbers(fields.split(","), 6, path, number)
    return [value * scale for value in values[:3]] + values[3:]


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


def sanitise_labels(labels: list[str]) -> list[str]:
    """Labels valid in DMIS: other characters become '_', at most 64 characters, an empty label
    becomes P<i>, repeated ones get _2, _3, ... Returns a list of str."""
    clean, seen = [], set()
    for index, label in enumerate(labels):
        base = re.sub(r"[^A-Za-z0-9_.-]", "_", str(label))[:LABEL_LIMIT] or f"P{index + 1}"
        candidate, copy = base, 1
        while candidate in seen:
            copy += 1
            suffix = f"_{copy}"
            candidate = base[:LABEL_LIMIT - len(suffix)] + suffix
        seen.add(candidate)
        clean.append(candidate)
    return clean


def check_dmis_labels(labels):
    """ValueError naming labels DMIS cannot take (rule: DMIS_LABEL_RULE) or repeated labels."""
    bad = [(index, label) for index, label in enumerate(labels) if not DMIS_LABEL.match(label)]
    if bad:
        shown = ", ".join(f"{label!r} (point {index + 1})" for index, label in bad[:5])
        raise InputError(
            f"{len(bad)} label(s) cannot be used in DMIS, where a label is {DMIS_LABEL_RULE}: {shown}; "
            "cmmsampling.sanitise_labels(labels) makes valid ones"
        )
    first = {}
    for index, label in enumerate(labels):
        if label in first:
            raise InputError(f"label {label!r} is used by points {first[label] + 1} and {index + 1}; "
                             "DMIS labels must be unique")
        first[label] = index


def dmis_program_name(name):
    """A DMISMN program name: printable ASCII without quotes, at most DMIS_NAME_LIMIT characters."""
    clean = re.sub(r"[^ -~]|'", "_", str(name)).strip()[:DMIS_NAME_LIMIT]
    return clean or "cmmsampling"


def dmis_statement(*groups):
    """Physical lines of one DMIS statement whose fields (text) come in groups.

    Fields are joined by commas; each group starts a line, and a line that would pass 80
    characters breaks after a comma and ends in the continuation mark '$'.
    """
    fields = [field for group in groups for field in group]
    starts = set(np.cumsum([len(group) for group in groups[:-1]]).tolist())
    tokens = [field + "," for field in fields[:-1]] + fields[-1:]
    lines, line = [], ""
    for index, token in enumerate(tokens):
        room = DMIS_LINE_LIMIT - (0 if index == len(tokens) - 1 else 1)
        if line and (index in starts or len(line) + len(token) > room):
            lines.append(line + "$")
            line = ""
        line += token
    return lines + [line]


def dmis_output(nominal, actual, name):
    """DMIS output text: for each point its nominal F(label)=FEAT/POINT and the measured actual
    FA(label)=FEAT/POINT (with the nominal vector), as a CMM writes them after a run.
    nominal: PointSet; actual: (N, 3) mm; name: the program's name."""
    lines = [f"DMISMN/'{dmis_program_name(name)}',{DMIS_VERSION}", "$$ measured by cmmsampling's virtual CMM",
             "UNITS/MM,ANGDEC"]
    vectors = fixed(nominal.normals, VECTOR_DECIMALS).tolist()
    for label, planned, measured, vector in zip(nominal.labels, fixed(nominal.points, COORDINATE_DECIMALS).tolist(),
                                                fixed(actual, COORDINATE_DECIMALS).tolist(), vectors):
        lines += dmis_statement([f"F({label})=FEAT/POINT", "CART", *planned], vector)
        lines += dmis_statement([f"FA({label})=FEAT/POINT", "CART", *measured], vector)
    lines.append("ENDFIL")
    return "\n".join(lines) + "\n"


def unmeasured(point_set):
    """Why a DMIS file's points are no measurement (its nominal F(label) statements only), or None."""
    if point_set.metadata.get("dmis_features") != "nominal":
        return None
    return ("holds the program's nominal points only (F(label)=FEAT/POINT), no measured FA(label) values; give the "
            "DMIS output file the CMM wrote after measuring")


FORMAT = FileFormat("dmis", NAME, DESCRIPTION, EXTENSIONS, ENCODING, write, read, contact_nominals=True,
                    measured=True, write_measured=dmis_output, unmeasured=unmeasured)
