"""PointSet: labelled probe points with approach vectors, the unit every exporter and reader uses."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..strategies.result import SamplingResult


@dataclass
class PointSet:
    """N probe points in one coordinate frame.

    labels: N strings (P1..PN by default); points: (N, 3) mm; normals: (N, 3) unit vectors out of the
    material (the probe travels along -normal); uv: (N, 2) face parameters or None when unknown;
    deviation: (N,) mm, the substitute's distance from the CAD face at each point, or None;
    metadata: JSON-friendly facts about where the points came from (source face, strategy, n,
    parameters, deviation figures in mm); faces: N names of the faces the points lie on (a part
    plan's points), or None; axes: (N, 3) unit, the probe's axis (ball towards head) at each point
    when the run knew the part (cmmsampling.access), else None; travel: for a probe path, N + 1
    pairs (leaving, arriving) of (M, 3) ball-centre positions in mm: the moves before each point
    (out of the previous one, then in to this one; the head turns between the two) and, last,
    out of the last point; else None.
    """

    labels: list
    points: np.ndarray
    normals: np.ndarray
    uv: np.ndarray | None = None
    deviation: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)
    faces: list | None = None
    axes: np.ndarray | None = None
    travel: list | None = None

    def __len__(self):
        return len(self.labels)

    @classmethod
    def from_result(cls, result: SamplingResult, source: str = "") -> PointSet:
        """The probe points of a SamplingResult; source names the face (e.g. 'Body:Face3')."""
        substitute = result.space.evaluate(result.poles, result.uv)
        metadata: dict[str, Any] = {"source": source, **result.settings, **result.deviation.figures()}
        return cls(
            labels=result.labels,
            points=np.array(result.points, dtype=float),
            normals=np.array(result.normals, dtype=float),
            uv=np.array(result.uv, dtype=float),
            deviation=np.linalg.norm(substitute - result.points, axis=1),
            metadata=metadata,
            axes=None if result.access is None else np.array(result.access.axes, dtype=float),
        )

    def datum_faces(self) -> dict[str, tuple[str, ...]]:
        """{label: its faces} of the datums the metadata states (``datums``: {label: a face's
        name, or a list of them for a datum of several faces}, primary first); {} for none."""
        stated = self.metadata.get("datums") or {}
        return {label: (faces,) if isinstance(faces, str) else tuple(faces) for label, faces in stated.items()}

    def datum_rows(self) -> dict[str, np.ndarray]:
        """{label: indices of its faces' points} of the datums stated (:meth:`datum_faces`) whose
        faces hold points, primary first; {} for a point set whose points name no faces."""
        if self.faces is None:
            return {}
        faces = np.array(self.faces, dtype=object)
        rows = {label: np.flatnonzero(np.isin(faces, list(names))) for label, names in self.datum_faces().items()}
        return {label: found for label, found in rows.items() if found.size}
