"""Closest points on a CAD face for many measured points at once.

OCC's distance, one query a point, took 1.5 ms a point: 30 s a pass over 20,000 points, which an
alignment makes several times. Here the feet are found all at once on the face's own NURBS model
(cmmsampling.geometry.surface.SurfaceModel, exact for B-spline and analytic faces): damped Newton
(cmmsampling.fitting.exact.closest_parameters) from the CLOSEST_STARTS nearest nodes of a raster
of the face, the nearest result kept; a foot outside the face's trim goes to the nearest point of
its edges, as the deviation's reverse side does. The deviations that decide the verdict, the
points nearest the zone's limits, are measured again with OCC (:func:`confirm_with_occ`).
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


class FaceCloser:
    """The closest points on one face (a Part.Face) for many points: call with points (M, 3) mm
    -> (feet (M, 3) mm, the face's outward unit normals there (M, 3))."""

    def __init__(self, face: Part.Face) -> None:
        setup = setup_of(face)
        self.model = setup.model
        self.on_face = setup.domain().on_face if self.model.trimmed else None
        self.parameters = NearestParameters(self.model, self.on_face, CLOSEST_GRID, CLOSEST_STARTS)
        self.nodes = self.parameters.nodes
        self.fallback = node_normals(self.nodes)

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        feet, near = self.parameters.locate(points)
        nearest, normals = self.model.points(feet), self.model.normals(feet)
        if self.on_face is not None:
            off = ~self.on_face(feet)
            if off.any():
                nearest[off], edge_uv = _nearest_on_edge_curves(self.model, self.nodes, points[off])
                normals[off] = self.model.normals(edge_uv)
        return nearest, normals_or(normals, self.fallback[near[:, 0]])


def confirm_with_occ(faces: Sequence[Part.Face], owner: np.ndarray, points: np.ndarray, deviations: np.ndarray,
                     offset: float = 0.0) -> tuple[np.ndarray, float]:
    """(deviations (N,) mm, largest disagreement mm): the signed deviations of points (N, 3) mm
    on their faces (owner (N,) indices into faces, Part.Face), those of the OCC_CONFIRMED points
    farthest from the zone's centre ``offset`` mm replaced by OCC's (its closest point and the
    face's normal there), and how far OCC's differed from the given ones at most."""
    deviations = np.array(deviations, dtype=float)
    rows = np.argsort(-np.abs(deviations - offset))[:OCC_CONFIRMED]
    disagreement = 0.0
    for index, face in enumerate(faces):
        mine = rows[owner[rows] == index]
        if not mine.size:
            continue
        feet, normals, _ = closest_points(face, points[mine])
        occ = np.einsum("ij,ij->i", points[mine] - feet, normals)
        disagreement = max(disagreement, float(np.abs(occ - deviations[mine]).max()))
        deviations[mine] = occ
    return deviations, disagreement
