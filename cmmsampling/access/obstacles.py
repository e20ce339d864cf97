"""A part as points on its faces, for fast clearance tests of a probe's pieces.

Points on every face (OCC's tessellation, its triangles filled to ``spacing`` mm) sit in a
KD-tree. A ball swept along a segment (a capsule) or a flat-ended cylinder is blocked when a
part point lies within it grown by ``margin`` (the spacing and the tessellation's deflection:
how far the surface may lie from its nearest point), so the tests err on the side of blocking.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

# Ball centres along a swept ball are this fraction of its radius apart.
SPHERE_STEP = 0.5
# The finest spacing of a part's points, mm, and the most points a part is modelled by (about
# 100 MiB with their k-d tree); a larger part gets them farther apart.
FINEST_SPACING_MM = 0.5
MAX_POINTS = 2_000_000


class Obstacles:
    """A part as points for fast clearance tests.

    part: a Part.Shape (solid, shell or faces); spacing: mm between neighbouring points on its
    faces (default: a fortieth of the part's diagonal, at most 0.5 mm), widened where the part
    would take more than max_points points (``coarsened`` says so: a large part's clearances
    are then judged with a wider margin, erring further on the side of blocking); deflection:
    OCC's tessellation tolerance, mm (default spacing / 5). box: (2, 3) the part's bounding box,
    mm; margin: mm added to every capsule's radius.
    """

    def __init__(self, part: Part.Shape, spacing: float | None = None, deflection: float | None = None,
                 max_points: int = MAX_POINTS) -> None:
        box = part.BoundBox
        self.box = np.array([[box.XMin, box.YMin, box.ZMin], [box.XMax, box.YMax, box.ZMax]])
        wanted = float(spacing or min(FINEST_SPACING_MM, box.DiagonalLength / 40.0))
        spacing = max(wanted, np.sqrt(part.Area / max_points))   # a fill holds at least area / spacing^2 points
        assert spacing is not None   # max() of two numbers
        self.deflection = float(deflection or spacing / 5.0)
        meshes = [_mesh(face, self.deflection) for face in part.Faces]
        self.spacing = _spacing_within(meshes, spacing, max_points)
        self.coarsened = self.spacing > wanted
        self.points = np.concatenate([_fill(vertices, corners, self.spacing) for vertices, corners in meshes])
        self.tree = cKDTree(self.points)
        self.margin = self.spacing + self.deflection

    def swept_blocked(self, starts: np.ndarray, ends: np.ndarray, radii: np.ndarray | float, margin: bool = True,
                      overreach: float | None = None) -> np.ndarray:
        """Balls swept along segments (capsules from starts (M, 3) to ends (M, 3), radius radii
        (M,), mm) that a part point lies within (plus the margin unless margin=False): (M,) bool.
        The capsule is covered by balls along its segment, a little larger than it between them:
        by at most ``overreach`` mm where given (the balls then lie closer together)."""
        radii = np.broadcast_to(np.asarray(radii, float), (len(starts),))
        steps = np.maximum(SPHERE_STEP * radii, self.spacing)
        if overreach is not None:   # a ball of radius r every s mm reaches sqrt(r^2 + (s/2)^2) from the axis
            steps = np.minimum(steps, 2.0 * np.sqrt(2.0 * radii * overreach + overreach ** 2))
        centres, owner, steps = along_segments(starts, ends, steps)
        reach = np.sqrt(radii ** 2 + (0.5 * steps) ** 2)[owner] + (self.margin if margin else 0.0)
        hit = np.zeros(owner.size, dtype=bool)
        for value in np.unique(reach):
            chosen = reach == value
            distances, _ = self.tree.query(centres[chosen], k=1, distance_upper_bound=value)
            hit[chosen] = np.isfinite(distances)
        return np.bincount(owner, weights=hit, minlength=len(starts)) > 0

    def cylinders_blocked(self, starts: np.ndarray, ends: np.ndarray, radii: np.ndarray | float) -> np.ndarray:
        """Flat-ended cylinders (axis from starts (M, 3) to ends (M, 3), radius radii (M,), mm),
        each grown by the margin, that hold a part point: (M,) bool.

        Balls around pieces of each axis find the part points near it: a piece with no point in
        its ball is clear, one at least a radius from both ends with a point within the radius is
        blocked (that ball lies inside the cylinder); only the others, of cylinders not blocked so,
        test their points against the cylinder itself."""
        starts, ends = np.asarray(starts, float), np.asarray(ends, float)
        radii = np.broadcast_to(np.asarray(radii, float), (len(starts),)) + self.margin
        centres, owner, steps = along_segments(starts, ends, np.maximum(SPHERE_STEP * radii, self.spacing))
        lengths = np.linalg.norm(ends - starts, axis=1)
        bounding = np.sqrt(radii ** 2 + (0.5 * steps) ** 2)[owner]
        distances = np.full(len(centres), np.inf)
        for value in np.unique(bounding):
            chosen = bounding == value
            distances[chosen] = self.tree.query(centres[chosen], k=1, distance_upper_bound=value)[0]
        along = np.linalg.norm(centres - starts[owner], axis=1)
        interior = (along >= radii[owner]) & (lengths[owner] - along >= radii[owner])
        hit = interior & (distances <= radii[owner])
        settled = np.bincount(owner, weights=hit, minlength=len(starts)) > 0
        unsure = np.isfinite(distances) & ~hit & ~settled[owner]
        if unsure.any():
            hit[unsure] = self._pieces_hold_points(centres[unsure], bounding[unsure], owner[unsure], starts, ends,
                                                   radii)
        return np.bincount(owner, weights=hit, minlength=len(starts)) > 0

    def _pieces_hold_points(self, centres: np.ndarray, bounding: np.ndarray, owner: np.ndarray, starts: np.ndarray,
                            ends: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(P,) bool: pieces (ball centres (P, 3), radii bounding (P,)) of the cylinders ``owner``
        (P,) whose balls hold a point inside the cylinder (starts, ends (M, 3), radii (M,))."""
        found = self.tree.query_ball_point(centres, bounding, return_sorted=False)
        counts = np.fromiter(map(len, found), dtype=int, count=len(found))
        indices = np.concatenate([np.asarray(f, dtype=int) for f in found]) if counts.sum() else np.zeros(0, int)
        piece = np.repeat(np.arange(len(centres)), counts)
        cylinder = owner[piece]
        axis = ends - starts
        length = np.linalg.norm(axis, axis=1)
        unit = axis / np.maximum(length, 1e-12)[:, None]
        offset = self.points[indices] - starts[cylinder]
        along = np.einsum("pc,pc->p", offset, unit[cylinder])
        across = np.linalg.norm(offset - along[:, None] * unit[cylinder], axis=1)
        inside = (along >= -self.margin) & (along <= length[cylinder] + self.margin) & (across <= radii[cylinder])
        return np.bincount(piece, weights=inside, minlength=len(centres)) > 0

    def exits(self, starts: np.ndarray, axes: np.ndarray, grow: float) -> tuple[np.ndarray, np.ndarray]:
        """(lengths (M,) mm, points (M, 3) mm): how far along axes (M, 3) unit the starts (M, 3)
        leave the part's box grown by ``grow`` mm (0 for a start already outside), and where."""
        low, high = self.box[0] - grow, self.box[1] + grow
        with np.errstate(divide="ignore", invalid="ignore"):
            far = np.where(axes > 0, (high - starts) / axes, np.where(axes < 0, (low - starts) / axes, np.inf))
        lengths = np.maximum(far.min(axis=1), 0.0)
        return lengths, starts + lengths[:, None] * axes

def along_segments(starts: np.ndarray, ends: np.ndarray,
                   steps: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points along segments from starts (M, 3) to ends (M, 3), at most steps (M,) apart, both
    ends included: (points (P, 3), owner (P,) the segment of each, steps (M,) as used)."""
    starts, ends = np.asarray(starts, float), np.asarray(ends, float)
    steps = np.broadcast_to(np.asarray(steps, float), (len(starts),))
    lengths = np.linalg.norm(ends - starts, axis=1)
    counts = np.ceil(lengths / steps).astype(int) + 1
    owner = np.repeat(np.arange(len(starts)), counts)
    first = np.cumsum(counts) - counts
    t = (np.arange(owner.size) - first[owner]) / np.maximum(counts[owner] - 1, 1)
    return starts[owner] + t[:, None] * (ends - starts)[owner], owner, lengths / np.maximum(counts - 1, 1)


def _mesh(face: Part.Face, deflection: float) -> tuple[np.ndarray, np.ndarray]:
    """A face's tessellation: (vertices (V, 3) mm, triangles' corners (T, 3, 3) mm)."""
    vertices, triangles = face.tessellate(deflection)
    vertices = np.array([[v.x, v.y, v.z] for v in vertices], dtype=float).reshape(-1, 3)
    triangles = np.array(triangles, dtype=int).reshape(-1, 3)
    return vertices, vertices[triangles]


def _grids(corners: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """How each triangle (corners (T, 3, 3) mm) is filled so that neighbouring points are at
    most spacing mm apart: (rows (T,), steps (T,)) ints. A triangle of rows 0 is filled on a
    barycentric grid of ``steps`` steps per side; one with rows > 0 (a long thin triangle, where
    that takes fewer points) by ``rows`` + 1 segments parallel to its longest side, from that side
    to the opposite corner, each of ``steps`` steps."""
    sides = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    longest = sides.max(axis=1)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    height = 2.0 * area / np.maximum(longest, 1e-300)
    steps = np.maximum(np.ceil(longest / spacing).astype(int), 1)
    rows = np.maximum(np.ceil(height / spacing).astype(int), 1)
    thin = (rows + 1) * (steps + 1) < (steps + 1) * (steps + 2) // 2
    return np.where(thin, rows, 0), steps


def _point_count(meshes: Sequence[tuple[np.ndarray, np.ndarray]], spacing: float) -> int:
    """How many points :func:`_fill` puts on the meshes at spacing mm."""
    total = 0
    for vertices, corners in meshes:
        rows, steps = _grids(corners, spacing)
        total += len(vertices) + int(np.where(rows > 0, (rows + 1) * (steps + 1), (steps + 1) * (steps + 2) // 2).sum())
    return total


def _spacing_within(meshes: Sequence[tuple[np.ndarray, np.ndarray]], spacing: float, max_points: int) -> float:
    """The smallest spacing from ``spacing`` up (mm, growing by a quarter) whose fill of the
    meshes holds at most max_points points, counted before any is made."""
    while _point_count(meshes, spacing) > max_points:
        spacing *= 1.25
    return spacing


def _fill(vertices: np.ndarray, corners: np.ndarray, spacing: float) -> np.ndarray:
    """Points on a face's mesh (vertices (V, 3), triangles' corners (T, 3, 3), mm): its vertices
    and its triangles filled as :func:`_grids` says: (P, 3)."""
    if not len(corners):
        return vertices
    rows, steps = _grids(corners, spacing)
    filled = [vertices]
    for r, k in set(zip(rows.tolist(), steps.tolist())):
        chosen = corners[(rows == r) & (steps == k)]
        filled.append(_barycentric(chosen, k) if r == 0 else _rows(chosen, r, k))
    return np.concatenate(filled)


def _barycentric(corners: np.ndarray, k: int) -> np.ndarray:
    """Points of triangles (corners (T, 3, 3)) on a barycentric grid of k steps: (T * W, 3)."""
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
    keep = i + j <= k
    weights = np.stack([i[keep], j[keep], k - i[keep] - j[keep]], axis=1) / k
    return np.einsum("wc,tcd->twd", weights, corners).reshape(-1, 3)


def _rows(corners: np.ndarray, r: int, k: int) -> np.ndarray:
    """Points of triangles (corners (T, 3, 3)) on r + 1 segments parallel to each one's longest
    side, from that side (t = 0) to the opposite corner (t = 1), k steps each: (T * (r + 1) * (k + 1), 3)."""
    sides = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    first = sides.argmax(axis=1)   # side j runs from corner j - 1 to corner j
    a = corners[np.arange(len(corners)), (first - 1) % 3]
    b = corners[np.arange(len(corners)), first]
    c = corners[np.arange(len(corners)), (first + 1) % 3]
    t = np.linspace(0.0, 1.0, r + 1)[:, None, None]
    s = np.linspace(0.0, 1.0, k + 1)[None, :, None]
    points = ((1.0 - t) * (a[:, None, None] + s * (b - a)[:, None, None]) + t * c[:, None, None])
    return points.reshape(-1, 3)
