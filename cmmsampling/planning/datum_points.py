"""The points of a plan's datum faces: spread to hold the motions each datum fixes.

A datum reference frame (ISO 5459) is set up from its datum features in precedence order: the
primary fixes what its geometry can (a plane: the motion along its normal and the two tilts),
the secondary what it can of the motions the primary leaves free (a plane at right angles: two),
the tertiary the rest. A datum face is not sampled for its form: its points are chosen from its
raster (cmmsampling.fitting.nodes) away from its edges and, with a probe, where the probe
reaches, as far apart as they can be (farthest-point order), DATUM_POINTS_PER_MOTION for each
motion it fixes and at least DATUM_MIN_POINTS (a cylinder CYLINDER_POINTS), and checked to hold those motions (not on one
line) as :func:`cmmsampling.inspect` does before it aligns on them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..access.obstacles import Obstacles
from ..access.probe import Probe
from ..access.reach import reach
from ..geometry.motions import split_motions
from ..fitting.nodes import face_nodes
from ..geometry.freecad_env import import_part
from ..geometry.validation import InputError
from ..strategies.face_setup import setup_of

Part = import_part()
DATUM_POINTS_PER_MOTION = 2
DATUM_MIN_POINTS = 4
# The raster nodes a datum's points are chosen from, evenly thinned to at most this many.
DATUM_CANDIDATES = 400
# The raster (nodes per direction) a datum's points are chosen on.
DATUM_GRID = 60
# mm a datum's points keep from the face's edges where the plan gives no edge offset.
DATUM_EDGE_MM = 2.0
# Points a cylindrical datum face gets at least, whatever motions it fixes: the CMM fits a
# least-squares cylinder through them (5 unknowns; PC-DMIS asks 6 points at least), and NIST's
# programs measure a bore with 8.
CYLINDER_POINTS = 8


@dataclass
class DatumPoints:
    """One datum face's points: label ('A'), face ('Face3'), motions (how many it fixes in its
    place of the frame), uv (n, 2), points (n, 3) mm, normals (n, 3) unit, out of the
    material, and the probe's Access to them (None without a probe)."""

    label: str
    face: str
    motions: int
    uv: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    access: object = None


def datum_labels(count: int) -> list[str]:
    """'A', 'B', ... for count datums in precedence order."""
    return [chr(ord("A") + index) for index in range(count)]


def plan_datums(named: list, probe: Probe | None = None, part: object = None,
                edge_offset: float | None = None, labels: list[str] | None = None) -> list[DatumPoints]:
    """The DatumPoints of the datum faces named (list of (name, Part.Face), primary first).
    probe and part: the points are kept to those the probe reaches on the part; edge_offset:
    mm from the edges (None: DATUM_EDGE_MM); labels: each face's datum label where the faces
    serve several frames (a model's datums: a datum of several faces names each of them), each
    face then spread to hold every motion it can fix on its own (None: the faces are one frame,
    A, B, C ... in order, each holding what the ones before it leave free). InputError naming a
    datum that fixes none of the motions left free, or whose face offers too few reachable points."""
    reaching = None if probe is None else (probe, Obstacles(part))
    free = np.eye(6)
    planned = []
    margin = DATUM_EDGE_MM if edge_offset is None else float(edge_offset)
    for label, (name, face) in zip(datum_labels(len(named)) if labels is None else labels, named):
        uv, points, normals = _candidates(face, margin)
        if reaching is not None:
            keep = reach(*reaching, points, normals).reachable
            uv, points, normals = uv[keep], points[keep], normals[keep]
        if len(points) < DATUM_MIN_POINTS:
            raise InputError(_too_few(label, name, len(points), probe is not None))
        pivot = points.mean(axis=0)
        held, free_after = split_motions(points, normals, free, pivot)
        motions = held.shape[1]
        if motions == 0:
            raise InputError(f"datum {label} ({name}) fixes none of the motions the datums before it leave free; "
                             "give another face as this datum or leave it out")
        least = CYLINDER_POINTS if isinstance(getattr(face, "Surface", None), Part.Cylinder) else DATUM_MIN_POINTS
        chosen = _spread_holding(points, normals, free, pivot, motions, least)
        found = None if reaching is None else reach(*reaching, points[chosen], normals[chosen])
        planned.append(DatumPoints(label, name, motions, uv[chosen], points[chosen], normals[chosen], found))
        free = free_after if labels is None else free
    return planned


def _too_few(label: str, name: str, count: int, probe: bool) -> str:
    """Why datum ``label`` (face ``name``) cannot be planned: it offers ``count`` (fewer than
    DATUM_MIN_POINTS) points away from its edges, or the probe (probe: one was given) reaches no
    more of them; what to change, in the words of the panel and of the API."""
    if probe and count == 0:
        return (f"datum {label} ({name}): the probe reaches no point of it on the part (a face the part rests on, "
                "or one its own material hides); measure the datums in a second set-up with the part turned, or "
                f"choose a face the probe reaches as datum {label} (the Datums field; datums=)")
    offers = "the probe reaches" if probe else "the face offers"
    return (f"datum {label} ({name}): {offers} only {count} point{'s' * (count != 1)} on it away from its edges, "
            f"{DATUM_MIN_POINTS} are needed; choose another face as datum {label} (the Datums field; datums=)")


def _candidates(face, margin: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(uv (M, 2), points (M, 3) mm, normals (M, 3)) of the face's raster nodes at least margin mm
    from its edges (all of them where none is that far), evenly thinned to DATUM_CANDIDATES."""
    setup = setup_of(face)
    nodes = face_nodes(setup.model, DATUM_GRID, setup.domain().on_face if setup.model.trimmed else None)
    counted = nodes.counted
    uv, points, normals = nodes.uv[counted], nodes.points[counted], nodes.normals[counted]
    if len(nodes.edge_points):
        inside = cKDTree(nodes.edge_points).query(points)[0] >= margin
        if inside.sum() >= DATUM_MIN_POINTS:
            uv, points, normals = uv[inside], points[inside], normals[inside]
    step = max(1, int(np.ceil(len(points) / DATUM_CANDIDATES)))
    return uv[::step], points[::step], normals[::step]


def _spread_holding(points: np.ndarray, normals: np.ndarray, free: np.ndarray, pivot: np.ndarray,
                    motions: int, least: int = DATUM_MIN_POINTS) -> np.ndarray:
    """Indices of points (M, 3) far apart (farthest-point order from the point farthest from
    their centroid): DATUM_POINTS_PER_MOTION per motion, at least ``least``, more where those do
    not yet hold the motions of free (6, K) that all the points hold."""
    count = min(len(points), max(least, DATUM_POINTS_PER_MOTION * motions))
    order = _farthest_order(points, len(points))
    while count < len(points) and split_motions(points[order[:count]], normals[order[:count]], free,
                                                pivot)[0].shape[1] < motions:
        count += 1
    return order[:count]


def _farthest_order(points: np.ndarray, count: int) -> np.ndarray:
    """The first count indices of points (M, 3) in farthest-point order: each the point farthest
    from those before it, starting from the one farthest from their centroid."""
    chosen = [int(np.argmax(np.linalg.norm(points - points.mean(axis=0), axis=1)))]
    distance = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return np.array(chosen)
