"""Measured points against the CAD face: OCC closest-point distances, signed (the reverse flow of
an export: points a CMM measured, read from its file, judged against the face they came from)."""
from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .formats.exporting import as_point_set, checked
from .formats.frames import placement_from_metadata, resolve_frame, to_global
from .formats.pointfiles import read_points
from .formats.pointset import PointSet
from .geometry.freecad_env import import_part
from .geometry.occ_distance import distances_to_face
from .geometry.surface import as_face
from .geometry.validation import InputError, check_real

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)


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
    def maximum(self) -> float:
        """Largest |distance|, mm."""
        return float(np.abs(self.distances).max())

    @property
    def mean(self) -> float:
        """Mean |distance|, mm."""
        return float(np.abs(self.distances).mean())

    @property
    def rms(self) -> float:
        """Root mean square distance, mm."""
        return float(np.sqrt(np.mean(self.distances ** 2)))

    def summary(self) -> dict[str, float]:
        """The figures as a dict: n, max_mm, mean_mm, rms_mm, lowest_mm and highest_mm (signed)."""
        return {"n": len(self.labels), "max_mm": self.maximum, "mean_mm": self.mean, "rms_mm": self.rms,
                "lowest_mm": float(self.distances.min()), "highest_mm": float(self.distances.max())}


def measured_deviation(face: Part.Face, points: PointSet | str | os.PathLike, *, frame: object = None,
                       probe_radius: float | None = None) -> MeasuredDeviation:
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
    radius = (stated_radius(point_set) if probe_radius is None
              else check_real("probe_radius", probe_radius, minimum=0.0))
    measured = checked(point_set)
    positions = measured.points
    if placement is not None:
        positions = to_global(measured.points, measured.normals, placement)[0]
    check_extent(positions, measured.labels)
    closest, normals, distances = closest_points(face, positions)
    side = np.sign(np.einsum("ij,ij->i", positions - closest, normals))
    return MeasuredDeviation(measured.labels, side * distances - radius, closest, radius)


# The farthest a measured point may lie from the origin, mm: beyond it the file's units or
# numbers are wrong (no CMM measures a kilometre).
MAX_COORDINATE_MM = 1e6


def stated_radius(point_set: PointSet) -> float:
    """The probe radius (mm) the point file states (0 when none); InputError for a stated value
    that is no finite number of at least 0."""
    stated = point_set.metadata.get("probe_radius_mm", 0.0)
    where = point_set.metadata.get("path", "the points")
    try:
        value = float(stated)
    except (TypeError, ValueError):
        raise InputError(f"{where}: the stated probe_radius_mm {stated!r} is not a number; correct the file's "
                         "comment or give probe_radius=") from None
    return check_real(f"{where}: the stated probe_radius_mm", value, minimum=0.0)


def check_extent(positions: np.ndarray, labels: Sequence[str]) -> None:
    """InputError naming the first point farther than MAX_COORDINATE_MM from the origin.
    positions: (N, 3) mm in the part's frame; labels: N names."""
    far = np.flatnonzero(np.abs(positions).max(axis=1) > MAX_COORDINATE_MM)
    if far.size:
        raise InputError(f"point {labels[far[0]]} lies {np.abs(positions[far[0]]).max():.3g} mm from the origin; "
                         "check the file's numbers and units (mm)")


def closest_points(face: Part.Face, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For points (N, 3) mm: the closest points on face (N, 3) mm, the face's outward unit normals
    there (N, 3) and the distances (N,) mm, by OCC
    (:func:`cmmsampling.geometry.occ_distance.distances_to_face`)."""
    distances, feet = distances_to_face(face, points)
    normals = [tuple(face.normalAt(*face.Surface.parameter(FreeCAD.Vector(*foot)))) for foot in feet]
    return feet, np.array(normals, dtype=float).reshape(-1, 3), distances
