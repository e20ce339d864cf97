"""Measure a face over I++ DME until its profile verdict is decided: the CMM touches only until
the verdict is certain either way (the rule: :mod:`cmmsampling.inspection.decide`).

On datums (:mod:`cmmsampling.cmm.frame`) their faces are measured first and the face is judged
in their frame. The run starts from FIRST points spread over the face (where earlier parts of
the series are given, those part_error places, and the belief expects their systematic error);
on a part with a probe, only where the probe reaches, by collision-free moves. Then after each
touch weighs what the points say about the whole face (the probability that it conforms, and
that it does not) and touches next where that is least known, counting the travel; it stops
when one side holds with probability 1 - risk, or at max_points (undecided, said so). Either
verdict stands only where the inspection of the measured points agrees by ISO 14253-1's rule (a
pass within t - U, a fail beyond t + U), and points that show a zone beyond t + U stop it as a
fail: the run never stops on a verdict the measured points do not bear out, and a fail the
model expects is looked for where it is likeliest. Each point is written as it comes
(:func:`cmmsampling.cmm.client.run_session`), whatever ends the run.
"""
from __future__ import annotations

import functools
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..access.probe import Probe
from ..access.probe_moves import StepMoves
from ..access.reach import Reachability, reach
from ..fitting.series import PlaneCoordinates, SeriesModel, greedy_design
from ..formats.pointset import PointSet
from ..formats.pointfiles import read_points
from ..geometry.surface import SurfaceModel, as_face
from ..geometry.validation import InputError, check_real
from ..inspection.decide import FEWEST_POINTS, Belief, Candidates, belief, minimum_zones, next_row, spread_design
from ..inspection.judge import Progress, inspect
from ..inspection.result import Inspection
from ..inspection.series import series_model
from ..strategies.sampling import probe_edge_offset, reachability_of
from .client import Journal, MeasuredRun, link_settings, run_session
from .frame import DATUM_PREFIX, RunFrame, run_frame

# Places on the face the touches are chosen among (a raster of its parameters, those on the face);
# the points spread over it first; the coverage factor of the expanded uncertainty the belief
# takes from the probing's standard uncertainty (U = k u); the default risk of a wrong verdict.
CANDIDATES = 400
FIRST = FEWEST_POINTS
COVERAGE = 2.0
RISK = 0.05
# A run stops undecided when this many points in a row have moved neither probability by more
# than STALL_MOVE: what is left is what the points cannot settle.
STALL_POINTS = 24
STALL_MOVE = 0.02


@dataclass
class DecidedRun:
    """What :func:`measure_until_decided` measured and found: run (the MeasuredRun: the file,
    a path-like), decision ('conforms', 'does not conform', or None: undecided), p_conform and
    p_nonconform (the last belief's), points (how many were measured), stopped (why the run
    ended, in words), history ((points, p_conform, p_nonconform) after each belief); inspection
    (cmmsampling.inspect of the measured file with the tolerance and uncertainty, made on first
    use, or by judged(progress): its Monte Carlo U takes a while; None where fewer than FIRST
    points came). cmmsampling.export(run, 'results.qif') writes its inspection's results."""

    run: MeasuredRun
    decision: str | None
    p_conform: float
    p_nonconform: float
    points: int
    stopped: str
    history: list = field(default_factory=list)
    judge: Callable[[MeasuredRun, Progress | None], Inspection] | None = field(default=None, repr=False)

    @functools.cached_property
    def inspection(self) -> Inspection | None:
        """The measured file's inspection (see the class's doc)."""
        return None if self.judge is None or self.points < FIRST else self.judge(self.run, None)

    @property
    def made(self) -> bool:
        """True once the inspection is made (reading it then costs nothing)."""
        return "inspection" in self.__dict__

    def judged(self, progress: Progress | None = None) -> Inspection | None:
        """The inspection, made now where it is not yet, with progress as cmmsampling.inspect
        takes it (InspectionCancelled where it returns True; the next call starts again)."""
        if not self.made and self.judge is not None and self.points >= FIRST:
            self.__dict__["inspection"] = self.judge(self.run, progress)
        return self.inspection

    def __fspath__(self) -> str:
        return os.fspath(self.run)

    def __str__(self) -> str:
        verdict = self.decision or "undecided"
        return (f"{verdict} after {self.points} points (P(conforms) {self.p_conform:.3f}, P(does not conform) "
                f"{self.p_nonconform:.3f}): {self.stopped}. {self.run}")


def face_candidates(face: Any, count: int = CANDIDATES, edge_offset: float = 0.0) -> tuple[Candidates, np.ndarray]:
    """(Candidates, uv (M, 2)) of a face: about count places of a raster of its parameter range
    inside its edges, samples of its edges about as far apart as the raster's places (the
    tolerance holds to the edges) and, to touch next to them, each of those moved inwards to
    where the probe keeps edge_offset mm from the edges; touchable those edge_offset mm from the
    edges; InputError where fewer than 2 FIRST are."""
    from ..strategies.face_setup import setup_of

    setup = setup_of(as_face(face))
    model: SurfaceModel = setup.model
    side = int(np.ceil(np.sqrt(count)))
    raster = model.raster((side, side)).reshape(-1, 2)
    u0, u1, v0, v1 = model.bounds
    inner = (raster[:, 0] > u0) & (raster[:, 0] < u1) & (raster[:, 1] > v0) & (raster[:, 1] < v1)
    raster = raster[inner & setup.domain(0.0).on_face(raster)]
    edges = _edge_places(model, np.sqrt(model.area / count))
    reached = setup.domain(edge_offset)
    ring = _inward(edges, raster.mean(axis=0), reached.contains)
    uv = np.vstack([raster, edges, ring])
    touchable = reached.contains(uv)
    if touchable.sum() < 2 * FIRST:
        raise InputError(f"only {touchable.sum()} of {len(uv)} places on the face lie {edge_offset:g} mm from its "
                         "edges: give more candidates or a smaller edge_offset")
    return Candidates(model.points(uv), model.normals(uv), PlaneCoordinates(model)(uv), touchable), uv


def _edge_places(model: SurfaceModel, spacing: float) -> np.ndarray:
    """(K, 2) uv: samples of the face's edges about spacing mm apart along them."""
    kept = []
    for loop in model.trim_loops(0.25 * spacing):
        steps = np.linalg.norm(np.diff(model.points(loop), axis=0), axis=1)
        walked = np.floor(np.r_[0.0, np.cumsum(steps)] / spacing)
        kept.append(loop[np.r_[True, np.diff(walked) > 0]])
    return np.vstack(kept)


def measure_until_decided(source: Any, server: str, tolerance: float, uncertainty: float = 0.0,
                          out: str | os.PathLike = "measured.csv", risk: float = RISK, max_points: int | None = None,
                          *, prior: Sequence[Inspection] | SeriesModel | None = None,
                          part: Any = None, probe: Probe | None = None, datums: Sequence[Any] | None = None,
                          edge_offset: float | None = None,
                          candidates: int = CANDIDATES, tool: str | None = None,
                          progress: Callable[[str | None], bool | None] | None = None, timeout_s: float = 60.0,
                          log: str | os.PathLike | None = None, volume: Sequence[Sequence[float]] | None = None,
                          seed: int = 0) -> DecidedRun:
    """Measure a face (a Part.Face, a shape of one face, or the workbench's probe points of one
    face, whose source face it takes; on the CMM in the CAD model's coordinates) over the I++
    DME server at 'host:port' until its profile verdict to tolerance t (mm) is
    decided with probability 1 - risk, or max_points (default: every touchable place) are
    measured. uncertainty: u, mm, the probing's standard uncertainty per point (as
    cmmsampling.inspect takes it); out, tool, progress, timeout_s, log, volume as
    :func:`cmmsampling.measure` takes them; prior: earlier parts of the series (a list of their
    Inspections, or a SeriesModel, as sample's part_error takes it): the first points are those
    part_error places on the touchable places, and the belief expects the series' systematic
    error in an unknown amount; part, probe: the solid the face belongs to (a Part.Shape) and
    the Probe (default cmmsampling.Probe()): the run touches only the places the probe reaches
    and goes between them by collision-free moves (those of a plan's probe path); a probe
    points object sampled with its part and probe brings both; without a part the moves are
    straight, as :func:`cmmsampling.measure` moves for a plan made without one; datums: the
    datum reference frame (Datums, or faces: Part.Faces or names of part's faces, A, B, C in
    order, primary first): their faces are measured first (a plan's datum points, unless a
    Datum brings its points), and the face is judged in their frame, floated only in the
    motions they leave free (the profile is location and form); edge_offset: mm the points
    keep from the face's edges (None: a probe ball's radius and a margin, less on a narrow
    face, as *Sample face* starts with: a point on an edge of a misplaced part lies beyond it);
    candidates: about how many places the points are chosen among; seed: the belief's random
    samples. Returns a DecidedRun; InputError before connecting for bad arguments."""
    tolerance = check_real("tolerance", tolerance, above=0.0)
    uncertainty = check_real("uncertainty", uncertainty, minimum=0.0)
    risk = check_real("risk", risk, above=0.0)
    if risk >= 0.5:
        raise InputError(f"risk ({risk:g}) must be below 0.5: it is the chance of a wrong verdict the run accepts")
    link = link_settings(server, out, log, timeout_s, volume)
    face = measured_face(source)
    offset = probe_edge_offset(face) if edge_offset is None else check_real("edge_offset", edge_offset, 0.0)
    places, uv = face_candidates(face, int(check_real("candidates", candidates, above=0.0)), offset)
    reachability = _reachability(source, face, part, probe)
    places, axes = _reached(places, reachability)
    frame = run_frame(datums, None if reachability is None else reachability.part,
                      None if reachability is None else reachability.probe, places.points.mean(axis=0))
    if frame is not None:
        places = replace(places, motions=frame.motions(places.points, places.normals))
    if prior is None:
        first = spread_design(places, FIRST)
    else:
        places, first = _with_series(places, uv, series_model(face, prior))
    limit = _points_limit(max_points, int(places.touchable.sum()))
    planned, moves = _planned(places, frame, reachability, axes)
    rules = _Rules(face, places, first, _Limits(tolerance, uncertainty, risk, limit, seed), moves, frame)
    run = run_session(link, planned, None if moves is None else moves.leg,
                      0.0 if moves is None else moves.probe.radius, tool, progress, rules.order, chosen=True)
    return rules.result(run)


def _planned(places: Candidates, frame: RunFrame | None, reachability: Reachability | None,
             axes: np.ndarray | None) -> tuple[PointSet, StepMoves | None]:
    """(the PointSet the run may touch: the frame's datum points, then the places labelled
    C1 ...; the collision-free StepMoves among them where the probe's reachability and the
    places' axes (M, 3) are given, else None)."""
    lead = PointSet([], np.empty((0, 3)), np.empty((0, 3))) if frame is None else frame.lead
    labels = list(lead.labels) + [f"C{row + 1}" for row in range(len(places))]
    planned = PointSet(labels, np.vstack([lead.points, places.points]), np.vstack([lead.normals, places.normals]),
                       metadata={"source": "measure until decided"})
    if reachability is None or axes is None:
        return planned, None
    lead_axes = np.empty((0, 3)) if frame is None else frame.axes()
    return planned, StepMoves(reachability.probe, reachability.obstacles, planned.points, planned.normals,
                              np.vstack([lead_axes, axes]))


def _inward(uv: np.ndarray, centre: np.ndarray, inside: Callable[[np.ndarray], np.ndarray],
            steps: int = 64) -> np.ndarray:
    """(K', 2): each of uv (K, 2) moved towards centre (2,) by the first of steps fractions of
    the way (up to half) where inside(uv) holds; those it never holds for left out."""
    fractions = np.linspace(0.0, 0.5, steps + 1)[1:]
    moved = uv[:, None, :] + fractions[None, :, None] * (centre - uv)[:, None, :]     # (K, steps, 2)
    holds = inside(moved.reshape(-1, 2)).reshape(len(uv), steps)
    found = holds.any(axis=1)
    return moved[found, holds[found].argmax(axis=1)]


def measured_face(source: Any) -> Any:
    """The Part.Face a run until decided measures: source itself (a face, or a shape of one), or
    the one face of a document object whose Proxy has planned(obj) (the workbench's probe
    points); InputError for a part plan of several faces."""
    method = getattr(getattr(source, "Proxy", None), "planned", None)
    if not callable(method):
        return as_face(source)
    faces = method(source).faces
    if len(faces) != 1:
        raise InputError(f"{source.Label} holds the points of {len(faces)} faces: measuring until decided judges one "
                         "face; select one face's probe points")
    return faces[0]


def _reachability(source: Any, face: Any, part: Any, probe: Probe | None) -> Reachability | None:
    """The probe's Reachability on the part (None: no part, straight moves): part and probe as
    given, else those of a probe points object sampled with its part and probe."""
    proxy: Any = getattr(source, "Proxy", None)
    sampled_with_part = callable(getattr(proxy, "follows_probe", None)) and proxy.follows_probe(source)
    if part is None and probe is None and sampled_with_part:
        part, probe = source.Source[0].Shape, proxy.path_probe(source)
    return reachability_of(part, probe, face)


def _reached(places: Candidates, reachability: Reachability | None) -> tuple[Candidates, np.ndarray | None]:
    """(places, the probe's axis at each (M, 3), NaN where it reaches none): without a
    Reachability, as they are and None; with one, touchable only where the probe reaches."""
    if reachability is None:
        return places, None
    rows = np.flatnonzero(places.touchable)
    access = reach(reachability.probe, reachability.obstacles, places.points[rows], places.normals[rows])
    if not access.reachable.any():
        raise InputError("the probe reaches none of the face's places on this part: check the probe's stylus "
                         "length and tilt (probe=), or the part (part=)")
    axes = np.full((len(places), 3), np.nan)
    axes[rows] = access.axes
    return replace(places, touchable=np.isfinite(axes).all(axis=1)), axes


def _with_series(places: Candidates, uv: np.ndarray, series: SeriesModel) -> tuple[Candidates, np.ndarray]:
    """(places with the series' systematic error as their trend, the FIRST touchable rows that
    leave the next part's error least known over every place: part_error's greedy design)."""
    touchable = np.flatnonzero(places.touchable)
    chosen, _ = greedy_design(series, uv[touchable], FIRST, judged=uv)
    return replace(places, trend=series.systematic(uv)[:, None]), touchable[chosen]


def _points_limit(max_points: int | None, count: int) -> int:
    """The most points a run measures: max_points (FIRST at least, at most the candidates'
    count), or every candidate."""
    if max_points is None:
        return count
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < FIRST:
        raise InputError(f"max_points ({max_points!r}) must be a whole number of at least {FIRST}, the points spread "
                         "over the face first, or None for no limit")
    return min(int(max_points), count)


@dataclass(frozen=True)
class _Limits:
    """What a run until decided judges by: tolerance t and u (mm), the risk of a wrong verdict,
    the most points it measures, the belief's seed."""

    tolerance: float
    uncertainty: float
    risk: float
    limit: int
    seed: int


class _Rules:
    """The run's choice of points and its stop (see the module's doc): order(journal) yields
    the rows to touch (the frame's datum points first, then the face's places: planned rows,
    a place's row after the datum points); result(run) the DecidedRun."""

    def __init__(self, face: Any, places: Candidates, first: np.ndarray, limits: _Limits,
                 moves: StepMoves | None = None, frame: RunFrame | None = None) -> None:
        self.face, self.places, self.first, self.moves, self.frame = face, places, first, moves, frame
        self.limits = limits
        self.lead = 0 if frame is None else len(frame.lead)
        self.transform: np.ndarray | None = None
        self.rows: list[int] = []
        self.found: Belief | None = None
        self.decision: str | None = None
        self.history: list[tuple[int, float, float]] = []
        self.stopped = "the run ended before the first points were measured"

    def order(self, journal: Journal) -> Iterator[tuple[int, str]]:
        """The rows to touch: the datum points, the FIRST places of the first design, then one
        place at a time where the belief is least sure, until decided (confirmed by the
        inspection) or at the limit."""
        for row in range(self.lead):
            yield row, f"datum point {row + 1} of {self.lead}"
        limit = self.limits.limit
        for row in self.first:
            self.rows.append(int(row))
            yield self.lead + int(row), f"point {len(self.rows)} of at most {limit} (the first design)"
        while True:
            found, decided = self._decided(journal)
            if decided is not None:
                self.stopped = decided
                return
            if len(self.rows) >= limit:
                self.stopped = f"undecided at the limit of {limit} points"
                return
            if self._stalled():
                self.stopped = (f"undecided: {STALL_POINTS} more points left P(conforms) at {found.p_conform:.2f} "
                                "(within a few hundredths); what would decide it, a profile within U of t or an "
                                "error where the probe cannot touch, the points cannot settle")
                return
            row = next_row(self.places, found, np.array(self.rows), self.rows[-1],
                           found.decision(self.limits.risk) == "does not conform",
                           None if self.moves is None else self._travel)
            self.rows.append(row)
            yield self.lead + row, (f"point {len(self.rows)} of at most {limit}: P(conforms) {found.p_conform:.3f}, "
                                    f"P(does not conform) {found.p_nonconform:.3f}")

    def _stalled(self) -> bool:
        """True when the last STALL_POINTS points moved neither probability by more than
        STALL_MOVE."""
        if len(self.history) <= STALL_POINTS:
            return False
        recent = np.array(self.history[-STALL_POINTS - 1:])[:, 1:]
        return bool((np.ptp(recent, axis=0) <= STALL_MOVE).all())

    def _travel(self, last: int) -> np.ndarray:
        """(M,) mm: the probe's travel along its moves from place last to every place (inf where
        it cannot go)."""
        assert self.moves is not None   # only asked for with the part's moves
        return self.moves.lengths(self.lead + last, self.lead + np.arange(len(self.places)))

    def _decided(self, journal: Journal) -> tuple[Belief, str | None]:
        """(the Belief of the points measured, why the run stops now or None): the belief decides,
        and the profile cmmsampling.inspect finds for them (to the bounded face, minimum zone; in
        the datum frame where there is one) agrees by ISO 14253-1's rule with U = COVERAGE u (the
        Monte Carlo U comes with the run's final inspection): within t - U for 'conforms', beyond
        t + U for 'does not conform'. Points that show a zone beyond t + U decide 'does not
        conform' whatever the belief. A belief of 'does not conform' the points do not show yet
        sends the next touch where the excess is likeliest."""
        limits = self.limits
        rows, d = self._deviations(journal)
        guard = COVERAGE * limits.uncertainty
        found = belief(self.places, rows, d, limits.tolerance, guard, seed=limits.seed)
        self.found = found
        self.history.append((len(rows), found.p_conform, found.p_nonconform))
        decision = found.decision(limits.risk)
        seen = float(minimum_zones(d[None], self.places.rigid[rows])[0][0])
        if decision is None and seen - guard <= limits.tolerance:
            within = 1.0 - found.p_conform - found.p_nonconform
            if within >= 1.0 - limits.risk:
                return found, (f"undecided: the profile lies within U of t with probability {within:.3f} >= "
                               f"{1 - limits.risk:g}, where ISO 14253-1 decides neither way")
            return found, None
        profile = self._judge(journal.measured()).profile
        if profile - guard > limits.tolerance:
            self.decision = "does not conform"
            return found, (f"decided: the measured points show it (profile {profile:.4f} mm beyond t + U), "
                           f"P(does not conform) {found.p_nonconform:.3f}")
        if decision == "conforms" and profile + guard <= limits.tolerance:
            self.decision = decision
            return found, (f"decided: P(conforms) {found.p_conform:.3f} >= {1 - limits.risk:g}, the measured points "
                           f"agree (profile {profile:.4f} mm)")
        return found, None

    def _judge(self, measured: PointSet | os.PathLike, **options: Any) -> Inspection:
        """cmmsampling.inspect of measured points (a PointSet of the run's, or its file; datum
        points included) on the face with the run's tolerance, in the frame's datums where there
        is one (a file's name kept as the inspection's measured file); options: inspect's others."""
        if self.frame is None:
            return inspect(self.face, measured, tolerance=self.limits.tolerance, **options)
        read = measured if isinstance(measured, PointSet) else read_points(measured)
        toleranced, datums = self.frame.measured(read)
        found = inspect(self.face, toleranced, tolerance=self.limits.tolerance, datums=datums, **options)
        if not isinstance(measured, PointSet):
            found.measured_file = os.fspath(measured)
        return found

    def _deviations(self, journal: Journal) -> tuple[np.ndarray, np.ndarray]:
        """(places measured (n,), their deviations (n,) mm along the nominal normals; in the
        datum frame where there is one: the contacts moved by the datums' association)."""
        labels = journal.planned.labels
        rows = np.array([row for row in self.rows if labels[self.lead + row] in journal.touched])
        contacts = np.array([journal.touched[labels[self.lead + row]][0] for row in rows])
        if self.frame is not None:
            if self.transform is None:
                self.transform = self._judge(journal.measured(), alignment="none").transform
            contacts = contacts @ self.transform[:3, :3].T + self.transform[:3, 3]
        offsets = contacts - self.places.points[rows]
        return rows, np.einsum("ij,ij->i", offsets, self.places.normals[rows])

    def _inspection(self, measured: os.PathLike, progress: Progress | None) -> Inspection:
        """cmmsampling.inspect of the measured file on the face with the run's tolerance and u
        (its expanded uncertainty and decision where u is given; in the datum frame where there is
        one), progress as it takes it."""
        return self._judge(measured, uncertainty=self.limits.uncertainty or None,
                           seed=self.limits.seed, progress=progress)

    def result(self, run: MeasuredRun) -> DecidedRun:
        """The DecidedRun of the run: the decision it stopped on (None where it did not)."""
        p_conform = self.found.p_conform if self.found is not None else float("nan")
        p_nonconform = self.found.p_nonconform if self.found is not None else float("nan")
        points = sum(not label.startswith(DATUM_PREFIX) for label in run.labels)
        return DecidedRun(run, self.decision, p_conform, p_nonconform, points, self.stopped, list(self.history),
                          self._inspection)
