"""The picture of an inspection: the measured face's colour map, as a PNG.

The face is drawn from above (its tessellation in light grey, projected on the plane of its two
largest extents), each aligned measured point as a dot coloured by its signed deviation on a
scale centred on 0 mm (blue inside the material, red outside) reaching the largest |d|; with a
tolerance, its zone's bounds +-t / 2 are marked on the colour bar where they fall inside it, and
points outside the zone are ringed.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from ..geometry.surface import as_face
from .result import Inspection, verdict_words

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

# The tessellation's tolerance as a fraction of the face's diagonal.
MESH_FRACTION = 5e-3


def write_inspection_figure(inspection: Inspection, face: Part.Face | Sequence[Part.Face], path: str | os.PathLike,
                            title: str = "Measured deviation") -> str | os.PathLike:
    """Write the colour map of an Inspection's points on ``face`` (Part.Face, or a list of faces
    for a plan) to the PNG ``path``; returns path."""
    faces = face if isinstance(face, (list, tuple)) else [face]
    outlines = [_triangles(as_face(f)) for f in faces]
    every = np.concatenate([o.reshape(-1, 3) for o in outlines] + [inspection.points])
    axes_2d = np.sort(np.argsort(-np.ptp(every, axis=0), kind="stable")[:2])
    fig = Figure(figsize=(7.5, 6))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for triangles in outlines:
        ax.add_collection(PolyCollection(triangles[..., axes_2d], facecolors="0.88", edgecolors="0.88",
                                         linewidths=0.3))
    limit = float(np.abs(inspection.deviations).max()) or 1.0
    xy = inspection.points[:, axes_2d]
    dots = ax.scatter(xy[:, 0], xy[:, 1], c=inspection.deviations, cmap="coolwarm", vmin=-limit, vmax=limit,
                      s=36, edgecolors="black", linewidths=0.3, zorder=3)
    outside = ~inspection.within
    if outside.any():
        ax.scatter(xy[outside, 0], xy[outside, 1], s=110, facecolors="none", edgecolors="black", linewidths=1.2,
                   zorder=4, label="outside the zone")
        ax.legend(loc="upper right", fontsize=8)
    bar = fig.colorbar(dots, ax=ax)
    bar.set_label("signed deviation (mm), + out of the material")
    if inspection.tolerance and inspection.tolerance / 2.0 < limit:
        for bound in (-inspection.tolerance / 2.0, inspection.tolerance / 2.0):
            bar.ax.axhline(bound, color="black", linewidth=1.5)
    ax.set_title(f"{title}: profile {inspection.profile:.4f} mm{verdict_words(inspection)}", fontsize=10)
    names = "xyz"
    ax.set_xlabel(f"{names[axes_2d[0]]} (mm)")
    ax.set_ylabel(f"{names[axes_2d[1]]} (mm)")
    ax.set_aspect("equal")
    ax.autoscale_view()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def _triangles(face: Part.Face) -> np.ndarray:
    """The face's tessellation as (T, 3, 3) triangle corners, mm."""
    points, triangles = face.tessellate(MESH_FRACTION * face.BoundBox.DiagonalLength)
    corners = np.array([tuple(p) for p in points], dtype=float)
    return corners[np.array(triangles, dtype=int)] if triangles else np.zeros((0, 3, 3))
