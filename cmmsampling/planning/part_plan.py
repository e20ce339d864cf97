"""A whole part: points on many faces, to a tolerance or within a total budget, run in parallel.

:func:`plan` takes a shape (all its faces, or those numbered in ``faces``) or a list of faces and
returns a :class:`PartPlan`: a :class:`FacePlan` per face with its points, its deviation and the
local bound, or the reason the face holds no points (too narrow for the edge offset, no usable
area), never silently dropped.

- With a tolerance, each face gets its own fewest N (:func:`points_needed`); faces run in
  parallel (:mod:`cmmsampling.runtime.jobs`). A face that is a rigid copy of another
  (:mod:`cmmsampling.geometry.congruence`: a pattern's instances, a fan's blades) is not searched
  again: once its original is done, the original's points are moved onto it and judged there;
  where its domain (edge offset, trim, probe reach) or that judgement differs from the
  original's, it runs its own search.
- With a total budget, every face starts at the first pole step (16 points) and the face with
  the largest deviation takes its next step while the budget lasts (greedy on the faces'
  deviation curves, run one step at a time). For curves that fall with N this is the best
  allocation for the worst face: any allocation with a lower maximum must give that face its next
  step too. Points the worst face cannot use (its next step does not fit) are left unspent.
"""
from __future__ import annotations

import functools
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from ..access.probe import Probe, check_probe
from ..access.reach import Access, Reachability
from ..fitting.substitute import DEFAULT_DEGREE
from ..geometry.congruence import FacePrint, face_copies, raster, rigid_copy
from ..geometry.freecad_env import import_part
from ..geometry.surface import as_face
from ..geometry.validation import InputError, InputTypeError, check_int, check_pair, check_real
from ..runtime import jobs as face_runs
from ..runtime.packages import require
from ..runtime.threads import blas_threads
from ..strategies.estimates import duration_text, time_left_text
from ..strategies.face_setup import reused, setup_of
from ..strategies.sampling import BEST_STRATEGY, STRATEGIES, check_arguments, evaluate, probe_edge_offset, sample
from .plan_points import plan_moves, plan_point_set, share_orientations
from .points_needed import (DEFAULT_MAX_POINTS, RISE_FACTOR, check_max_points, fewest_points, points_needed,
                            step_counts)

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from ..access.probe import Motion
    from ..access.probe_moves import ProbeMoves
    from ..formats.pointset import PointSet
    from ..strategies.result import SamplingResult
else:
    Part = import_part()
FIT_KEYS = ("fit_degree", "fit_poles", "smoothing", "grid")
CANCELLED_REASON = "cancelled before this face was planned"
# A copy takes its original's points where its judged maximum deviation agrees with the
# original's within this share and COPY_AGREEMENT_MM: the same problem gives the same figure
# (a face the substitute fits exactly judges about 1e-8 mm, rounding's).
COPY_AGREEMENT = 1e-6
COPY_AGREEMENT_MM = 1e-6
# Cells per direction of the rasters on which a copy's domain and its original's are compared,
# and the share of them that may differ: cells the trim passes through fall either way by
# rounding (1 or 2 of 4096 on the Ventilator's copies).
DOMAIN_CELLS = 64
DOMAIN_MISMATCH = 1e-3
# Where a group of congruent faces' search misses the tolerance, this many of its copies search
# again, one after another, before the rest take the best of the searches' points: a search
# with a time limit (optimal) is a draw, and on the Ventilator's 13 copies of one 1 mm^2 face
# about half the searches of their own met 0.05 mm.
RETRIES = 1
# Seconds a plan's runs of a strategy with a time limit (optimal) take at most unless told
# otherwise: a face's search runs it at several N, so the plan's time stays bounded (the Plan part
# panel starts with the same).
PLAN_TIME_LIMIT_S = 10.0
# A toleranced face is called met only where the probe reaches at least this share of its area:
# its substitute is judged over the reached part alone, and a verdict on less than half of a face
# would speak for the rest, which no point touched. Below it the face is flagged instead.
REACHED_SHARE_MIN = 0.5
# The strategy a datum face's FacePlan names: its points are spread to hold the frame, not sampled.
DATUM_STRATEGY = "datum"


@dataclass
class FaceJob:
    """One face's share of a plan, as plain data: name ('Face3'), the face as BREP text, mode
    ('tolerance' or 'points'), tolerance (mm) or n, strategy, n_max and the keyword arguments
    of sample(); part_brep: the whole part as BREP text when the probe's reach is judged (with
    probe, a cmmsampling.Probe), else ''."""

    name: str
    brep: str
    mode: str
    strategy: str
    tolerance: float | None = None
    n: int = 0
    n_max: int = DEFAULT_MAX_POINTS
    arguments: dict = field(default_factory=dict)
    part_brep: str = ""
    probe: object = None
    original: object = None
    original_brep: str = ""


@dataclass
class FacePlan:
    """One face of a plan.

    name: 'Face3'; area: mm^2; n: points (0 when the face holds none); uv (n, 2), points (n, 3)
    mm, normals (n, 3) unit, out of the material; maximum: the substitute's maximum deviation,
    mm; bound: the local bound about it, mm (the least maximum that reshaping it could reach);
    met: the tolerance is met (None without a tolerance); edge_offset: mm; settings: the run's
    parameters; tried: the N a tolerance search ran (cmmsampling.planning.points_needed.Tried);
    reason: why the face holds no points, or why no N met the tolerance; seconds: time taken;
    access: how the probe reaches each point and where on the face it reaches none
    (cmmsampling.access.reach.Access) when the plan judged the probe's reach, else None;
    copy_of: where the face is a rigid copy of another whose points it took, that face's name
    and the motion, e.g. 'Face55 (turned 30 deg, moved 41.2 mm)' ('' for a face searched itself);
    datum: the datum label of a datum face ('A'), whose points are spread to hold the frame
    (cmmsampling.planning.datum_points), not sampled for its form ('' for a toleranced face).
    """

    name: str
    area: float
    n: int = 0
    uv: np.ndarray | None = None
    points: np.ndarray | None = None
    normals: np.ndarray | None = None
    maximum: float = float("nan")
    bound: float = float("nan")
    met: bool | None = None
    edge_offset: float = 0.0
    strategy: str = ""
    settings: dict = field(default_factory=dict)
    tried: list = field(default_factory=list)
    reason: str = ""
    seconds: float = 0.0
    access: Access | None = None
    copy_of: str = ""
    datum: str = ""

    @property
    def axes(self):
        """(n, 3) the probe's axis at each point (NaN where OCC found it blocked), or None when the
        plan did not judge the probe's reach."""
        return None if self.access is None else self.access.axes

    @property
    def tilted(self):
        """Points reached with the stylus off their normal."""
        return 0 if self.access is None else int(self.access.tilted.sum())

    @property
    def unreached(self):
        """Points OCC found the probe cannot reach."""
        return 0 if self.access is None else int((~self.access.reachable).sum())

    @property
    def unreached_area(self):
        """mm^2 of the face the probe cannot reach (no point was placed there)."""
        return 0.0 if self.access is None else self.access.unreached_area

    @property
    def placed(self):
        """True when the face holds points."""
        return self.n > 0

    @property
    def reached_share(self):
        """The share of the face's area the probe reaches, 0..1 (1 where the plan did not judge
        the probe's reach): the part its maximum deviation is judged over."""
        if self.access is None or self.area <= 0:
            return 1.0
        return min(1.0, max(0.0, 1.0 - self.unreached_area / self.area))

    @property
    def flagged(self):
        """True for a toleranced face with points whose reached share is below
        REACHED_SHARE_MIN: it is not called met, whatever its maximum over that share."""
        return self.placed and not self.datum and self.reached_share < REACHED_SHARE_MIN

    @property
    def met_text(self):
        """'yes' or 'no' for the tolerance met, 'flagged' where too little of the face is reached
        to say (:attr:`flagged`), '' without a tolerance."""
        if self.met is None:
            return ""
        return "flagged" if self.flagged else ("yes" if self.met else "no")

    @property
    def reach_text(self):
        """Where the probe reaches part of the face: the area out of reach, the share reached and
        for a flagged face that it is not called met, e.g. '44.7 mm^2 out of the probe's reach:
        it reaches 10 % of the face, not called met (a verdict needs 50 %)'; '' where it reaches
        all of it."""
        if self.unreached_area <= 0:
            return ""
        text = (f"{self.unreached_area:.4g} mm^2 out of the probe's reach: it reaches "
                f"{percent(self.reached_share)} of the face")
        return text + (f", not called met (a verdict needs {percent(REACHED_SHARE_MIN)})" if self.flagged else "")

    @property
    def notes(self):
        """The datum a datum face's points hold, why the face holds no points or misses the
        tolerance, how many points the probe
        reaches tilted or not at all, and where more points gave a larger maximum: one text (''
        when there is nothing to say)."""
        parts = [f"datum {self.datum}: points spread to fix {self.settings['motions']} motions"] if self.datum else []
        parts += [self.reason] if self.reason else []
        parts += [f"{self.tilted} point{'s' if self.tilted > 1 else ''} tilted"] if self.tilted else []
        parts += [f"{self.unreached} point{'s' if self.unreached > 1 else ''} the probe cannot reach"] if self.unreached else []
        parts += [self.reach_text] if self.reach_text else []
        rise = larger_with_more(self.tried)
        parts += [rise] if rise else []
        parts += [f"a rigid copy of {self.copy_of}: its points and search, judged on this face"] if self.copy_of else []
        return "; ".join(parts)

    @property
    def line(self):
        """One line on the face's outcome, e.g. 'Face3: 46 points, max 0.0312 mm, tolerance met'
        or 'Face7: no points (the face is narrower than ...)'."""
        if not self.placed:
            return f"{self.name}: no points ({self.reason})"
        if self.datum:
            return f"{self.name}: datum {self.datum}, {self.n} points spread to fix {self.settings['motions']} motions"
        met = {None: "", True: ", tolerance met", False: ", tolerance not met"}[self.met]
        over = f" over the {percent(self.reached_share)} of the face the probe reaches" if self.unreached_area else ""
        if self.flagged and self.met is not None:
            met = f", flagged: not called met, a verdict needs {percent(REACHED_SHARE_MIN)} of the face"
        reach = f", {self.tilted} tilted" if self.tilted else ""
        reach += f", {self.unreached} unreachable" if self.unreached else ""
        return f"{self.name}: {self.n} points, max {self.maximum:.4f} mm{over}{met}{reach}"


@dataclass
class PartPlan:
    """A plan of a part: faces (FacePlan, in the order given), the mode ('tolerance' or
    'points'), tolerance (mm) or budget (points), the strategy and the seconds it took;
    cancelled when stopped early (faces not run have no points and say so); part: the shape
    planned and probe: the Probe whose reach was judged (None when not); notes: sentences on how
    the faces ran where that differs from what was asked (fewer processes, failed workers);
    datums: the datum faces' names, primary first (datums A, B, C ...), whose faces come first
    in ``faces`` and are measured first ([] for none); face_tolerances: {name: mm} where each
    face had its own tolerance (``tolerance`` is then the smallest; {} for one tolerance)."""

    faces: list
    mode: str
    strategy: str
    tolerance: float | None = None
    budget: int | None = None
    seconds: float = 0.0
    cancelled: bool = False
    shapes: dict = field(default_factory=dict, repr=False)
    part: object = field(default=None, repr=False)
    probe: object = None
    notes: list = field(default_factory=list)
    datums: list = field(default_factory=list)
    face_tolerances: dict = field(default_factory=dict)
    _results: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _moves: ProbeMoves | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def placed(self) -> list[FacePlan]:
        """The faces that hold points."""
        return [face for face in self.faces if face.placed]

    @property
    def refused(self) -> list[FacePlan]:
        """The faces that hold no points, each with its reason."""
        return [face for face in self.faces if not face.placed]

    @property
    def n_total(self) -> int:
        """Points over all faces."""
        return sum(face.n for face in self.faces)

    @property
    def area(self) -> float:
        """Area of all the faces, mm^2."""
        return sum(face.area for face in self.faces)

    @property
    def toleranced(self) -> list[FacePlan]:
        """The faces with points that are no datum faces."""
        return [face for face in self.placed if not face.datum]

    @property
    def worst(self) -> float:
        """The largest maximum deviation over the toleranced faces with points, mm (NaN without any)."""
        return max((face.maximum for face in self.toleranced), default=float("nan"))

    def result(self, name: str) -> SamplingResult:
        """The SamplingResult of a face of the plan (computed again from its points: the fit,
        the deviation over the part of the face the probe reaches, as the plan judged it, and
        OCC's check), for the document; its settings are the face's run's (the edge offset and
        spacing it used among them). Computed once per face and kept (:meth:`prepare_results`)."""
        if name in self._results:
            return self._results[name]
        face = self.faces[[f.name for f in self.faces].index(name)]
        fit = {key: face.settings[key] for key in FIT_KEYS if key in face.settings}
        out_of_reach = None if face.access is None else face.access.out_of_reach
        result = evaluate(self.shapes[name], face.uv, strategy=face.strategy, out_of_reach=out_of_reach, **fit)
        result.access = face.access
        result.settings = {**result.settings, **face.settings}
        self._results[name] = result
        return result

    def prepare_results(self, progress: Callable | None = None) -> None:
        """Compute what adding the plan to a document needs: the document's result of every
        toleranced face with points (:meth:`result`) and, for a plan with a probe that reaches
        all its points, the probe's path (:meth:`probe_moves`), so that adding the plan only
        writes them (the Plan part panel does this in its worker thread: judging the faces and
        the path through a 300-face part took 6 s in the GUI's). progress: callable(done, total)
        after each face and after the path, returning True to stop (the rest are computed when
        asked)."""
        names = [face.name for face in self.toleranced]
        steps = len(names) + int(self.has_path)
        for done, name in enumerate(names, start=1):
            self.result(name)
            if progress is not None and progress(done, steps):
                return
        if self.has_path:
            self.probe_moves()
            if progress is not None:
                progress(steps, steps)

    @property
    def has_path(self) -> bool:
        """Whether the plan has a probe path: made with a probe that reaches every point placed."""
        return self.probe is not None and bool(self.placed) and not any(face.unreached for face in self.placed)

    def point_set(self) -> PointSet:
        """The plan's points as one PointSet (cmmsampling.formats.pointset): labels '<face>_P<i>',
        each point's face, the plan's facts (:func:`cmmsampling.planning.plan_points.plan_point_set`)."""
        return plan_point_set(self)

    def probe_moves(self, motion: Motion | None = None) -> ProbeMoves:
        """The collision-free probe path through every point of a plan made with a probe
        (cmmsampling.access.probe_moves.ProbeMoves; motion: the CMM's speeds, a Motion; the
        path with the default speeds is computed once and kept)."""
        if motion is not None:
            return plan_moves(self, motion)
        if self._moves is None:
            self._moves = plan_moves(self)
        return self._moves

    def table(self) -> str:
        """The per-part table as text: face, area, N, deviation, bound, tolerance met, notes;
        then the plan's own notes, a line each."""
        lines = [f"{'face':<10} {'area mm^2':>10} {'N':>5} {'max mm':>9} {'bound mm':>9} {'met':>7}  notes"]
        for face in self.faces:
            if face.datum:
                lines.append(f"{face.name:<10} {face.area:>10.1f} {face.n:>5} {'':>9} {'':>9} {'':>7}  {face.notes}")
                continue
            lines.append(f"{face.name:<10} {face.area:>10.1f} {face.n:>5} {face.maximum:>9.4f} {face.bound:>9.4f} "
                         f"{face.met_text:>7}  {face.notes}")
        lines.append(f"{'part':<10} {self.area:>10.1f} {self.n_total:>5} {self.worst:>9.4f}")
        lines += [f"Note: {note}" for note in self.notes]
        return "\n".join(lines)


def percent(share):
    """A share 0..1 as a whole percentage, '10 %' (below 1 % with one significant digit, '0.4 %',
    above 99 % to 0.1 % rounded down, '99.6 %': a share that is not all never reads 0 or 100 %)."""
    value = 100.0 * share
    if 0 < value < 1:
        return f"{value:.1g} %"
    return f"{np.floor(value * 10) / 10:.1f} %" if 99 < value < 100 else f"{value:.0f} %"


def plan(shape_or_faces: Part.Shape | list, tolerance: float | Mapping[str, float] | None = None,
         n_total: int | None = None,
         strategy: str = BEST_STRATEGY, *, faces: list | None = None, n_max: int = DEFAULT_MAX_POINTS,
         edge_offset: float | None = None, processes: int | None = None, scheduler: object = None,
         progress: Callable | None = None, probe: Probe | None = None, part: Part.Shape | None = None,
         resume: PartPlan | None = None, datums: list | None = None, **arguments) -> PartPlan:
    """Probe points for a whole part: to a tolerance on every face, or a total of points.

    shape_or_faces: a Part.Shape (its faces, or those numbered from 1 in ``faces``, e.g.
    [1, 3, 5]) or a list of Part.Face (named Face1.. by position) or of (name, Part.Face);
    tolerance: mm, each face gets the fewest N that meets it (up to n_max), or {face name: mm}
    a tolerance for each face planned; n_total: the points of the whole part, spent to make the
    worst face's deviation smallest; exactly one of the two.
    strategy and ``arguments``: as in :func:`cmmsampling.sample` (workers default 1: the faces
    are the parallel part; time_limit, for the optimal strategy, default PLAN_TIME_LIMIT_S = 10 s
    per run, None: each run until it converges); edge_offset: mm, None for each face's probe edge offset;
    processes: local processes (None: all cores); scheduler: a Dask scheduler address or
    distributed.Client; progress: callable(done, total, message) after each face's run (message:
    the face's :attr:`FacePlan.line`, then on a second line the plan's tally, e.g. "12 of 40
    faces, 610 points so far, about 2 min left") and about every second while faces run (the
    first line then empty, the tally ending "running for 35 s" and, for each face under way, the
    N it runs and the best maximum so far, e.g. "; Face57: N = 36 (best so far 0.1046 mm with 16
    points)"), returning True to cancel: the
    faces under way stop within a second or two, and the faces done are kept; probe: a
    cmmsampling.Probe whose reach on the part is judged (each face keeps to what it reaches, an
    indexing head's orientations are then shared across the faces where that needs fewer, unless
    the plan was cancelled:
    :func:`cmmsampling.planning.plan_points.share_orientations`, and
    ``export(plan, order="probe_path")`` writes a collision-free path); part: the shape the probe
    must keep clear of (default: shape_or_faces when it is a shape); resume: a cancelled
    tolerance plan of the same faces, tolerance and strategy, whose faces done are kept and not
    run again; datums: the datum faces of the part's datum reference frame, primary first, by
    number as in ``faces`` ([3, 1, 5]; shape_or_faces a shape) or by name (['Face3', 'Face1']):
    labelled A, B, C, taken out of the toleranced faces, their points spread to hold the motions
    each fixes (cmmsampling.planning.datum_points; reachable by the probe where one is given),
    measured first; ``inspect(plan, measured)`` then aligns on them. Returns a PartPlan.
    """
    if (tolerance is None) == (n_total is None):
        raise InputError("give either tolerance= (mm, the deviation every face must meet) or n_total= "
                         "(the points of the whole part), not both or neither")
    if scheduler is not None:
        require("distributed", "Plans on a Dask cluster (scheduler=)", "plans on this machine's processes")
    named = named_faces(shape_or_faces, faces)
    datum_faces = _datum_faces(shape_or_faces, named, datums)
    named = [(name, face) for name, face in named if name not in dict(datum_faces)]
    if not named:
        raise InputError("every face to plan is a datum face: give the toleranced faces too (faces=[...])")
    part, part_brep = _part(shape_or_faces, part, probe)
    datum_plans = _datum_plans(datum_faces, probe, part, edge_offset)
    arguments = {"workers": 1, **arguments}
    if edge_offset is not None:
        arguments["edge_offset"] = check_real("edge_offset", edge_offset, 0.0)
    degree = arguments.get("fit_degree", DEFAULT_DEGREE)
    check_arguments(strategy, arguments, fewest_points(check_pair("fit_degree", degree, 1)))
    if "time_limit" in STRATEGIES[strategy].options:
        arguments.setdefault("time_limit", PLAN_TIME_LIMIT_S)
    start = time.perf_counter()
    if tolerance is not None:
        tolerances = face_tolerances(tolerance, named)
        n_max = check_max_points(n_max, degree)
        kept = kept_faces(resume, named, tolerances, strategy)

        def job(name, face):
            return FaceJob(name, face.exportBrepToString(), "tolerance", strategy, tolerance=tolerances[name],
                           n_max=n_max, arguments=arguments, part_brep=part_brep, probe=probe)

        outcomes, cancelled, notes = _tolerance_runs(named, kept, job, processes, scheduler, progress)
        result = PartPlan(_completed(outcomes, named), "tolerance", strategy, tolerance=min(tolerances.values()),
                          cancelled=cancelled, notes=notes,
                          face_tolerances=tolerances if isinstance(tolerance, Mapping) else {})
    else:
        if resume is not None:
            raise InputError("resume= continues a plan to a tolerance; plan a total of points (n_total=) anew")
        result = _plan_budget(named, check_int("n_total", n_total, 1), strategy, arguments, processes, scheduler,
                              progress, part_brep, probe)
    with_datums(result, datum_plans, dict(datum_faces))
    result.shapes = {**dict(datum_faces), **dict(named)}
    result.part, result.probe = part, probe
    if not result.cancelled:
        share_orientations(result)
    result.seconds = time.perf_counter() - start
    return result


def face_tolerances(tolerance: float | Mapping[str, float], named: list) -> dict[str, float]:
    """{name: mm} the tolerance of each named face ((name, Part.Face) pairs): one for all, or
    a mapping that names every face; InputError for a face it leaves out or a tolerance <= 0."""
    if not isinstance(tolerance, Mapping):
        value = check_real("tolerance", tolerance, above=0.0)
        return {name: value for name, _ in named}
    missing = [name for name, _ in named if name not in tolerance]
    if missing:
        raise InputError(f"tolerance= names no tolerance for {missing[0]}; give one for every face planned "
                         "({'Face3': 0.05, ...}) or one for all")
    return {name: check_real(f"tolerance of {name}", tolerance[name], above=0.0) for name, _ in named}


def _datum_faces(shape_or_faces, named, datums):
    """[(name, Part.Face)] of the datum faces, primary first: datums by number of a shape's faces
    or by name among named and the shape's faces; InputError naming one that is not there or
    given twice."""
    if datums is None or (hasattr(datums, "__len__") and not len(datums)):
        return []
    if isinstance(datums, (str, int)):
        datums = [datums]
    if all(isinstance(item, (int, np.integer)) and not isinstance(item, bool) for item in datums):
        if not isinstance(shape_or_faces, Part.Shape):
            raise InputError("datums= by number picks faces of a shape; with a list of faces, give their names")
        return named_faces(shape_or_faces, list(datums))
    known = dict(named_faces(shape_or_faces) if isinstance(shape_or_faces, Part.Shape) else named)
    names = [str(item) for item in datums]
    missing = [name for name in names if name not in known]
    if missing:
        raise InputError(f"datum {missing[0]!r} is no face of the part; give the datum faces by number or as "
                         "'Face3', primary first")
    if len(set(names)) != len(names):
        raise InputError("a datum face is given twice; give each datum once, primary first")
    return [(name, known[name]) for name in names]


def _datum_plans(datum_faces, probe, part, edge_offset):
    """The DatumPoints of the datum faces (cmmsampling.planning.datum_points), before any face
    runs: a datum the probe cannot reach is refused at once."""
    from .datum_points import plan_datums

    if not datum_faces:
        return []
    return plan_datums(datum_faces, probe, part, None if edge_offset is None else check_real("edge_offset",
                                                                                          edge_offset, 0.0))


def with_datums(result, planned, shapes):
    """Put the datum faces' FacePlans (planned: their DatumPoints, shapes: {name: Part.Face})
    first in result's faces and their names in ``result.datums``."""
    if not planned:
        return
    faces = [FacePlan(datum.face, float(shapes[datum.face].Area), len(datum.points), datum.uv,
                      datum.points, datum.normals, strategy=DATUM_STRATEGY,
                      settings={"datum": datum.label, "motions": datum.motions}, access=datum.access,
                      datum=datum.label) for datum in planned]
    result.faces = faces + result.faces
    result.datums = [datum.face for datum in planned]


def _part(shape_or_faces, part, probe):
    """(part, its BREP text) when the probe's reach is judged (a probe given), else (None, '');
    ValueError for a probe without a part to judge it on."""
    if probe is None:
        if part is not None:
            raise InputError("part= is what a probe must keep clear of: give probe= (a cmmsampling.Probe) too")
        return None, ""
    check_probe(probe)
    part = shape_or_faces if part is None and isinstance(shape_or_faces, Part.Shape) else part
    if not isinstance(part, Part.Shape):
        raise InputError("a probe's reach is judged on the whole part: give part= (the solid) with a list of faces")
    return part, part.exportBrepToString()


def named_faces(shape_or_faces, numbers=None):
    """[(name, Part.Face)] of a shape (faces numbered from 1, optionally only ``numbers``, a list of
    whole numbers, each once) or of a list of faces or (name, face) pairs. InputError naming a face
    number the shape lacks, one given twice, or ``numbers`` with a list of faces."""
    if isinstance(shape_or_faces, Part.Shape):
        faces = shape_or_faces.Faces
        if not faces:
            raise InputError("the shape has no faces to plan")
        chosen = range(1, len(faces) + 1) if numbers is None else face_numbers(numbers)
        bad = [k for k in chosen if not 1 <= k <= len(faces)]
        if bad:
            raise InputError(f"the shape has faces 1 to {len(faces)}; there is no face {bad[0]}")
        return [(f"Face{k}", faces[k - 1]) for k in chosen]
    if numbers is not None:
        raise InputError("faces= picks faces of a shape by number; with a list of faces, list only the faces to plan")
    named = [item if isinstance(item, tuple) else (f"Face{k}", item)
             for k, item in enumerate(shape_or_faces, start=1)]
    if not named:
        raise InputError("no faces to plan")
    names = [name for name, _ in named]
    if len(set(names)) != len(names):
        raise InputError("the faces' names must be unique")
    return [(name, as_face(face)) for name, face in named]


def face_numbers(numbers):
    """faces= as a list of ints (numpy integers too); InputTypeError for anything else (a single
    number, True), InputError for a number given twice."""
    if isinstance(numbers, (str, bytes)) or not isinstance(numbers, (list, tuple, range, np.ndarray)):
        raise InputTypeError(f"faces must be a list of face numbers, e.g. [1, 3, 5], got {numbers!r}")
    chosen = [check_int("a face number", k, 1) for k in numbers]
    twice = sorted({k for k in chosen if chosen.count(k) > 1})
    if twice:
        raise InputError(f"face {twice[0]} is given twice in faces=; give each face once")
    if not chosen:
        raise InputError("faces= is empty; give at least one face number, or leave it out for every face")
    return chosen


def solve_face(job):
    """A FaceJob's FacePlan (runs in a worker process, or here, with one BLAS thread: the faces
    are the parallel part): the tolerance search, or one run at job.n; a refused face gets its
    reason."""
    with blas_threads(1), reused():
        return _solve_face(job)


def _solve_face(job):
    """solve_face() without the thread limit."""
    started = time.perf_counter()
    shape = Part.Shape()
    shape.importBrepFromString(job.brep)
    face = shape.Faces[0]
    planned = FacePlan(job.name, float(face.Area), strategy=job.strategy, met=None)
    arguments = dict(job.arguments)
    if job.part_brep:
        arguments["part"] = part_reachability(job.part_brep, job.probe)
    try:
        if "edge_offset" not in arguments:
            arguments["edge_offset"] = probe_edge_offset(face)
        planned.edge_offset = arguments["edge_offset"]
        if job.mode == "points":
            result = sample(face, job.n, job.strategy, progress=lambda *_: face_runs.stop_asked(), **arguments)
        else:
            result = _copied(job, face, arguments, planned) if job.mode == "copy" else None
            if result is None:
                answer = points_needed(face, job.tolerance, job.strategy, n_max=job.n_max,
                                       progress=_searching, **arguments)
                planned.tried, planned.met, planned.reason = answer.tried, answer.met, answer.reason
                result = answer.result
    except InputError as exc:
        result, planned.reason = None, str(exc)
    if result is not None:
        _take(planned, result)
    planned.seconds = time.perf_counter() - started
    return planned


def _copied(job, face, arguments, planned):
    """The SamplingResult of the original's points (job.original, a FacePlan) moved onto ``face``,
    its rigid copy, and judged there, with ``planned`` told the original's search and the
    motion; None where the two faces' problems differ: not a rigid copy (as judged here), another
    edge offset or domain (:func:`_same_domain`), or a maximum deviation that does not agree with
    the original's (COPY_AGREEMENT, COPY_AGREEMENT_MM)."""
    original, other = job.original, _face_of(job.original_brep)
    copy = rigid_copy(_face_print(other), _face_print(face))
    if copy is None or abs(original.edge_offset - arguments["edge_offset"]) > 1e-9:
        return None
    if not _same_domain(other, face, copy.shift, arguments):
        return None
    fit = {key: arguments[key] for key in FIT_KEYS if key in arguments}
    result = evaluate(face, original.uv + copy.shift, strategy=job.strategy, part=arguments.get("part"),
                      occ_check=arguments.get("occ_check", True), **fit)
    if abs(result.deviation.maximum - original.maximum) > COPY_AGREEMENT * original.maximum + COPY_AGREEMENT_MM:
        return None
    result.settings = {**result.settings, **original.settings}
    planned.tried, planned.reason = original.tried, original.reason
    planned.met = bool(result.deviation.maximum <= job.tolerance)
    planned.copy_of = f"{original.name} ({copy.motion_text})"
    return result


def _face_of(brep):
    """The Part.Face in BREP text."""
    shape = Part.Shape()
    shape.importBrepFromString(brep)
    return shape.Faces[0]


def _face_print(face):
    """The congruence FacePrint of a Part.Face (its setup's model, shared within a reused() block)."""
    model = setup_of(face).model
    return FacePrint(model, model.area)


def _domain(face, arguments):
    """The FaceDomain of a face for a plan's arguments: their edge offset, the probe's reach
    where they hold a part."""
    return setup_of(face).domain(arguments["edge_offset"], arguments.get("part"))


def _same_domain(original, copy, shift, arguments):
    """True when two faces' domains (:func:`_domain`) agree at the centres of all but a
    DOMAIN_MISMATCH share of DOMAIN_CELLS x DOMAIN_CELLS cells of the original's parameter
    rectangle, moved by ``shift`` (2,) on the copy. (The original's points are not asked: a
    search leaves many on its domain's edge, where rounding decides either way.)"""
    places = raster(setup_of(original).model, DOMAIN_CELLS, centres=True)
    differ = _domain(original, arguments).contains(places) != _domain(copy, arguments).contains(places + shift)
    return bool(differ.mean() <= DOMAIN_MISMATCH)


def _searching(n, message):
    """A face's tolerance search's progress in a plan's job: tell the plan the N about to run
    and the best so far (face_runs.report); True when the plan was cancelled."""
    if message is not None:
        face_runs.report(message)
    return face_runs.stop_asked()


def larger_with_more(tried, factor=RISE_FACTOR):
    """A note where a search's larger N gave a larger maximum than a smaller N, by more than
    ``factor`` (the largest such rise), e.g. 'more points gave a larger maximum: N = 81 reached
    0.2749 mm, N = 49 0.0084 mm'; '' where none did. tried: the search's Tried runs."""
    runs = sorted((t.n, t.maximum) for t in tried if np.isfinite(t.maximum))
    rises = [(larger / smaller, (n, larger), (m, smaller))
             for k, (n, larger) in enumerate(runs) for m, smaller in runs[:k] if m < n and smaller > 0]
    ratio, (n, larger), (m, smaller) = max(rises, default=(0.0, (0, 0.0), (0, 0.0)))
    if ratio <= factor:
        return ""
    return f"more points gave a larger maximum: N = {n} reached {larger:.4g} mm, N = {m} {smaller:.4g} mm"


@functools.lru_cache(maxsize=1)
def part_reachability(brep, probe):
    """The Reachability of the part in ``brep`` (a BREP string) for probe (a Probe): built once
    per process for the faces of a plan it runs (the part's points take seconds to build)."""
    part = Part.Shape()
    part.importBrepFromString(brep)
    return Reachability(part, probe)


def _take(planned, result):
    """Copy what a plan keeps of a SamplingResult into a FacePlan."""
    planned.n = result.n
    planned.uv, planned.points, planned.normals = result.uv, result.points, result.normals
    planned.maximum = result.deviation.maximum
    planned.bound = result.bounds()["grid"].lower
    planned.settings = dict(result.settings)
    planned.access = result.access


def _tolerance_runs(named, kept, job, processes, scheduler, progress):
    """(outcomes in the order of named (None where cancelled), cancelled, notes) of a tolerance
    plan, run in rounds: the faces kept (a resumed plan's, {name: FacePlan}) as they are; every
    face that copies none searched in the first round; each copy once its group's searches are
    done (:func:`_group_job`). job: (name, Part.Face) -> its tolerance FaceJob (made once a face:
    it writes the face's BREP)."""
    faces = dict(named)
    originals = {name: original for name, original in copied_faces(named).items() if name not in kept}
    groups = {original: [copy for copy, of in originals.items() if of == original] for original in originals.values()}
    job_of = functools.lru_cache(maxsize=None)(lambda name: job(name, faces[name]))
    tally = PlanTally(len(named), len(kept), sum(face.n for face in kept.values()))
    done, cancelled, notes = dict(kept), False, []
    jobs = _round(named, originals, groups, done, job_of)
    while jobs and not cancelled:
        outcomes, cancelled, round_notes = _run(jobs, processes, scheduler, progress, tally)
        done.update((ran.name, outcome) for ran, outcome in zip(jobs, outcomes) if outcome is not None)
        notes += [note for note in round_notes if note not in notes]
        jobs = _round(named, originals, groups, done, job_of)
    return [done.get(name) for name, _ in named], cancelled, notes


def _round(named, originals, groups, done, job_of):
    """The jobs of a plan's next round: each face not done that copies none, and each copy whose
    :func:`_group_job` is ready (originals: {copy's name: original's name}; groups: {original's
    name: its copies' names}; job_of: name -> the face's tolerance FaceJob)."""
    jobs, searching = [], set()
    for name, _ in named:
        if name in done:
            continue
        original = originals.get(name)
        ready = job_of(name) if original is None else _group_job(name, original, groups[original], done, searching,
                                                                 job_of)
        jobs += [ready] if ready is not None else []
    return jobs


def _group_job(name, original, copies, done, searching, job_of):
    """The job of the copy ``name`` once its group's searches allow, None until then.

    A group is an original and its copies (names). Its searches are its faces done by a search
    of their own. Once the original is done: where the best search (:func:`_best_search`) meets
    the tolerance or holds no points, or the group had RETRIES more searches, the
    copy takes the best's points (:func:`_copy_job`); else one copy at a time searches itself
    (``searching``: the groups with such a search in this round), a second chance that then serves
    the whole group."""
    if original not in done or original in searching:
        return None
    searched = [face for face in [original, *copies] if face in done and not done[face].copy_of]
    best = _best_search([done[face] for face in searched])
    if done[best].met or not done[best].placed or len(searched) > RETRIES:
        return _copy_job(job_of(name), done[best], job_of(best).brep)
    searching.add(original)
    return job_of(name)


def _best_search(plans):
    """The name of the best of a group's searched FacePlans: those that meet the tolerance where
    any does, among them the first (the original first) whose maximum is within COPY_AGREEMENT
    and COPY_AGREEMENT_MM of the least: a lower figure by rounding alone does not count."""
    plans = [plan for plan in plans if plan.met] or plans
    least = min((plan.maximum for plan in plans if plan.placed), default=float("nan"))
    return next((plan.name for plan in plans if plan.maximum <= least * (1 + COPY_AGREEMENT) + COPY_AGREEMENT_MM),
                plans[0].name)


def copied_faces(named):
    """{name: the name of the face it is a rigid copy of} (cmmsampling.geometry.congruence) for
    the named faces ([(name, Part.Face)]) that copy an earlier one; a face whose surface cannot
    be read copies none."""
    prints = []
    for _, face in named:
        try:
            prints.append(_face_print(face))
        except (ValueError, RuntimeError):
            prints.append(None)
    found = face_copies(prints)
    return {name: named[copy.original][0] for (name, _), copy in zip(named, found) if copy is not None}


def _copy_job(job, original, original_brep):
    """The job of a face that copies the face in ``original_brep`` (BREP text): judged with the
    original's points (its FacePlan) where the original holds some, else searched like any face."""
    if not original.placed:
        return job
    return replace(job, mode="copy", original=original, original_brep=original_brep)


def _run(jobs, processes, scheduler, progress, tally=None):
    """(outcomes, cancelled, notes) of the jobs through face_runs.run_all; tally: the PlanTally
    the progress counts on (None: one for these jobs alone)."""
    stopped = []
    tally = tally or PlanTally(len(jobs))

    def watched(done, total, message):
        report = (f"{message}\n{tally.line}" if message is not None
                  else f"\n{tally.line}, {tally.elapsed}{tally.working_text}")
        if progress is not None and progress(tally.done, tally.total, report):
            stopped.append(True)
            return True
        return False

    outcomes, notes = face_runs.run_all(solve_face, jobs, processes, scheduler, watched, describe=tally.count,
                                        during=lambda index, text: tally.say(jobs[index].name, text))
    return outcomes, bool(stopped), notes


class PlanTally:
    """Faces done, points so far and the time left of a plan's run, for its progress messages.

    total: faces in all; done, points: those of them done before this run (a resumed plan).
    """

    def __init__(self, total, done=0, points=0):
        self.total, self.done, self.points = total, done, points
        self.working = {}
        self._before = done
        self._start = self._last = time.perf_counter()

    def count(self, job, outcome):
        """Count a finished face (its FacePlan); returns the face's line."""
        self.done += 1
        self.points += outcome.n
        self.working.pop(job.name, None)
        self._last = time.perf_counter()
        return outcome.line

    def say(self, name, text):
        """Keep what the face ``name`` under way last said of itself (its N and best so far)."""
        self.working[name] = text

    @property
    def working_text(self):
        """What the faces under way last said, e.g. "; Face57: N = 36 (best so far 0.1046 mm
        with 16 points)" ('' before any said anything)."""
        return "".join(f"; {name}: {text}" for name, text in self.working.items())

    @property
    def line(self):
        """e.g. "12 of 40 faces, 610 points so far, about 2 min left": at each face done, the
        pace of the faces run so far times the faces left, counted down from then (none before
        a face is done, or once a count-down from a second or more has run out)."""
        text = f"{self.done} of {self.total} faces, {self.points} points so far"
        ran = self.done - self._before
        if ran and self.done < self.total:
            pace = (self._last - self._start) / ran * (self.total - self.done)
            left = pace - (time.perf_counter() - self._last)
            text += f", {time_left_text(max(left, 0.0))}" if left >= 1 or pace < 1 else ""
        return text

    @property
    def elapsed(self):
        """e.g. "running for 35 s": the time since this run started."""
        return f"running for {duration_text(time.perf_counter() - self._start)}"


def kept_faces(resume, named, tolerances, strategy):
    """{name: FacePlan} of a resumed plan's faces that ran (none without one); InputError when it
    is not a tolerance plan of these faces with these tolerances ({name: mm}) and strategy."""
    if resume is None:
        return {}
    if not isinstance(resume, PartPlan):
        raise InputTypeError(f"resume must be the PartPlan of a cancelled plan, got {type(resume).__name__}")
    tolerance = min(tolerances.values())
    earlier = resume.face_tolerances or {name: resume.tolerance for name, _ in named}
    if (resume.mode, resume.strategy) != ("tolerance", strategy) or earlier != tolerances:
        raise InputError(f"the plan to resume is a {resume.mode} plan with {resume.strategy} (tolerance "
                         f"{resume.tolerance} mm), not to {tolerance:g} mm with {strategy}: give the same "
                         "tolerance and strategy, or plan anew without resume=")
    faces = dict(named)
    ran = {face.name: face for face in resume.faces if face.reason != CANCELLED_REASON}
    other = [name for name in ran if name not in faces or not _same_face(resume.shapes[name], faces[name])]
    if other:
        raise InputError(f"{other[0]} of the plan to resume is not {other[0]} of this part: resume a plan "
                         "of the same part and faces, or plan anew without resume=")
    return ran


def _same_face(earlier, face):
    """True when two Part.Faces are the same face: the same shape, or one read again (the same
    area and centre of mass within a micrometre)."""
    if earlier.isSame(face):
        return True
    moved = earlier.CenterOfMass.sub(face.CenterOfMass).Length
    return abs(earlier.Area - face.Area) <= 1e-6 * max(face.Area, 1.0) and moved <= 1e-3


def _completed(outcomes, named):
    """FacePlans for every face: the outcomes, and for a face without one (cancelled) a plan
    that says so."""
    why = CANCELLED_REASON
    return [outcome if outcome is not None else FacePlan(name, float(face.Area), reason=why)
            for outcome, (name, face) in zip(outcomes, named)]


def _plan_budget(named, budget, strategy, arguments, processes, scheduler, progress, part_brep, probe):
    """The greedy allocation of a total of points (see the module docstring)."""
    degree = arguments.get("fit_degree", DEFAULT_DEGREE)
    first = fewest_points(degree)
    jobs = [FaceJob(name, face.exportBrepToString(), "points", strategy, n=first, arguments=arguments,
                    part_brep=part_brep, probe=probe) for name, face in named]
    if budget < first * len(jobs):
        raise InputError(f"{budget} points give fewer than {first} to each of the {len(jobs)} faces; give "
                         f"n_total of at least {first * len(jobs)}, or fewer faces")
    firsts = [s[1] for s in step_counts(budget, degree)]
    outcomes, cancelled, notes = _run(jobs, processes, scheduler, progress)
    faces = _completed(outcomes, named)
    spent = sum(face.n for face in faces)
    while not cancelled:
        worst = max((k for k, face in enumerate(faces) if face.placed), key=lambda k: faces[k].maximum, default=None)
        if worst is None:
            break
        later = [n for n in firsts if n > faces[worst].n]
        if not later or spent - faces[worst].n + later[0] > budget:
            break
        job = FaceJob(faces[worst].name, jobs[worst].brep, "points", strategy, n=later[0], arguments=arguments,
                      part_brep=part_brep, probe=probe)
        [stepped], cancelled, step_notes = _run([job], 1, scheduler, progress)
        notes += [note for note in step_notes if note not in notes]
        if stepped is None or not stepped.placed or not stepped.maximum < faces[worst].maximum:
            faces[worst].reason = f"its next step ({later[0]} points) did not lower its deviation"
            break
        spent += stepped.n - faces[worst].n
        faces[worst] = stepped
    return PartPlan(faces, "points", strategy, budget=budget, cancelled=cancelled, notes=notes)
