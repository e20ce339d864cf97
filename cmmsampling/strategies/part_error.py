"""Points where the next part of a series is least known: the ``part_error`` strategy.

Every other strategy places points to rebuild the CAD face; this one places them to find the
manufactured part's error, given what the series' earlier parts showed
(cmmsampling.fitting.series: the systematic error and how parts scatter about it). The points are
chosen one at a time among CANDIDATES feasible places of the face (a Halton set inside its trim,
edge offset and probe reach), each where measuring lowers the sum of the error's posterior
variances over those places most, keeping the strategy's spacing; a blind layout (uniform,
Halton, Hammersley) the model expects to do better as a whole is returned instead. The result records the error
map's expected RMS and largest standard deviation over the face (``expected_rms_mm``,
``expected_max_sd_mm``), the model's prediction of how well the next part will be known.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial import cKDTree

from ..fitting.exact import NearestParameters
from ..fitting.series import SeriesModel, greedy_design
from ..geometry.validation import InputError
from .blind import feasible_candidates
from .registry import STRATEGIES, Progress, Strategy, StrategyOutcome, layouts
from .settings import BEST_STARTS

if TYPE_CHECKING:
    from .problem import SamplingProblem

CANDIDATES = 1200
JUDGED = 30
NO_PRIOR = ("part_error places points where the series' earlier parts leave the next part's error least known: "
            "give prior=[the Inspection of an earlier part, ...] (cmmsampling.inspect) or a series model "
            "(cmmsampling.series_model)")


def series_of(problem: SamplingProblem, prior: SeriesModel | list[Any]) -> SeriesModel:
    """The SeriesModel of ``prior`` on the problem's face: prior itself when it is one, else one
    built from its inspections' points (each with ``points`` (M, 3) mm and ``deviations`` (M,) mm)."""
    if isinstance(prior, SeriesModel):
        return prior
    nearest = NearestParameters(problem.model, problem.domain.on_face)
    return SeriesModel(problem.model, [(nearest(part.points), part.deviations) for part in prior])


def run_part_error(problem: SamplingProblem, progress: Progress | None,
                   prior: SeriesModel | list[Any]) -> StrategyOutcome:
    """Near the fewest-unknowns design for the next part (see the module docstring)."""
    series = series_of(problem, prior)
    candidates = feasible_candidates(problem, candidate_count(problem.n))
    if len(candidates) < problem.n:
        raise InputError(f"only {len(candidates)} feasible places found on the face for {problem.n} points; "
                         "lower n or edge_offset")
    places = problem.model.points(candidates)
    tree = cKDTree(places)
    spacing = problem.min_spacing

    def spaced_out(index: int) -> list[int]:
        return tree.query_ball_point(places[index], spacing) if spacing > 0 else [index]

    judged = judged_places(problem, candidates)
    chosen, variances = greedy_design(series, candidates, problem.n, spaced_out, judged)
    uv, variances, layout = _best_design(problem, series, judged, candidates[chosen], variances)
    rms, largest = float(np.sqrt(variances.mean())), float(np.sqrt(variances.max()))
    notes = [f"placed where {series.parts} earlier part{'s' if series.parts > 1 else ''} leave the error least "
             f"known: the error map is expected within {rms:.3g} mm RMS (1 standard deviation; at most "
             f"{largest:.3g} mm)"]
    if layout is not None:
        notes.append(f"the {STRATEGIES[layout].label} layout is expected to know the part better than the points "
                     "chosen one at a time, and is returned")
    details = {"prior": f"{series.parts} earlier parts", "expected_rms_mm": rms, "expected_max_sd_mm": largest}
    return StrategyOutcome(uv, details=details, notes=notes)


def judged_places(problem: SamplingProblem, candidates: np.ndarray) -> np.ndarray:
    """(Q, 2) uv where the error map is judged: a JUDGED x JUDGED raster of the face's parameter
    range, those on the face (inside its trim); the candidates (C, 2) where none is."""
    raster = problem.model.raster((JUDGED, JUDGED)).reshape(-1, 2)
    on_face = raster[problem.domain.on_face(raster)]
    return on_face if len(on_face) else candidates


def _best_design(problem: SamplingProblem, series: SeriesModel, judged: np.ndarray, greedy: np.ndarray,
                 variances: np.ndarray) -> tuple[np.ndarray, np.ndarray, str | None]:
    """(uv (N, 2), posterior variances (Q,) mm^2 at the judged places (Q, 2), the blind layout's name or
    None): the greedy design, or a blind layout of BEST_STARTS (those the face takes) where the
    model expects a smaller sum of variances after it; choosing one point at a time is not
    always the best set of N."""
    best: tuple[np.ndarray, np.ndarray, str | None] = (greedy, variances, None)
    for name, uv in layouts(problem, optional=BEST_STARTS).items():
        spread = series.predict(uv, np.zeros(len(uv)), judged)[1] ** 2
        if spread.sum() < best[1].sum():
            best = (uv, spread, name)
    return best


def candidate_count(n: int) -> int:
    """How many feasible places the N points are chosen among: CANDIDATES, or 4 N for more points."""
    return max(CANDIDATES, 4 * n)


def _part_error_memory(n: int, poles: tuple[int, int], nodes: int, options: dict[str, Any], workers: int) -> int:
    """The posterior covariance of the judged places and candidates with the candidates, and the
    temporaries of its updates: 4 (Q + C, C) arrays."""
    count = candidate_count(n)
    return 4 * 8 * (JUDGED ** 2 + count) * count


def _check_part_error_options(options: dict[str, Any]) -> dict[str, Any]:
    """The prior must be given: a SeriesModel or a non-empty list of inspections."""
    prior = options["prior"]
    if prior is None or (not isinstance(prior, SeriesModel) and len(list(prior)) == 0):
        raise InputError(NO_PRIOR)
    if isinstance(prior, SeriesModel):
        return dict(options)
    parts = list(prior)
    for part in parts:
        if not (hasattr(part, "points") and hasattr(part, "deviations")):
            raise InputError(f"prior holds a {type(part).__name__}, not an inspection; {NO_PRIOR}")
        if len(set(getattr(part, "faces", None) or [None])) > 1:
            raise InputError("a prior inspection covers several faces: build the series of one with "
                             "cmmsampling.series_model(face, inspections, name='FaceN') and give that as prior")
    return {**options, "prior": parts}


RECORD = Strategy(
    "part_error", run_part_error,
    "where the series' earlier parts leave the next part's error least known (needs their inspections)",
    "part error (series)", {"prior": None}, _check_part_error_options, requires=("prior",),
    memory=_part_error_memory)
