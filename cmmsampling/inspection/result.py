"""An inspection's results: the Inspection (measured points judged against the CAD model, what
cmmsampling.inspect returns) and the words and bands its verdict is shown in.

How the points are paired, aligned and judged: cmmsampling.inspection.judge.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..fitting.deviation import NUMERICAL_ZERO_MM
from ..fitting.occ_surface import substitute_surface
from ..geometry.freecad_env import import_part
from ..geometry.validation import InputError
from .align import PROFILE_KINDS, Alignment
from .series import deviation_map, face_rows
from .uncertainty import NO_UNCERTAINTY, ProfileUncertainty, decide

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from ..fitting.series import SeriesModel
else:
    Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)

# A point inside the zone is "near" its limit beyond this fraction of the half zone t / 2.
NEAR_FRACTION = 0.8
# A point within this much (mm) of the zone's limit is on it: finer than any CMM resolves, and
# than the rounding of the closest points (a point placed on the limit lands 1e-14 mm either side).
LIMIT_SLACK_MM = NUMERICAL_ZERO_MM
BANDS = ("out below", "near below", "in", "near above", "out above")

@dataclass
class Inspection:
    """Measured points judged against the CAD model.

    labels: N; nominal: (N, 3) mm, the planned points (NaN where none was planned, a bare face);
    measured: (N, 3) mm, as read (contact points); points: (N, 3) mm, aligned to the CAD model;
    deviations: (N,) mm, signed (+ out of the material); transform: (4, 4) measured -> CAD;
    alignment: the Alignment; tolerance: the profile tolerance t (mm) or None; faces: N names of
    the faces the points were judged on; notes: what the pairing found (points planned but not
    measured); zone_offset: o, mm, the zone's centre from the nominal (+ out of the material);
    face_forms: {face name: its form profile, mm, each face aligned alone (None, with the reason
    in notes, where its points cannot be), for a part of several faces};
    for a SamplingResult's points (the paper's step), substitute_poles: (n_u, n_v, 3) mm, the
    substitute fitted to the aligned measured points at their planned (u, v), and
    substitute_deviation: its DeviationStats against the CAD face (the deviation map); else None;
    measured_file: the file read ('' for a PointSet); normals: (N, 3) unit, the face's outward
    normal at each aligned point's closest point, or for a point beyond an edge the direction from
    its foot on the edge (the point's foot is points - deviations * normals); beyond_edges: the
    labels of the points beyond an edge of their face, judged by their distance to the edge;
    datums: a DatumFit per datum of the frame the points were judged in (cmmsampling.inspection.
    datums; empty: the form profile, floated); uncertainty: the ProfileUncertainty of the
    profile (cmmsampling.inspection.uncertainty) or None where none was given; location_free:
    the datums fixed the zone's orientation only (an orientation tolerance).
    """

    labels: list
    nominal: np.ndarray
    measured: np.ndarray
    points: np.ndarray
    deviations: np.ndarray
    transform: np.ndarray
    alignment: Alignment
    tolerance: float | None = None
    faces: list | None = None
    notes: list = field(default_factory=list)
    substitute_poles: np.ndarray | None = None
    substitute_deviation: object = None
    space: Any = None
    measured_file: str = ""
    zone_offset: float = 0.0
    face_forms: dict = field(default_factory=dict)
    normals: np.ndarray | None = None
    datums: list = field(default_factory=list)
    uncertainty: ProfileUncertainty | None = None
    planned_faces: dict = field(default_factory=dict)
    beyond_edges: list = field(default_factory=list)
    location_free: bool = False

    def deviation_map(self, uv: np.ndarray, prior: Sequence[Inspection] | SeriesModel | None = None,
                      face: str | None = None) -> np.ndarray:
        """The measured part's signed deviation from the CAD face at uv (M, 2) in the face's
        parameter range: (M,) mm, + out of the material, in this inspection's alignment.

        From this inspection's points on the face alone (prior None: kriging, a Gaussian process
        with a Matern 5/2 covariance fitted by maximum likelihood) or also from the earlier parts
        of the series (prior: their Inspections, or cmmsampling.series_model(face, them): the
        posterior mean given the series' systematic error and scatter; see
        cmmsampling.fitting.series; a list is fitted anew at each call: to map many parts, build
        the model once with series_model and pass it). face: the face's name where the inspection
        covers several.
        """
        rows, name = face_rows(self, face)
        if name not in self.planned_faces:
            raise InputError(f"this inspection does not hold the CAD face {name!r} (one read back from a file or "
                             "document): inspect the measured points again with their plan")
        return deviation_map(self, self.planned_faces[name], uv, prior, name if face is not None else None)

    @property
    def feet(self) -> np.ndarray:
        """(N, 3) mm: the closest point of each aligned point on its face."""
        return self.points - self.deviations[:, None] * self.normals

    @property
    def substitute(self) -> Part.BSplineSurface | None:
        """The substitute rebuilt from the measured points as a Part.BSplineSurface, or None."""
        return None if self.substitute_poles is None else substitute_surface(self.space, self.substitute_poles)

    @property
    def placement(self) -> FreeCAD.Placement:
        """The alignment as a FreeCAD.Placement (measured -> CAD)."""
        return FreeCAD.Placement(FreeCAD.Matrix(*self.transform.ravel().tolist()))

    def _form_text(self, name: str) -> str:
        """'; form 0.0101 mm aligned alone' for a face of several with its own form profile."""
        form = self.face_forms.get(name)
        return "" if form is None else f" with the part's alignment; form {form:.4f} mm aligned alone"

    @property
    def free_motions(self) -> tuple[str, ...]:
        """The motions the points do not hold (cmmsampling.inspection.align.held_motions), kept
        where the labelled nominals put them: e.g. ('rz', 'x', 'y') for a plane z = const."""
        return self.alignment.free_motions

    @property
    def profile(self) -> float:
        """The form profile, mm: the width of the zone centred on the nominal (offset by
        zone_offset) that holds every point, 2 max |d - o|."""
        return 2.0 * float(np.abs(self.deviations - self.zone_offset).max())

    @property
    def face_profiles(self) -> dict[str, float]:
        """{face name: its profile, mm}, the faces in the order of their first point."""
        names = list(dict.fromkeys(cast(list, self.faces)))
        owner = np.array([names.index(name) for name in cast(list, self.faces)])
        off = np.abs(self.deviations - self.zone_offset)
        return {name: 2.0 * float(off[owner == index].max()) for index, name in enumerate(names)}

    def face_passed(self, profile: float) -> bool | None:
        """Whether a profile (mm) is within the tolerance (None without one)."""
        return None if self.tolerance is None else profile <= self.tolerance + 2 * LIMIT_SLACK_MM

    @property
    def within(self) -> np.ndarray:
        """(N,) bool: the point lies inside the tolerance zone (all True without a tolerance)."""
        if self.tolerance is None:
            return np.ones(len(self.labels), dtype=bool)
        return np.abs(self.deviations - self.zone_offset) <= self.tolerance / 2.0 + LIMIT_SLACK_MM

    @property
    def bands(self) -> np.ndarray:
        """(N,) int in -2 .. 2, the point's band in the tolerance zone (BANDS[band + 2]): 0 in,
        +-1 near the limit (|d| beyond NEAR_FRACTION of t / 2), +-2 out of the zone, + above the
        nominal (out of the material); all 0 without a tolerance."""
        if self.tolerance is None:
            return np.zeros(len(self.labels), dtype=int)
        return tolerance_bands(self.deviations, self.tolerance, self.zone_offset)

    @property
    def passed(self) -> bool | None:
        """The profile is within the tolerance (None without one)."""
        return self.face_passed(self.profile)

    @property
    def profile_uncertainty(self) -> float | None:
        """U, mm, the profile's expanded uncertainty (k = 2), or None where none was given."""
        return None if self.uncertainty is None else self.uncertainty.expanded

    @property
    def decision(self) -> str | None:
        """ISO 14253-1's decision on the whole profile: 'conforms', 'does not conform' or
        'undecided' (cmmsampling.inspection.uncertainty.DECISIONS); None without a tolerance
        or an uncertainty."""
        return self.face_decision(None)

    def face_decision(self, name: str | None) -> str | None:
        """The decision on face ``name``'s profile (None: the whole profile), as :attr:`decision`."""
        if self.tolerance is None or self.uncertainty is None:
            return None
        profile = self.profile if name is None else self.face_profiles[name]
        expanded = self.uncertainty.expanded if name is None else self.uncertainty.faces[name]
        return decide(profile, expanded, self.tolerance + 2 * LIMIT_SLACK_MM)

    @property
    def profile_kind(self) -> str:
        """What the profile is, in the summary's words: floated form, or relative to datums."""
        if not self.datums:
            return PROFILE_KINDS[self.alignment.method]
        frame = "|".join(datum.label for datum in self.datums)
        if self.location_free:
            return f"oriented by datums {frame}, location free: orientation and form, ISO 1101"
        return f"relative to datums {frame}: location and form, ISO 1101"

    def decision_text(self) -> str:
        """The verdict's uncertainty in a line: 'ISO 14253-1: undecided: profile 0.0480 mm, U =
        0.0040 mm (k = 2 ...)', or that none was given."""
        if self.uncertainty is None:
            return NO_UNCERTAINTY
        if self.tolerance is None:
            return f"profile {self.profile:.4f} mm, {self.uncertainty.text()}"
        return (f"ISO 14253-1: {self.decision} (profile {self.profile:.4f} mm, tolerance {self.tolerance:g} mm, "
                f"guard band U): {self.uncertainty.text()}")

    def summary(self) -> str:
        """The inspection in a few lines: points, alignment, profile, verdict."""
        zone = f" (zone offset {self.zone_offset:+g} mm)" if self.zone_offset else ""
        lines = [f"{len(self.labels)} points, {self._alignment_words()}, "
                 f"points moved up to {self.alignment.moved_mm:.4g} mm)",
                 "motions the points do not hold (kept where their labels put them): "
                 + (", ".join(self.free_motions) if self.free_motions else "none")]
        lines = lines if self.alignment.method != "none" or self.datums else lines[:1]
        if self.datums:
            lines.insert(1, "datums " + " | ".join(datum.text() for datum in self.datums))
        lines.append(f"deviation {self.deviations.min():+.4f} .. {self.deviations.max():+.4f} mm, "
                     f"profile {self.profile:.4f} mm ({self.profile_kind}){zone}")
        if self.tolerance is not None:
            outside = int((~self.within).sum())
            lines.append(f"tolerance {self.tolerance:g} mm: {verdict_text(self.passed)}"
                         f"{f', {outside} points outside the zone' if outside else ''}")
        lines.append(self.decision_text())
        faces = self.face_profiles
        if len(faces) > 1:
            lines += [f"{name}: profile {value:.4f} mm" + self._face_verdict(name, value) + self._form_text(name)
                      for name, value in faces.items()]
        notes = self.notes + ([] if self.uncertainty is None else self.uncertainty.notes) + self._edge_notes()
        return "\n".join(lines + [f"note: {note}" for note in notes])

    def _edge_notes(self) -> list[str]:
        """The note naming the points beyond an edge of their face (none where there are none)."""
        count = len(self.beyond_edges)
        if not count:
            return []
        names = ", ".join(self.beyond_edges[:8]) + (" ..." if count > 8 else "")
        return [f"{count} point{'s lie' if count > 1 else ' lies'} beyond an edge of {'their' if count > 1 else 'its'} "
                f"face, judged by the distance to the edge: {names}"]

    def _alignment_words(self) -> str:
        """'alignment min_max (7 steps' or 'aligned on datums A|B|C (then min_max, 3 steps in the
        motions they leave free' (the summary's first line closes the bracket)."""
        steps = f"{self.alignment.iterations} steps{' (capped: not settled)' if self.alignment.capped else ''}"
        if not self.datums:
            return f"alignment {self.alignment.method} ({steps}"
        frame = "|".join(datum.label for datum in self.datums)
        return f"aligned on datums {frame} (then {self.alignment.method}, {steps} in the motions they leave free"

    def _face_verdict(self, name: str, profile: float) -> str:
        """', PASS' (and ', U 0.0041 mm: conforms' with an uncertainty) for a face's profile."""
        if self.tolerance is None:
            return "" if self.uncertainty is None else f", U {self.uncertainty.faces[name]:.4f} mm"
        text = f", {verdict_text(self.face_passed(profile))}"
        if self.uncertainty is not None:
            text += f", U {self.uncertainty.faces[name]:.4f} mm: {self.face_decision(name)}"
        return text


def verdict_text(passed: bool | None) -> str:
    """'PASS' or 'FAIL' for a verdict (True or False)."""
    return "PASS" if passed else "FAIL"


def verdict_words(inspection: Inspection) -> str:
    """The verdict after a profile, the decision first where an uncertainty gives one:
    ', tolerance 0.05 mm: undecided by ISO 14253-1 (U 0.0061 mm, k = 2; the profile alone: PASS)';
    else ', tolerance 0.05 mm: PASS', ', U 0.0061 mm (k = 2)' without a tolerance, or ''."""
    spread = "" if inspection.uncertainty is None else f"U {inspection.profile_uncertainty:.4f} mm"
    if inspection.passed is None:
        return f", {spread} (k = 2)" if spread else ""
    tolerance = f", tolerance {inspection.tolerance:g} mm: "
    if inspection.decision is None:
        return f"{tolerance}{verdict_text(inspection.passed)}"
    return (f"{tolerance}{inspection.decision} by ISO 14253-1 ({spread}, k = 2; the profile alone: "
            f"{verdict_text(inspection.passed)})")


def verdict_word(inspection: Inspection) -> str:
    """The one word (or words) a verdict shows first: ISO 14253-1's decision ('conforms', 'does not
    conform', 'undecided') where an uncertainty gives one, else 'PASS' or 'FAIL', or 'no tolerance'."""
    if inspection.passed is None:
        return "no tolerance"
    return inspection.decision if inspection.decision is not None else verdict_text(inspection.passed)


def tolerance_bands(deviations: np.ndarray, tolerance: float, offset: float = 0.0) -> np.ndarray:
    """(N,) int in -2 .. 2 for deviations (N,) mm against a profile tolerance t mm whose zone is
    centred at offset o mm: 0 where |d - o| <= NEAR_FRACTION t / 2, +-1 up to t / 2, +-2 beyond,
    signed as d - o (a point within LIMIT_SLACK_MM of the limit is on it)."""
    half, away = tolerance / 2.0, np.asarray(deviations) - offset
    size = np.where(np.abs(away) > half + LIMIT_SLACK_MM, 2, np.where(np.abs(away) > NEAR_FRACTION * half, 1, 0))
    return (np.sign(away) * size).astype(int)


def band_limits(tolerance: float, offset: float = 0.0) -> tuple[float, float, float, float]:
    """The deviations (mm) where the bands meet for a tolerance t mm centred at offset o mm:
    (o - t/2, o - 0.8 t/2, o + 0.8 t/2, o + t/2)."""
    half = tolerance / 2.0
    return (offset - half, offset - NEAR_FRACTION * half, offset + NEAR_FRACTION * half, offset + half)
