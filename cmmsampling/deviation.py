"""Deviation of the substitute geometry from the CAD face on an evaluation grid.

The deviation at a grid node (u, v) is the distance |S(u, v) - F(u, v)| in mm between the
substitute surface S and the CAD face F at the same parameters. It bounds the closest-point
distance from S(u, v) to F from above; the OCC cross-check (cmmsampling.crosscheck) reports both.
Pure numpy: the objective can be shipped to a worker process.
"""
from dataclasses import dataclass

import numpy as np

from .bspline import design_matrices

DEFAULT_GRID = 60


class EvaluationGrid:
    """A regular (n_u x n_v) raster of the face's parameter range, with the nodes inside the face.

    uv: (n_u, n_v, 2); mask: (n_u, n_v) bool, True where the node lies on the face (inside its
    trimming loops, when a FaceDomain is given; every node otherwise).
    """

    def __init__(self, model, size=DEFAULT_GRID, domain=None):
        self.size = _grid_size(size)
        self.uv = model.raster(self.size)
        self.mask = np.ones(self.size, dtype=bool) if domain is None else domain.on_face(self.uv)
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

    model: the CAD truth (a SurfaceModel or NurbsPatch; only its NurbsPatch is kept, so the
    objective pickles without FreeCAD objects); space: SubstituteSpace; grid: EvaluationGrid.
    Calling it with uv: (P, N, 2) returns (P,) maximum deviations in mm.
    """

    def __init__(self, model, space, grid):
        self.model = model.patch()
        self.space = space
        self.grid = grid
        u = grid.uv[:, 0, 0]
        v = grid.uv[0, :, 1]
        self._grid_u = design_matrices(space.uknots, space.degrees[0], u)[0]
        self._grid_v_t = design_matrices(space.vknots, space.degrees[1], v)[0].T.copy()
        self._cad = np.ascontiguousarray(grid.cad.transpose(2, 0, 1))
        self._inside = None if grid.mask.all() else grid.mask.ravel()
        self.evaluations = 0

    def fit(self, uv):
        """Substitute poles for point sets at uv: (..., N, 2) -> (..., n_u, n_v, 3).

        Points and basis rows are laid out coordinate (or basis) before the points, so that every
        elementwise step runs along the points, and each point set is computed the same way
        whatever the size of the batch.
        """
        uv = np.asarray(uv, dtype=float)
        u, v = np.ascontiguousarray(uv[..., 0]), np.ascontiguousarray(uv[..., 1])
        points = self.model.points_by_coordinate(u, v)
        return self.space.solve(self.space.u_basis.values(u), self.space.v_basis.values(v), points)

    def squared_field(self, poles):
        """Squared deviation on the grid for poles (P, n_u, n_v, 3) -> (P, g_u, g_v) mm^2."""
        by_coord = np.ascontiguousarray(poles.transpose(0, 3, 1, 2))
        surface = np.matmul(np.matmul(self._grid_u, by_coord), self._grid_v_t)
        surface -= self._cad
        return np.einsum("pcij,pcij->pij", surface, surface)

    def grid_error(self, poles):
        """Error S - F on the grid for one substitute, poles (n_u * n_v, 3) or (n_u, n_v, 3).

        Returns (error (3, g_u, g_v) mm, distance (g_u, g_v) mm, inside (g_u, g_v) bool).
        """
        by_coord = np.asarray(poles).reshape(self.space.poles + (3,)).transpose(2, 0, 1)
        error = self._grid_u @ by_coord @ self._grid_v_t - self._cad
        return error, np.sqrt((error ** 2).sum(axis=0)), self.grid.mask

    def grid_transpose(self, field):
        """G^T applied to a grid field (3, g_u, g_v): the (n_u * n_v, 3) pole-space result."""
        pulled = self._grid_u.T @ field @ self._grid_v_t.T
        return pulled.transpose(1, 2, 0).reshape(-1, 3)

    def __call__(self, uv):
        """Maximum deviation of each point set's substitute: uv (P, N, 2) -> (P,) mm."""
        uv = np.asarray(uv, dtype=float)
        squared = self.squared_field(self.fit(uv)).reshape(uv.shape[0], -1)
        if self._inside is not None:
            squared = squared[:, self._inside]
        self.evaluations += uv.shape[0]
        return np.sqrt(squared.max(axis=1))

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
    the largest over the grid nodes of largest deviation (see cmmsampling.crosscheck).
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
