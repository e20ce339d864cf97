"""Coordinate frames of point files: the document's global frame or a local one (a FreeCAD
placement), the metadata that states a local frame, and points moved between frames."""
import numpy as np

from ..geometry.freecad_env import import_freecad
from ..geometry.validation import InputError, InputTypeError

FreeCAD = import_freecad()

FRAME_KEYS = ("frame", "frame_name", "frame_origin_mm", "frame_x_axis", "frame_y_axis", "frame_z_axis")


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
        raise InputTypeError(
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
        raise InputError(
            f"the points are in a local frame but {', '.join(missing)} is not stated; pass frame="
        )
    matrix = np.eye(4)
    matrix[:3, :3] = np.column_stack([metadata[f"frame_{axis}_axis"] for axis in "xyz"])
    matrix[:3, 3] = metadata["frame_origin_mm"]
    return FreeCAD.Placement(FreeCAD.Matrix(*matrix.ravel()))
