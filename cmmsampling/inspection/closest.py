"""Closest points on a CAD face for many measured points at once.

OCC's distance, one query a point, took 1.5 ms a point: 30 s a pass over 20,000 points, which an
alignment makes several times. Here the feet are found all at once on the face's own NURBS model
(cmmsampling.geometry.surface.SurfaceModel, exact for B-spline and analytic faces): damped Newton
(cmmsampling.fitting.exact.closest_parameters) from the CLOSEST_STARTS nearest nodes of a raster
of the face, the nearest result kept; a foot outside the face's trim goes to the nearest point of
its edges, as the deviation's reverse side does. The deviations that decide the verdict, the
points nearest the zone's limits, are measured again with OCC (:func:`confirm_with_occ`).

A point's distance is to the bounded face, not to its surface extended past an edge (ISO 1101's
zone is swept by a ball along the bounded nominal): where the foot lies on an edge, the point is
judged by its whole distance to that foot, signed by the side of the face it lies on, and the
direction the distance grows in (:func:`distance_directions`) stands for the normal in every fit.
A zone offset o (ISO 1101's UZ) moves the foot by o along that direction, so a point past an edge
is judged by |d - o| too (not by its distance to the offset surface's own edge: the same over the
face, a simplification past it).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..fitting.exact import NearestParameters, _nearest_on_edge_curves, node_normals
from ..fitting.sides import normals_or
from ..measurement import closest_points
from ..strategies.face_setup import setup_of

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

# The raster whose nodes start the searches, per direction, and how many of the nearest start each.
CLOSEST_GRID = 60
CLOSEST_STARTS = 4
# The points with the largest |deviation - offset| measured again with OCC, and how far (mm) its
# foot may lie from this module's before the inspection says so.
OCC_CONFIRMED = 50
OCC_AGREEMENT_MM = 1e-6
# A foot is on an edge where the point lies more than this (mm) off the normal through it: the
# surface's own feet (Newton's and OCC's) lie off it by 1e-9 mm or less.
EDGE_REACH_MM = 1e-6
# Every DENSE_STEP-th raster node of the face (and every edge node) stands for the whole face.
DENSE_STEP = 2


def distance_directions(points: np.ndarray, feet: np.ndarray,
                        normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(directions (M, 3) unit, on_edge (M,) bool) for points (M, 3) mm, their feet on the
    bounded face (M, 3) mm and the face's outward unit normals there (M, 3): the direction in
    which the signed distance n' . (p - f) grows, the normal where the point lies on the normal
    through its foot, else (the foot on an edge, the point beyond it) the unit vector from the
    foot to the point, turned to the side of the face the point lies on (out of the material
    where n . (p - f) >= 0)."""
    gap = np.asarray(points, dtype=float) - feet
    along = np.einsum("ij,ij->i", gap, normals)
    length = np.linalg.norm(gap, axis=1)
    on_edge = np.linalg.norm(gap - along[:, None] * normals, axis=1) > EDGE_REACH_MM
    directions = np.array(normals, dtype=float)
    side = np.where(along[on_edge] >= 0.0, 1.0, -1.0)
    directions[on_edge] = side[:, None] * gap[on_edge] / length[on_edge, None]
    return directions, on_edge


class FaceCloser:
    """The closest points on one face (a Part.Face) for many points: call with points (M, 3) mm
    -> (feet (M, 3) mm, the directions the distances grow in (M, 3): the face's outward unit
    normals, or for a point beyond an edge the unit vector from its foot, :func:`distance_directions`).
    bounded False: the normals alone, the face's surface taken as extended past its edges (a
    datum's: ISO 5459 associates a datum with an ideal feature of unlimited extent, a plane for
    a planar face)."""

    def __init__(self, face: Part.Face, bounded: bool = True) -> None:
        self.bounded = bounded
        setup = setup_of(face)
        self.model = setup.model
        self.on_face = setup.domain().on_face if self.model.trimmed else None
        self.parameters = NearestParameters(self.model, self.on_face, CLOSEST_GRID, CLOSEST_STARTS)
        self.nodes = self.parameters.nodes
        self.fallback = node_normals(self.nodes)

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        feet, directions, _ = self.edges(points)
        return feet, directions

    def edges(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(feet (M, 3) mm, directions (M, 3), on_edge (M,) bool: the foot lies on an edge of
        the face and the point beyond it) for points (M, 3) mm."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        feet, near = self.parameters.locate(points)
        nearest, normals = self.model.points(feet), self.model.normals(feet)
        if self.on_face is not None:
            off = ~self.on_face(feet)
            if off.any():
                nearest[off], edge_uv = _nearest_on_edge_curves(self.model, self.nodes, points[off])
                normals[off] = self.model.normals(edge_uv)
        normals = normals_or(normals, self.fallback[near[:, 0]])
        if not self.bounded:
            return nearest, normals, np.zeros(len(points), dtype=bool)
        directions, on_edge = distance_directions(points, nearest, normals)
        return nearest, directions, on_edge


def dense_nodes(closer: FaceCloser) -> tuple[np.ndarray, np.ndarray]:
    """(points (M, 3) mm, outward normals (M, 3)): every DENSE_STEP-th raster node on the face
    and every edge node, the face as a whole."""
    nodes = closer.nodes
    kept = np.zeros_like(nodes.counted)
    kept[::DENSE_STEP, ::DENSE_STEP] = True
    kept &= nodes.counted
    return (np.vstack([nodes.points[kept], nodes.edge_points]),
            np.vstack([nodes.normals[kept], nodes.edge_normals]))


def confirm_with_occ(faces: Sequence[Part.Face], owner: np.ndarray, points: np.ndarray, deviations: np.ndarray,
                     offset: float = 0.0) -> tuple[np.ndarray, float]:
    """(deviations (N,) mm, largest disagreement mm): the signed deviations of points (N, 3) mm
    on their faces (owner (N,) indices into faces, Part.Face), those of the OCC_CONFIRMED points
    farthest from the zone's centre ``offset`` mm replaced by OCC's (the distance to its closest
    point on the bounded face, signed by the face's normal there: :func:`distance_directions`),
    and how far OCC's differed from the given ones at most."""
    deviations = np.array(deviations, dtype=float)
    rows = np.argsort(-np.abs(deviations - offset))[:OCC_CONFIRMED]
    disagreement = 0.0
    for index, face in enumerate(faces):
        mine = rows[owner[rows] == index]
        if not mine.size:
            continue
        feet, normals, _ = closest_points(face, points[mine])
        occ = np.einsum("ij,ij->i", points[mine] - feet, distance_directions(points[mine], feet, normals)[0])
        disagreement = max(disagreement, float(np.abs(occ - deviations[mine]).max()))
        deviations[mine] = occ
    return deviations, disagreement
