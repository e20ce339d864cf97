"""Which rigid motions a set of points on their faces holds: the twists (a rotation vector w rad
about a pivot and a shift s mm, (w, s) in R^6) that move the points off their faces, and those
that slide them along (a plane's in-plane motions, a cylinder's turn about its axis).

The inspection aligns on the held ones and keeps the others free; a plan spreads a datum face's
points until they hold what its face holds. Pure numpy/scipy."""
from __future__ import annotations

import numpy as np
from scipy.linalg import eigh

# A motion the points hold weakly: moving them 1 mm along it (a turn that moves them 1 mm RMS)
# changes their RMS distance from the face by less than this, mm: 1 % of the motion, so that a
# micrometre of probing error would set it to a tenth of a millimetre or more.
WEAK_SENSITIVITY = 0.01
# The regularisation of the motions' metric, as a share of its trace: a motion that moves none of
# the points (a turn about the line they lie on) counts as weakly held, not singular.
METRIC_FLOOR = 1e-12


def twist_jacobian(points: np.ndarray, normals: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """(M, 6): how the signed distances of points (M, 3) mm (outward normals (M, 3)) change by a
    twist (rotation vector w rad about pivot (3,) mm, shift s mm): ((p - pivot) x n, n)."""
    return np.hstack([np.cross(points - pivot, normals), normals])


def split_motions(points: np.ndarray, normals: np.ndarray, allowed: np.ndarray,
                  pivot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(held (6, H), weak (6, K - H)): the twists of allowed (6, K) that move points (M, 3) mm
    off their face (outward normals (M, 3)) by at least WEAK_SENSITIVITY mm RMS per mm RMS of
    the points' own motion, and those that do not; a held column moves the points 1 mm RMS."""
    if not allowed.shape[1]:
        return allowed, allowed
    jacobian = twist_jacobian(points, normals, pivot) @ allowed
    arms = points - pivot
    motion = np.cross(allowed[:3].T[None, :, :], arms[:, None, :]) + allowed[3:].T[None, :, :]
    metric = np.einsum("mki,mli->kl", motion, motion) / len(points)
    metric += METRIC_FLOOR * np.trace(metric) * np.eye(len(metric))
    values, vectors = eigh(jacobian.T @ jacobian / len(points), metric)
    weak = np.sqrt(np.maximum(values, 0.0)) < WEAK_SENSITIVITY
    return allowed @ vectors[:, ~weak], allowed @ vectors[:, weak]
