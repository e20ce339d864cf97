"""Export probe points for a CMM and judge the points it measured.

:func:`export` writes a PointSet (or a SamplingResult, or a document object whose Proxy offers
``point_set(obj)``) as a DMIS input program, a PC-DMIS XYZ file or a CSV file, in the global frame
or in a local coordinate system, optionally as probe-ball centres and in a short probing order.
Files are replaced atomically: a failed export leaves an existing file as it was.
:func:`measured_deviation` measures points (e.g. a CMM's results read with
:func:`cmmsampling.pointfiles.read_points`) against the CAD face.
"""
import csv
import io
import os
import re
import tempfile
from dataclasses import dataclass

import numpy as np

from .freecad_env import import_part
from .pointfiles import (
    CSV_COLUMNS, CSV_COMMENT, DMIS_COMMENT, DMIS_COMMENT_CONTINUED, READER_KEYS, metadata_comment_lines,
    metadata_value_text, read_points, resolve_format,
)
from .pointset import PointSet
from .probe_path import short_path, unchanged
from .result import SamplingResult
from .surface import as_face
from .validation import check_choice, check_real

Part = import_part()
import FreeCAD  # noqa: E402

COORDINATE_DECIMALS = 7
VECTOR_DECIMALS = 9
PARAMETER_DECIMALS = 10
DMIS_VERSION = "05.2"
DMIS_LINE_LIMIT = 80
DMIS_LABEL = re.compile(r"[A-Za-z0-9_.-]{1,64}\Z")
DMIS_LABEL_RULE = "1 to 64 characters of A-Z, a-z, 0-9, '-', '_' and '.'"
DMIS_NAME_LIMIT = DMIS_LINE_LIMIT - len(f"DMISMN/'',{DMIS_VERSION}")
LABEL_LIMIT = 64
ORDERS = ("as_optimised", "short_path")
UNIT_TOLERANCE = 1e-3
FRAME_KEYS = ("frame", "frame_name", "frame_origin_mm", "frame_x_axis", "frame_y_axis", "frame_z_axis")
PROBE_KEYS = ("probe_radius_mm", "points")
ORDER_KEYS = ("order", "path_length_mm")
WRITTEN_KEYS = FRAME_KEYS + PROBE_KEYS + ORDER_KEYS + ("count", "units") + READER_KEYS
XYZ_HEADER = "XYZIJK    METRIC"


class ExportError(OSError):
    """A point file could not be written; the message names the path and the reason."""


@dataclass(frozen=True)
class WriteOptions:
    """What the writers need besides the points: DMIS program name, approach, retract and search
    distances (mm), and whether to write the descriptive comments."""

    name: str
    approach: float
    retract: float
    search: float
    comments: bool


FORMAT_NAMES = {"dmis": "DMIS", "xyz": "XYZIJK text", "csv": "CSV"}


@dataclass(frozen=True)
class ExportReport:
    """What :func:`export` wrote.

    path: absolute path; format: 'dmis', 'xyz' or 'csv'; count: points written; order: the order
    asked for; length_before, length_after: mm, open 3D path through the written points in the
    source's order and in the written order; frame: 'global' or 'local'; probe_radius: mm added
    along the normals (0: contact points).
    """

    path: str
    format: str
    count: int
    order: str
    length_before: float
    length_after: float
    frame: str
    probe_radius: float

    @property
    def saving(self):
        """Path shortening in mm."""
        return self.length_before - self.length_after

    def __str__(self):
        what = "contact points" if self.probe_radius == 0 else f"ball centres, probe radius {self.probe_radius:g} mm"
        line = (f"Wrote {self.count} points to {self.path} ({FORMAT_NAMES.get(self.format, self.format)}, "
                f"{self.frame} frame, {what}). ")
        if self.order == "short_path":
            line += f"Probe path {self.length_after:.1f} mm in the short-path order"
            if self.saving > 0:
                line += (f" ({self.length_before:.1f} mm in the optimised order: "
                         f"{100 * self.saving / self.length_before:.0f} % shorter)")
            return line + "."
        return line + f"Probe path {self.length_before:.1f} mm in the optimised order."


def export(source, path, format=None, *, frame=None, probe_radius=0.0, order="as_optimised", name=None,
           approach=2.0, retract=2.0, search=5.0, comments=True):
    """Write probe points to a file for a CMM.

    source: a PointSet, a SamplingResult, or a document object whose Proxy has ``point_set(obj)``;
    points: (N, 3) mm, normals (N, 3) unit vectors out of the material (the probe travels along
    -normal), both global. path: the file; format: 'dmis', 'xyz' or 'csv', by default from the
    extension (.dmi/.dmis, .xyz/.txt, .csv).
    frame: None for global coordinates, or the local coordinate system as a FreeCAD.Placement or an
    object with a Placement (e.g. a datum coordinate system; its global placement is used): points
    are written as placement.inverse() * p, normals rotated only.
    probe_radius: mm; when positive the points are probe-ball centres p + r * n (the radius is
    stated in DMIS and CSV comments; the XYZ format has no comments, so an XYZ file holds the
    points as written and the caller has to keep the radius with it).
    order: 'as_optimised' keeps the source's order, 'short_path' visits the points along a short
    path (nearest neighbour + 2-opt, :mod:`cmmsampling.probe_path`).
    name: DMIS program name (default: the file name without extension); approach, retract,
    search: DMIS SNSET distances, mm; comments: write the source's metadata (source face,
    strategy, parameters, deviation figures) as comments; the frame, probe radius and order are
    stated in DMIS and CSV files either way.
    The file is written to a temporary file in the same folder and then moved over the target, so
    an existing file survives any failure. Returns an ExportReport; ValueError or TypeError for bad
    input, ExportError (an OSError) naming the path and the reason when it cannot be written.
    """
    fmt = resolve_format(path, format)
    check_choice("order", order, list(ORDERS))
    radius = check_real("probe_radius", probe_radius, minimum=0.0)
    options = WriteOptions(
        name=dmis_program_name(_stem(path) if name is None else name),
        approach=check_real("approach", approach, above=0.0),
        retract=check_real("retract", retract, above=0.0),
        search=check_real("search", search, above=0.0),
        comments=bool(comments),
    )
    placement, frame_name = resolve_frame(frame)
    point_set, facts = prepared(as_point_set(source), placement, radius, frame_name)
    path_order = short_path(point_set.points) if order == "short_path" else unchanged(point_set.points)
    point_set = reordered(point_set, path_order.order)
    facts.update(order=order, path_length_mm=path_order.length_after)
    text = WRITERS[fmt](point_set, facts, options)
    target = write_atomically(path, text, "ascii" if fmt != "csv" else "utf-8")
    return ExportReport(target, fmt, len(point_set), order, path_order.length_before, path_order.length_after,
                        facts["frame"], facts["probe_radius_mm"])


def _stem(path):
    """The file name of path without folder and extension."""
    return os.path.splitext(os.path.basename(os.fspath(path)))[0]


def as_point_set(source):
    """The PointSet of a PointSet, a SamplingResult or a document object whose Proxy has point_set(obj)."""
    if isinstance(source, PointSet):
        return source
    if isinstance(source, SamplingResult):
        return PointSet.from_result(source)
    method = getattr(getattr(source, "Proxy", None), "point_set", None)
    if callable(method):
        point_set = method(source)
        if isinstance(point_set, PointSet):
            return point_set
        raise TypeError(
            f"{source.Name}.Proxy.point_set() returned {type(point_set).__name__}, not a PointSet"
        )
    raise TypeError(
        f"cannot export a {type(source).__name__}; give a PointSet, a SamplingResult or a document "
        "object whose Proxy has point_set(obj)"
    )


def resolve_frame(frame):
    """(placement or None, name) of a frame: None (global), a FreeCAD.Placement, or an object with a
    Placement (its global placement where it has one, and its Label as the name)."""
    if frame is None:
        return None, ""
    if isinstance(frame, FreeCAD.Placement):
        return FreeCAD.Placement(frame), ""
    getter = getattr(frame, "getGlobalPlacement", None)
    placement = getter() if callable(getter) else getattr(frame, "Placement", None)
    if not isinstance(placement, FreeCAD.Placement):
        raise TypeError(
            "frame must be None, a FreeCAD.Placement or an object with a Placement, "
            f"got {type(frame).__name__}"
        )
    return placement, str(getattr(frame, "Label", ""))


def rotation_and_origin(placement):
    """(R (3, 3), t (3,) mm) of a placement: global = R @ local + t."""
    matrix = np.array(placement.toMatrix().A, dtype=float).reshape(4, 4)
    return matrix[:3, :3], matrix[:3, 3]


def to_local(points, normals, placement):
    """points (N, 3) mm and normals (N, 3) from global into the placement's frame: R^T (p - t), R^T n."""
    rotation, origin = rotation_and_origin(placement)
    return (points - origin) @ rotation, normals @ rotation


def to_global(points, normals, placement):
    """points (N, 3) mm and normals (N, 3) from the placement's frame into global: R p + t, R n."""
    rotation, origin = rotation_and_origin(placement)
    return points @ rotation.T + origin, normals @ rotation.T


def frame_facts(placement, name=""):
    """Metadata stating a local frame: its name, origin (mm) and axes, all in global coordinates."""
    rotation, origin = rotation_and_origin(placement)
    facts = {"frame": "local", "frame_name": name} if name else {"frame": "local"}
    facts["frame_origin_mm"] = origin.tolist()
    for axis, column in zip("xyz", rotation.T):
        facts[f"frame_{axis}_axis"] = column.tolist()
    return facts


def placement_from_metadata(metadata):
    """The FreeCAD.Placement of the local frame stated in metadata (see :func:`frame_facts`), or None
    for global points. ValueError when a local frame is stated incompletely."""
    if metadata.get("frame", "global") == "global":
        return None
    missing = [key for key in FRAME_KEYS[2:] if key not in metadata]
    if missing:
        raise ValueError(
            f"the points are in a local frame but {', '.join(missing)} is not stated; pass frame="
        )
    matrix = np.eye(4)
    matrix[:3, :3] = np.column_stack([metadata[f"frame_{axis}_axis"] for axis in "xyz"])
    matrix[:3, 3] = metadata["frame_origin_mm"]
    return FreeCAD.Placement(FreeCAD.Matrix(*matrix.ravel()))


def prepared(point_set, placement, radius, frame_name=""):
    """The point set as it is written, and the facts that say what its numbers mean.

    Checks the point set, moves the points to the ball centres p + radius * n, then into the
    placement's frame. A point set whose metadata already states a local frame or a probe radius
    (e.g. one read from a file) keeps those facts when neither is applied again, and is refused
    when one would be applied on top. Returns (PointSet, facts dict).
    """
    point_set = checked(point_set)
    stated = point_set.metadata
    if placement is not None and stated.get("frame", "global") != "global":
        raise ValueError("these points are already in a local frame; export them with frame=None, "
                         "or export the global points")
    stated_radius = float(stated.get("probe_radius_mm", 0.0))
    if radius > 0 and stated_radius > 0:
        raise ValueError(f"these points are already probe-ball centres (radius {stated_radius} mm); "
                         "export them with probe_radius=0, or export the contact points")
    points = point_set.points + radius * point_set.normals
    normals = point_set.normals
    if placement is None:
        facts = {key: stated[key] for key in FRAME_KEYS if key in stated} or {"frame": "global"}
    else:
        facts = frame_facts(placement, frame_name)
        points, normals = to_local(points, normals, placement)
    total = radius + stated_radius
    facts["probe_radius_mm"] = total
    facts["points"] = (f"probe-ball centres (contact point + {total:g} mm * normal)" if total > 0
                       else "contact points on the face")
    metadata = {key: value for key, value in stated.items() if key not in WRITTEN_KEYS}
    return PointSet(point_set.labels, points, normals, point_set.uv, point_set.deviation, metadata), facts


def checked(point_set):
    """A copy of point_set with float arrays, str labels and normalised normals.

    ValueError naming the problem: no points, wrong shapes, NaN or infinite values, a normal whose
    length differs from 1 by more than 1e-3.
    """
    points = np.asarray(point_set.points, dtype=float)
    count = len(points)
    if count == 0:
        raise ValueError("the point set has no points")
    if points.shape != (count, 3):
        raise ValueError(f"points must be an (N, 3) array in mm, got shape {points.shape}")
    normals = np.asarray(point_set.normals, dtype=float)
    if normals.shape != (count, 3):
        raise ValueError(
            f"normals must be an (N, 3) array like the points {points.shape}, got {normals.shape}"
        )
    if len(point_set.labels) != count:
        raise ValueError(f"{len(point_set.labels)} labels for {count} points")
    labels = [str(label) for label in point_set.labels]
    _check_finite("points", points, labels)
    _check_finite("normals", normals, labels)
    lengths = np.linalg.norm(normals, axis=1)
    bad = np.flatnonzero(np.abs(lengths - 1.0) > UNIT_TOLERANCE)
    if bad.size:
        raise ValueError(f"the normal of point {labels[bad[0]]} has length {lengths[bad[0]]:.6g}; "
                         "approach vectors must be unit vectors")
    uv = _optional(point_set.uv, (count, 2), "uv", labels)
    deviation = _optional(point_set.deviation, (count,), "deviation", labels)
    return PointSet(labels, points, normals / lengths[:, None], uv, deviation, dict(point_set.metadata))


def _check_finite(name, values, labels):
    """ValueError naming the first point whose row of values (N, k) is not finite."""
    bad = np.flatnonzero(~np.all(np.isfinite(values.reshape(len(labels), -1)), axis=1))
    if bad.size:
        raise ValueError(
            f"{name} of point {labels[bad[0]]} contain NaN or infinite values ({bad.size} points)"
        )


def _optional(values, shape, name, labels):
    """values as a finite float array of shape, or None when None; ValueError otherwise."""
    if values is None:
        return None
    array = np.asarray(values, dtype=float)
    if array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    _check_finite(name, array, labels)
    return array


def reordered(point_set, order):
    """point_set with its points, labels and per-point values in order (N,) int."""
    return PointSet([point_set.labels[i] for i in order], point_set.points[order], point_set.normals[order],
                    _taken(point_set.uv, order), _taken(point_set.deviation, order), point_set.metadata)


def _taken(values, order):
    """values[order], or None for None."""
    return None if values is None else values[order]


def sanitise_labels(labels):
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
        raise ValueError(
            f"{len(bad)} label(s) cannot be used in DMIS, where a label is {DMIS_LABEL_RULE}: {shown}; "
            "cmmsampling.sanitise_labels(labels) makes valid ones"
        )
    first = {}
    for index, label in enumerate(labels):
        if label in first:
            raise ValueError(f"label {label!r} is used by points {first[label] + 1} and {index + 1}; "
                             "DMIS labels must be unique")
        first[label] = index


def dmis_program_name(name):
    """A DMISMN program name: printable ASCII without quotes, at most DMIS_NAME_LIMIT characters."""
    clean = re.sub(r"[^ -~]|'", "_", str(name)).strip()[:DMIS_NAME_LIMIT]
    return clean or "cmmsampling"


def fixed(values, decimals):
    """values (any shape) as text in fixed notation with decimals digits, never '-0.000': same shape, str."""
    return np.char.mod(f"%.{decimals}f", np.round(np.asarray(values, dtype=float), decimals) + 0.0)


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


def dmis_text(point_set, facts, options):
    """A DMIS 5.2 input program measuring each point once: FEAT/POINT, MEAS/POINT, PTMEAS, ENDMES."""
    check_dmis_labels(point_set.labels)
    xyz = fixed(point_set.points, COORDINATE_DECIMALS)
    ijk = fixed(point_set.normals, VECTOR_DECIMALS)
    entries = [(key, text.encode("ascii", "backslashreplace").decode("ascii"))
               for key, text in comment_entries(point_set, facts, options)]
    lines = [f"DMISMN/'{options.name}',{DMIS_VERSION}", f"{DMIS_COMMENT} probe points written by cmmsampling"]
    lines += metadata_comment_lines(entries, f"{DMIS_COMMENT} ", DMIS_COMMENT_CONTINUED, DMIS_LINE_LIMIT)
    lines += ["UNITS/MM,ANGDEC", "MODE/PROG,MAN"]
    distances = {"APPRCH": options.approach, "RETRCT": options.retract, "SEARCH": options.search}
    lines += [f"SNSET/{word},{fixed(value, COORDINATE_DECIMALS).item()}" for word, value in distances.items()]
    for label, position, vector in zip(point_set.labels, xyz.tolist(), ijk.tolist()):
        lines += dmis_statement([f"F({label})=FEAT/POINT", "CART", *position], vector)
        lines += dmis_statement(["MEAS/POINT", f"F({label})", "1"])
        lines += dmis_statement(["PTMEAS/CART", *position], vector)
        lines.append("ENDMES")
    lines.append("ENDFIL")
    return "\n".join(lines) + "\n"


def xyz_text(point_set, facts, options):
    """PC-DMIS XYZIJK text: 'XYZIJK' in columns 1-6, 'METRIC' in 11-16, then x,y,z,i,j,k per line."""
    rows = np.concatenate(
        [fixed(point_set.points, COORDINATE_DECIMALS), fixed(point_set.normals, VECTOR_DECIMALS)], axis=1
    )
    return "\n".join([XYZ_HEADER] + [",".join(row) for row in rows.tolist()]) + "\n"


def csv_text(point_set, facts, options):
    """CSV: '# key: value' comments, header label,x,y,z,i,j,k,u,v[,deviation], one row per point
    (u, v empty where unknown)."""
    count = len(point_set)
    columns = [np.array(point_set.labels, dtype=object)[:, None],
               fixed(point_set.points, COORDINATE_DECIMALS), fixed(point_set.normals, VECTOR_DECIMALS),
               np.full((count, 2), "") if point_set.uv is None else fixed(point_set.uv, PARAMETER_DECIMALS)]
    header = list(CSV_COLUMNS)
    if point_set.deviation is not None:
        columns.append(fixed(point_set.deviation, COORDINATE_DECIMALS)[:, None])
        header.append("deviation")
    buffer = io.StringIO()
    buffer.write("".join(f"{line}\n" for line in metadata_comment_lines(
        comment_entries(point_set, facts, options), f"{CSV_COMMENT} ")))
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(np.concatenate(columns, axis=1).tolist())
    return buffer.getvalue()


WRITERS = {"dmis": dmis_text, "xyz": xyz_text, "csv": csv_text}


# The temporary files of write_atomically: .<file name>.<process id>.<random>.tmp
TEMPORARY = re.compile(r"^\..+\.(?P<pid>\d+)\.[A-Za-z0-9_]{8}\.tmp$")


def check_writable(path):
    """ExportError naming the path and the reason unless a file can be written at path: the
    folder exists and takes new files (a temporary file is created there and removed), and path
    is no folder. Returns the absolute path. For checking output paths before a long run."""
    target = os.path.abspath(os.fspath(path))
    if os.path.isdir(target):
        raise ExportError(f"could not write {target}: it is a folder; give a file name")
    descriptor, temporary = _temporary_file(target)
    os.close(descriptor)
    os.unlink(temporary)
    return target


def _temporary_file(target):
    """(descriptor, path) of a new temporary file beside target, named after it and this process;
    ExportError naming the reason when the folder takes no new file."""
    try:
        descriptor, temporary = tempfile.mkstemp(
            prefix=f".{os.path.basename(target)}.{os.getpid()}.", suffix=".tmp",
            dir=os.path.dirname(target))
    except OSError as exc:
        raise ExportError(f"could not write {target}: {_reason(exc, target)}") from exc
    return descriptor, temporary


def remove_stale_temporaries(folder):
    """Remove the temporary files that writes killed midway (kill -9, power loss) left in folder:
    those of write_atomically whose process is gone. Returns the paths removed."""
    removed = []
    for name in os.listdir(folder):
        match = TEMPORARY.match(name)
        if match and not _process_alive(int(match["pid"])):
            try:
                os.unlink(os.path.join(folder, name))
                removed.append(os.path.join(folder, name))
            except OSError:
                pass
    return removed


def _process_alive(pid):
    """True when a process with this id runs on this machine (or may: no permission to ask)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def write_atomically(path, text, encoding):
    """Write text to path through a temporary file in the same folder (fsync, then os.replace).

    On any failure the temporary file is removed and an existing file at path is untouched;
    temporary files of earlier writes that were killed midway are removed first
    (:func:`remove_stale_temporaries`). Returns the absolute path; ExportError naming the path
    and the reason when it cannot be written.
    """
    target = os.path.abspath(os.fspath(path))
    folder = os.path.dirname(target)
    data = text.encode(encoding)
    descriptor, temporary = _temporary_file(target)
    remove_stale_temporaries(folder)
    try:
        with os.fdopen(descriptor, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temporary, _file_mode(target))
        os.replace(temporary, target)
    except BaseException as exc:
        os.unlink(temporary)
        if isinstance(exc, OSError):
            raise ExportError(f"could not write {target}: {_reason(exc, target)}") from exc
        raise
    return target


def _reason(exc, target):
    """Why target could not be written, in words, from the OSError raised."""
    folder = os.path.dirname(target)
    if isinstance(exc, NotADirectoryError):
        blocker = folder
        while blocker and not os.path.exists(blocker):
            blocker = os.path.dirname(blocker)
        return f"{blocker} is a file, not a folder"
    if isinstance(exc, FileNotFoundError) and not os.path.isdir(folder):
        return f"the folder {folder} does not exist"
    if isinstance(exc, IsADirectoryError):
        return f"{target} is a folder"
    if isinstance(exc, PermissionError):
        return f"no permission to write in {folder} ({exc.strerror})"
    return f"the folder {folder} takes no new files ({exc.strerror or exc}); choose another folder"


def _file_mode(target):
    """Permission bits for the new file: those of the file it replaces, else 0o666 less the umask."""
    if os.path.exists(target):
        return os.stat(target).st_mode & 0o7777
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@dataclass(frozen=True)
class MeasuredDeviation:
    """Measured points against the CAD face.

    labels: N strings; distances: (N,) mm, signed closest-point distance of each contact point from
    the face, positive outside the material (excess), negative inside; closest: (N, 3) mm, global,
    the closest points on the face; probe_radius: mm, taken off the ball-centre distances.
    """

    labels: list
    distances: np.ndarray
    closest: np.ndarray
    probe_radius: float

    @property
    def maximum(self):
        """Largest |distance|, mm."""
        return float(np.abs(self.distances).max())

    @property
    def mean(self):
        """Mean |distance|, mm."""
        return float(np.abs(self.distances).mean())

    @property
    def rms(self):
        """Root mean square distance, mm."""
        return float(np.sqrt(np.mean(self.distances ** 2)))

    def summary(self):
        """The figures as a dict: n, max_mm, mean_mm, rms_mm, lowest_mm and highest_mm (signed)."""
        return {"n": len(self.labels), "max_mm": self.maximum, "mean_mm": self.mean, "rms_mm": self.rms,
                "lowest_mm": float(self.distances.min()), "highest_mm": float(self.distances.max())}


def measured_deviation(face, points, *, frame=None, probe_radius=None):
    """How far measured points lie from the CAD face: OCC closest-point distances, signed.

    face: a Part.Face (or a shape with one face); points: a path to a DMIS/XYZ/CSV file, a
    PointSet, a SamplingResult or a document object whose Proxy has point_set(obj).
    frame: the local coordinate system the points are given in (as in :func:`export`); None takes
    the frame the file states (global when none). probe_radius: mm; the points are ball centres
    and the radius is taken off each distance; None takes the radius the file states (0 when none).
    Returns a MeasuredDeviation (distances positive where material is in excess).
    """
    face = as_face(face)
    point_set = read_points(points) if isinstance(points, (str, os.PathLike)) else as_point_set(points)
    placement = resolve_frame(frame)[0] if frame is not None else placement_from_metadata(point_set.metadata)
    radius = (float(point_set.metadata.get("probe_radius_mm", 0.0)) if probe_radius is None
              else check_real("probe_radius", probe_radius, minimum=0.0))
    measured = checked(point_set)
    positions = measured.points
    if placement is not None:
        positions = to_global(measured.points, measured.normals, placement)[0]
    closest, normals, distances = closest_points(face, positions)
    side = np.sign(np.einsum("ij,ij->i", positions - closest, normals))
    return MeasuredDeviation(measured.labels, side * distances - radius, closest, radius)


def closest_points(face, points):
    """For points (N, 3) mm: the closest points on face (N, 3) mm, the face's outward unit normals
    there (N, 3) and the distances (N,) mm, by OCC (``face.distToShape``)."""
    rows = []
    for point in points:
        distance, pairs, _ = face.distToShape(Part.Vertex(FreeCAD.Vector(*point)))
        foot = pairs[0][0]
        u, v = face.Surface.parameter(foot)
        rows.append((*foot, *face.normalAt(u, v), distance))
    data = np.array(rows, dtype=float)
    return data[:, :3], data[:, 3:6], data[:, 6]
