"""What a plan hands the formats and the CMM: its points as one PointSet, its probe path, and
the head orientations shared across its faces.

PartPlan.point_set() and PartPlan.probe_moves() call these; export(), QIF plans and a live CMM
take any source that has them, so the formats need not know a plan."""
from __future__ import annotations

import time
from dataclasses import asdict, replace

import numpy as np

from ..access.obstacles import Obstacles
from ..access.orientations import orientation_labels
from ..access.probe_moves import moves_through
from ..access.reach import Access, Reachability, fewest_orientations
from ..formats.exporting import measuring_groups, spacing_by_face
from ..formats.pointset import PointSet
from ..geometry.validation import InputError


def plan_point_set(plan):
    """The points of a PartPlan as one PointSet: labels '<face>_P<i>' (unique across the faces),
    the face of each point, and the plan's facts (strategy, tolerance or budget, the worst face's
    deviation, each face's edge offset and point spacing as used, the faces without points and
    why)."""
    placed = plan.placed
    if not placed:
        raise InputError("the plan has no points: " + "; ".join(f"{f.name}: {f.reason}" for f in plan.faces))
    labels = [f"{face.name}_P{i}" for face in placed for i in range(1, face.n + 1)]
    toleranced = [face for face in placed if not face.datum]
    metadata = {"source": "part plan", "strategy": plan.strategy, "mode": plan.mode, "faces": len(plan.faces),
                "points_per_face": {face.name: face.n for face in placed}, "worst_max_mm": plan.worst,
                "max_deviation_mm": {face.name: float(face.maximum) for face in toleranced},
                **spacing_by_face({face.name: face.settings for face in toleranced})}
    if plan.datums:
        metadata["datums"] = {face.datum: face.name for face in placed if face.datum}
    if plan.face_tolerances:
        metadata["tolerance_mm_by_face"] = {face.name: plan.face_tolerances[face.name] for face in toleranced}
    elif plan.tolerance is not None:
        metadata["tolerance_mm"] = plan.tolerance
    if plan.budget is not None:
        metadata["budget"] = plan.budget
    if plan.refused:
        metadata["faces_without_points"] = {face.name: face.reason for face in plan.refused}
    if plan.probe is not None:
        metadata["probe"] = asdict(plan.probe)
        metadata["points_tilted"] = sum(face.tilted for face in placed)
    axes = np.concatenate([f.axes for f in placed]) if all(f.axes is not None for f in placed) else None
    return PointSet(labels, np.concatenate([f.points for f in placed]), np.concatenate([f.normals for f in placed]),
                    np.concatenate([f.uv for f in placed]), None, metadata,
                    [face.name for face in placed for _ in range(face.n)], axes)


def plan_moves(plan, motion=None):
    """The ProbeMoves through every point of a plan made with a probe (motion: the CMM's speeds
    for the time estimate); ValueError for a plan without a probe or with points it cannot reach."""
    placed = plan.placed
    if plan.probe is None or any(face.axes is None for face in placed):
        raise InputError("a probe path needs the probe's reach on the part: plan with probe=cmmsampling.Probe(...), "
                         "or export with order='short_path'")
    unreached = [face.name for face in placed if face.unreached]
    if unreached:
        raise InputError(f"the probe cannot reach some points of {', '.join(unreached)}; export with "
                         "order='short_path', or plan again")
    point_set = plan.point_set()
    return moves_through(plan.probe, Obstacles(plan.part), point_set.points, point_set.normals, point_set.axes, motion,
                         groups=measuring_groups(point_set))


# Seconds OCC may spend judging the poses a plan-wide cover of the orientations would take.
SHARED_COVER_SECONDS = 20.0


def share_orientations(plan) -> None:
    """Re-aim a probe plan's points (every face's, the datum faces' too) so that as few of its
    indexing head's orientations as serve the whole part do: each face's run covered its own
    points (cmmsampling.access.reach.fewest_orientations); covered again together, faces that
    one orientation serves share it, and the program changes tips less often. A pose the cover
    would newly take is judged by OCC first (SHARED_COVER_SECONDS at most; one left unjudged is
    not taken). The faces' accesses are replaced where the whole plan then needs fewer
    orientations than the faces' own, else left. Nothing for a plan without a probe, an indexing
    head or two faces with points."""
    placed = [face for face in plan.placed if face.access is not None]
    if plan.probe is None or plan.probe.index_step is None or len(placed) < 2:
        return
    reachability = Reachability(plan.part, plan.probe)
    joined = Access(*(np.concatenate([getattr(face.access, name) for face in placed])
                      for name in ("reachable", "axes", "tilts", "angles", "ranks")))
    points = np.concatenate([face.points for face in placed])
    normals = np.concatenate([face.normals for face in placed])
    shared, _ = fewest_orientations(plan.probe, reachability.obstacles, points, normals, joined,
                                    reachability.judge_until(time.perf_counter() + SHARED_COVER_SECONDS))
    reached = joined.reachable
    if orientation_count(shared.axes[reached]) >= orientation_count(joined.axes[reached]):
        return
    starts = np.cumsum([0] + [face.n for face in placed])
    for face, start, end in zip(placed, starts[:-1], starts[1:]):
        face.access = replace(face.access, axes=shared.axes[start:end], tilts=shared.tilts[start:end],
                              angles=shared.angles[start:end])


def orientation_count(axes: np.ndarray) -> int:
    """The distinct head orientations of probe axes (N, 3) unit."""
    return int(orientation_labels(axes).max(initial=-1)) + 1
