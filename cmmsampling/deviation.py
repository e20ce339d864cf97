"""Deviation of the substitute geometry from the CAD face on an evaluation grid.

The deviation at a grid node (u, v) is the distance |S(u, v) - F(u, v)| in mm between the
substitute surface S and the CAD face F at the same parameters. It bounds the closest-point
distance from S(u, v) to F from above; the OCC cross-check reports both.
"""
from dataclasses import dataclass

import numpy as np

from .freecad_env import import_part

Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

DEFAULT_GRID = 60
OCC_DISTANCE_NODES = 50


class EvaluationGrid:
    """A regular (n_u x n_v) raster of the face's parameter range, with the nodes inside the face.

    uv: (n_u, n_v, 2); mask: (n_u, n_v) bool, True where the node lies on the face.
    """

    def __init__(self, model, size=DEFAULT_GRID):
        self.size = _grid_size(size)
        self.uv = model.raster(self.size)
        self.mask = np.ones(self.size, dtype=bool)
        self.cad = model.points(self.uv)

    @property
    def nodes(self):
        """The (K, 2) parameters of the nodes inside the face."""
        return self.uv[self.mask]


def _grid_size(size):
    """(n_u, n_v) from an int or a pair."""
    pair = (size, size) if np.ndim(size) == 0 else tuple(size)
    return tuple(int(s) for s in pair)


class DeviationObjective:
    """Maximum deviation of the substitute fit, for whole swarms of point sets at once.

    model: SurfaceModel (the CAD truth); space: SubstituteSpace; grid: EvaluationGrid.
    Calling it with uv: (P, N, 2) returns (P,) maximum deviations in mm.
    """

    def __init__(self, model, space, grid):
        self.model = model
        self.space = space
        self.grid = grid
        u = grid.uv[:, 0, 0]
        v = grid.uv[0, :, 1]
        self._grid_u = space.bases(np.column_stack([u, np.full_like(u, v[0])]))[0][0]
        self._grid_v_t = space.bases(np.column_stack([np.full_like(v, u[0]), v]))[1][0].T.copy()
        self._cad = np.ascontiguousarray(grid.cad.transpose(0, 2, 1))
        self._mask = grid.mask
        self.evaluations = 0

    def fit(self, uv):
        """Substitute poles for point sets at uv: (..., N, 2) -> (..., n_u, n_v, 3)."""
        return self.space.fit(uv, self.model.points(uv))

    def squared_field(self, poles):
        """Squared deviation on the grid for poles (P, n_u, n_v, 3) -> (P, g_u, g_v) mm^2."""
        n_u, n_v = self.space.poles
        count = poles.shape[0]
        by_coord = np.ascontiguousarray(poles.transpose(0, 1, 3, 2)).reshape(count, n_u, 3 * n_v)
        along_u = np.matmul(self._grid_u, by_coord).reshape(count, -1, n_v)
        surface = np.matmul(along_u, self._grid_v_t).reshape((count,) + self._cad.shape)
        surface -= self._cad
        np.square(surface, out=surface)
        return surface.sum(axis=2)

    def __call__(self, uv):
        """Maximum deviation of each point set's substitute: uv (P, N, 2) -> (P,) mm."""
        uv = np.asarray(uv, dtype=float)
        squared = self.squared_field(self.fit(uv))
        self.evaluations += uv.shape[0]
        return np.sqrt(squared[:, self._mask].max(axis=1))

    def field(self, uv):
        """Deviation field and poles of one point set: uv (N, 2) -> ((g_u, g_v) mm, (n_u, n_v, 3))."""
        poles = self.fit(np.asarray(uv, dtype=float)[None])
        return np.sqrt(self.squared_field(poles)[0]), poles[0]


@dataclass
class DeviationStats:
    """Deviation of a substitute surface from the CAD face, all in mm.

    maximum, mean, rms, std: over the grid nodes inside the face.
    field: (g_u, g_v) deviation per node (NaN outside the face); grid_uv: (g_u, g_v, 2).
    occ_maximum: the same maximum with both surfaces evaluated by OpenCASCADE.
    occ_distance_maximum: OCC closest-point distance from the substitute to the CAD face,
    the largest over the grid nodes of largest deviation (at most OCC_DISTANCE_NODES of them).
    """

    maximum: float
    mean: float
    rms: float
    std: float
    field: np.ndarray
    grid_uv: np.ndarray
    occ_maximum: float = float("nan")
    occ_distance_maximum: float = float("nan")

    @classmethod
    def from_field(cls, field, grid):
        """Statistics of a (g_u, g_v) deviation field over the grid's nodes inside the face."""
        inside = field[grid.mask]
        shown = np.where(grid.mask, field, np.nan)
        return cls(
            maximum=float(inside.max()),
            mean=float(inside.mean()),
            rms=float(np.sqrt(np.mean(inside**2))),
            std=float(inside.std()),
            field=shown,
            grid_uv=grid.uv,
        )


def occ_cross_check(stats, substitute, face):
    """Fill stats.occ_maximum and stats.occ_distance_maximum using OpenCASCADE only.

    substitute: the fitted Part.BSplineSurface; face: the CAD Part.Face (its (u, v) are the grid's).
    """
    nodes = stats.grid_uv[~np.isnan(stats.field)]
    cad = face.Surface
    gaps = np.array([(substitute.value(u, v) - cad.value(u, v)).Length for u, v in nodes])
    stats.occ_maximum = float(gaps.max())
    worst = nodes[np.argsort(gaps)[-OCC_DISTANCE_NODES:]]
    distances = [face.distToShape(Part.Vertex(substitute.value(u, v)))[0] for u, v in worst]
    stats.occ_distance_maximum = float(max(distances))
    return stats
