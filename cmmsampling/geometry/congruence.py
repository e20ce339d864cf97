"""Congruent faces: a face that is a rigid copy of another, as a pattern's instances are.

A part often repeats a feature (a fan's blades, a flange's bosses): their faces are the same
surface turned and moved, and so is every sampling problem on them. Face B copies face A when,
with B's parameters those of A moved by a constant ``shift`` (the same widths of the parameter
rectangle, e.g. a revolved surface started at another angle), B's points at RASTER x RASTER
places of the rectangle are A's turned by a proper rotation R and moved by t (least squares,
Kabsch), within TOLERANCE_MM, B's unit normals there are A's turned by R within
NORMAL_TOLERANCE (the same side out of the material), and the two faces' areas agree within
AREA_RTOL. Mirror images do not count (no proper rotation takes a face onto its mirror image).
The trim inside the rectangle is not compared here: a plan compares the two faces' domains and
judges the copied points on the copy itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .nurbs import NurbsPatch
    from .surface import SurfaceModel

RASTER = 9
TOLERANCE_MM = 1e-6
NORMAL_TOLERANCE = 1e-6
AREA_RTOL = 1e-6


@dataclass(frozen=True)
class RigidCopy:
    """How a face copies another: original: its index among the faces compared; rotation (3, 3)
    and translation (3,) mm take the original's points to the copy's (x -> R x + t); shift (2,):
    the copy's parameters are the original's plus it."""

    original: int
    rotation: np.ndarray
    translation: np.ndarray
    shift: np.ndarray

    @property
    def angle_deg(self) -> float:
        """The rotation's angle, degrees."""
        return float(np.degrees(np.arccos(np.clip((np.trace(self.rotation) - 1.0) / 2.0, -1.0, 1.0))))

    @property
    def distance_mm(self) -> float:
        """The translation's length, mm."""
        return float(np.linalg.norm(self.translation))

    @property
    def motion_text(self) -> str:
        """The motion in words, e.g. 'turned 30 deg, moved 41.2 mm' (a part below TOLERANCE_MM of
        motion left out; 'in place' for none)."""
        parts = [f"turned {self.angle_deg:.3g} deg"] if np.abs(self.rotation - np.eye(3)).max() > TOLERANCE_MM else []
        parts += [f"moved {self.distance_mm:.4g} mm"] if self.distance_mm > TOLERANCE_MM else []
        return ", ".join(parts) or "in place"


def raster(model: NurbsPatch, count: int = RASTER, centres: bool = False) -> np.ndarray:
    """(count^2, 2) parameters over the model's parameter rectangle, row by row: from corner to
    corner, or (centres) at the centres of count x count equal cells."""
    u0, u1, v0, v1 = model.bounds
    steps = (np.arange(count) + 0.5) / count if centres else np.linspace(0.0, 1.0, count)
    u, v = np.meshgrid(u0 + steps * (u1 - u0), v0 + steps * (v1 - v0), indexing="ij")
    return np.stack([u, v], -1).reshape(-1, 2)


def widths(model: NurbsPatch) -> np.ndarray:
    """(2,) the widths of the model's parameter rectangle."""
    u0, u1, v0, v1 = model.bounds
    return np.array([u1 - u0, v1 - v0])


def rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(rotation (3, 3), translation (3,), largest residual mm) of the proper rigid motion that takes
    points source (M, 3) closest to target (M, 3) in least squares (Kabsch)."""
    source_mean, target_mean = source.mean(0), target.mean(0)
    u, _, vt = np.linalg.svd((source - source_mean).T @ (target - target_mean))
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    rotation = vt.T @ flip @ u.T
    translation = target_mean - source_mean @ rotation.T
    residual = float(np.abs(source @ rotation.T + translation - target).max())
    return rotation, translation, residual


class FacePrint:
    """What the comparison needs of one face: model (SurfaceModel), area (mm^2), and its points
    and normals at the :func:`raster` of its parameter rectangle."""

    def __init__(self, model: SurfaceModel, area: float) -> None:
        self.model, self.area = model, float(area)
        self.widths = widths(model)
        places = raster(model)
        self.points, self.normals = model.points(places), model.normals(places)


def rigid_copy(original: FacePrint, copy: FacePrint, index: int = 0,
               tolerance: float = TOLERANCE_MM) -> RigidCopy | None:
    """The RigidCopy by which ``copy`` copies ``original`` (both FacePrints; index: the original's
    index, kept in the answer), None where it does not (see the module docstring)."""
    if abs(original.area - copy.area) > AREA_RTOL * max(original.area, copy.area):
        return None
    if not np.allclose(original.widths, copy.widths, rtol=1e-9, atol=1e-12):
        return None
    rotation, translation, residual = rigid_fit(original.points, copy.points)
    if residual > tolerance or np.abs(original.normals @ rotation.T - copy.normals).max() > NORMAL_TOLERANCE:
        return None
    shift = np.subtract(copy.model.bounds[0::2], original.model.bounds[0::2])
    return RigidCopy(index, rotation, translation, shift)


def face_copies(prints: list) -> list:
    """For each FacePrint (None: a face left out, copying none and copied by none), the RigidCopy
    of the first earlier face it copies that copies no other (an original), or None where it
    copies none: a list as long as prints."""
    found: list[RigidCopy | None] = []
    originals: list[int] = []
    for print_ in prints:
        copy = None
        if print_ is not None:
            copy = next((c for k in originals if (c := rigid_copy(prints[k], print_, k)) is not None), None)
            if copy is None:
                originals.append(len(found))
        found.append(copy)
    return found
