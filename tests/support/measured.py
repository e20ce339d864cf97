"""Measured points made by hand for the inspection's tests: points on a plane, moved rigidly, and
judged against their nominals on one face."""
import numpy as np
from scipy.spatial.transform import Rotation

import cmmsampling
from cmmsampling.inspection.judge import Planned

from .faces import Part


def judged(face, nominal, measured, **options):
    """cmmsampling.inspect of measured points (N, 3) mm labelled P1..PN against nominal points
    (N, 3) mm on one face."""
    labels = [f"P{k + 1}" for k in range(len(nominal))]
    planned = Planned(labels, nominal, [face], ["face"], np.zeros(len(nominal), dtype=int))
    normals = np.full_like(measured, np.nan)
    return cmmsampling.inspect(planned, cmmsampling.PointSet(labels, measured, normals), **options)


def moved(points, degrees, shift, about=None):
    """points (N, 3) mm turned by the rotation vector ``degrees`` (3,) about ``about`` (default
    their centroid) and shifted by ``shift`` (3,) mm."""
    centre = points.mean(axis=0) if about is None else about
    return Rotation.from_rotvec(np.radians(degrees)).apply(points - centre) + centre + np.asarray(shift)


def plane_points(count=36, seed=3):
    """(face, points (N, 3) mm) on the plane z = 0, 100 x 80 mm."""
    xy = np.random.default_rng(seed).uniform([5, 5], [95, 75], (count, 2))
    return Part.makePlane(100, 80), np.column_stack([xy, np.zeros(count)])
