"""SamplingResult: the probe points of one run and how well their substitute fits the face."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..access.probe_moves import NO_PART, moves_through
from ..fitting.occ_surface import substitute_surface, trimmed_like
from ..geometry.validation import InputError
from .blind import projection_frame

if TYPE_CHECKING:   # for the annotations only: the modules import this one
    import Part   # FreeCAD ships no type stubs: to the type checker Part's classes are Any

    from ..access.probe import Motion
    from ..access.probe_moves import ProbeMoves
    from ..access.reach import Access, Reachability
    from ..fitting.bound import MinimaxBound
    from ..fitting.deviation import DeviationStats
    from ..fitting.substitute import SubstituteSpace
    from ..geometry.surface import SurfaceModel
    from .problem import SamplingProblem

# A substitute within this share of the face's diagonal of it reproduces it: rounding, and the
# smoothing's pull on the fit's edges along the face (a plane's substitute shrinks by ~1e-9 of its size).
EXACT_FIT = 1e-6


@dataclass
class SamplingResult:
    """One sampling run.

    strategy: its name; n: number of points; uv: (N, 2) on ``model.face``; points: (N, 3) mm;
    normals: (N, 3) unit vectors out of the material (the probe approaches along -normal);
    poles: (n_u, n_v, 3) mm, the substitute's poles; space: its SubstituteSpace;
    deviation: DeviationStats at the nodes of the evaluation grid (cmmsampling.fitting.deviation); history: best maximum deviation (mm) per
    iteration for the optimisers, else None; evaluations: fitness evaluations;
    timings: seconds per phase; settings: every parameter of the run; cancelled: stopped early;
    check: DeviationStats on the check grid (3x denser than the grid optimised on), computed on
    first use (about half a second);
    problem: the SamplingProblem it was computed for (grids, objective, bounds); access: how the
    probe reaches each point when the run was given the part (cmmsampling.access.reach.Access:
    reachable, axes, tilts, head angles), else None.
    """

    strategy: str
    uv: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    poles: np.ndarray
    space: SubstituteSpace
    deviation: DeviationStats
    model: SurfaceModel
    history: np.ndarray | None = None
    evaluations: int = 0
    timings: dict[str, float] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    cancelled: bool = False
    problem: SamplingProblem | None = None
    notes: list[str] = field(default_factory=list)
    access: Access | None = None
    _bounds: dict | None = field(default=None, repr=False)
    _check: DeviationStats | None = field(default=None, repr=False)

    @property
    def check(self) -> DeviationStats:
        """DeviationStats at the nodes of the check grid, 3x denser than the grid optimised on."""
        if self._check is None:
            self._check = cast("SamplingProblem", self.problem).deviation(self.poles, check=True)
        return self._check

    @property
    def exact(self) -> bool:
        """True when the substitute reproduces the face to rounding (e.g. a plane): every point set
        is then as good as any other."""
        return self.deviation.maximum <= EXACT_FIT * self.model.diagonal

    @property
    def n(self) -> int:
        """Number of probe points."""
        return len(self.uv)

    @property
    def face(self) -> Part.Face:
        """The face as it was given."""
        return self.model.source_face

    @property
    def substitute(self) -> Part.BSplineSurface:
        """The fitted substitute surface as a Part.BSplineSurface over the face's parameter range
        (the surface the deviation is measured on; never extended beyond it)."""
        return substitute_surface(self.space, self.poles)

    def substitute_shape(self) -> Part.Face:
        """The delivered substitute as a Part.Face: :attr:`substitute` trimmed like the face in the
        parameter plane (the document's Substitute surface)."""
        return trimmed_like(self.face, self.substitute)

    def bounds(self) -> dict[str, MinimaxBound]:
        """Local bounds about this result's substitute, mm: the least maximum deviation that
        moving its poles along its normals could reach (cmmsampling.fitting.bound).

        {"grid": MinimaxBound on the evaluation grid, "check": on the check grid}; computed on first
        call (about a second), then kept.
        """
        if self._bounds is None:
            self._bounds = cast("SamplingProblem", self.problem).bounds(self.poles)
        return self._bounds

    def bound_exceeds(self, level: float) -> tuple[bool, float]:
        """(exceeds, bound): whether the local bound on the grid (:meth:`bounds`) exceeds ``level``
        mm, and that bound (mm) where telling took computing it, else NaN. A bracket around it
        (reweighted least squares, milliseconds) tells where it lies wholly above or below
        ``level``; the linear programme (a quarter of a second on a 30 x 30 grid) only where not."""
        if self._bounds is None or "grid" not in self._bounds:
            lower, upper = cast("SamplingProblem", self.problem).bound_bracket(self.poles, level)
            if lower > level or upper <= level:
                return lower > level, float("nan")
        bound = self.bounds()["grid"].lower
        return bound > level, bound

    def multiple_of_bound(self, check: bool = False) -> float:
        """Maximum deviation as a multiple of the local bound about this substitute (about 1 when
        no reshaping of it along its normals lowers its maximum; see :meth:`bounds`), on the grid
        or the check grid; 1 when the fit is exact (see :attr:`exact`)."""
        if self.exact:
            return 1.0
        bound = self.bounds()["check" if check else "grid"].lower
        maximum = (self.check if check else self.deviation).maximum
        return maximum / bound if bound > 0 else float("inf")

    @property
    def labels(self) -> list[str]:
        """Point labels P1..PN."""
        return [f"P{i + 1}" for i in range(self.n)]

    def summary(self) -> dict[str, Any]:
        """The headline figures as a dict (deviations in mm, the largest normal angle in degrees,
        times in s)."""
        return {
            "strategy": self.strategy,
            "n": self.n,
            **self.deviation.figures(),
            "normal_angle_deg": self.deviation.normal_angle,
            "check_max_mm": self.check.maximum,
            "time_s": self.timings.get("total_s", float("nan")),
            "evaluations": self.evaluations,
            "cancelled": self.cancelled,
        }

    def __repr__(self) -> str:
        d = self.deviation
        return (
            f"<SamplingResult {self.strategy} N={self.n} max={d.maximum:.4f} mm "
            f"mean={d.mean:.4f} mm rms={d.rms:.4f} mm in {self.timings.get('total_s', 0):.2f} s"
            f"{' (cancelled)' if self.cancelled else ''}>"
        )

    def substitute_grid(self) -> np.ndarray:
        """The substitute surface on the evaluation raster: (g_u, g_v, 3) mm."""
        return self.space.evaluate(self.poles, self.deviation.grid_uv)

    def map_coordinates(self) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
        """Plot coordinates of the deviation grid and of the probe points, with axis labels.

        Returns (grid (g_u, g_v, 2), points (N, 2), (x label, y label)): the machine footprint in
        mm where it is one-to-one (:func:`footprint`), else the face's (u, v) parameters.
        """
        uv = self.deviation.grid_uv
        view = footprint(self.model, uv)
        if view is None:
            return uv, self.uv, ("u (face parameter)", "v (face parameter)")
        xy, names, frame = view
        return xy, self.points @ frame[:2].T, tuple(f"{name} (mm)" for name in names)

    def probe_moves(self, motion: Motion | None = None) -> ProbeMoves:
        """The collision-free probe path through the points (cmmsampling.access.probe_moves.ProbeMoves;
        motion: the CMM's speeds for the time estimate, a Motion). ValueError for a run made without
        the part (``sample(..., part=)``) or with points the probe cannot reach."""
        access = self.access
        if access is None:
            raise InputError(NO_PART)
        if not access.reachable.all():
            blocked = ", ".join(f"P{k + 1}" for k in np.flatnonzero(~access.reachable)[:10])
            raise InputError(f"the probe cannot reach {np.count_nonzero(~access.reachable)} of the points ({blocked}); "
                             "sample again with part= (the run keeps to what the probe reaches) or export with "
                             "order='short_path'")
        reachability = cast("Reachability", cast("SamplingProblem", self.problem).reachability)
        return moves_through(reachability.probe, reachability.obstacles, self.points, self.normals, access.axes, motion)

    def point_table(self) -> list[tuple[str | float, ...]]:
        """Per-point rows (label, x, y, z, i, j, k, u, v) as a list of tuples."""
        return [
            (label, *map(float, p), *map(float, nrm), *map(float, uv))
            for label, p, nrm, uv in zip(self.labels, self.points, self.normals, self.uv)
        ]


def footprint(model: SurfaceModel, uv: np.ndarray) -> tuple[np.ndarray, tuple[str, ...], np.ndarray] | None:
    """The face seen along the machine axis closest to its mean normal.

    model: the face's SurfaceModel; uv: (g_u, g_v, 2) grid of parameters. Returns (xy (g_u, g_v,
    2) mm, (name_1, name_2), frame (3, 3)) where the view is one-to-one on the grid (every cell
    keeps its orientation), else None (a face that folds over itself in every machine view, e.g. a
    whole cylinder).
    """
    frame = projection_frame(model)
    xy = model.points(uv.reshape(-1, 2)).reshape(uv.shape[:2] + (3,)) @ frame[:2].T
    along_u = xy[1:, :-1] - xy[:-1, :-1]
    along_v = xy[:-1, 1:] - xy[:-1, :-1]
    turn = along_u[..., 0] * along_v[..., 1] - along_u[..., 1] * along_v[..., 0]
    if not (np.all(turn > 0) or np.all(turn < 0)):
        return None
    names = tuple("xyz"[int(np.argmax(np.abs(axis)))] for axis in frame[:2])
    return xy, names, frame
