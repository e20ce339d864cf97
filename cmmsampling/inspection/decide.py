"""Measuring until the verdict is decided: how likely a face conforms to its profile tolerance
given the points measured so far, and where the next touch tells most about it.

The face's deviation along its normals, e(x), is a Gaussian field over plane coordinates x (mm,
:class:`cmmsampling.fitting.series.PlaneCoordinates`): a rigid motion of the part on the table
(its components along the places' rigid basis J, unknown: a flat prior), where a series of
earlier parts is known its systematic error in an unknown amount (flat too), plus a Matern 5/2 field
of unknown variance, length scale and probing noise. The variance is integrated out (Jeffreys'
prior: the field between the points is Student-t with n - p degrees of freedom, p the shapes
held in unknown amounts), and the length scale and the noise are weighed over a grid by their restricted
likelihood (those amounts integrated out), not fixed at the likeliest: a few points say
little about how rough the face is between them, and a belief that takes the likeliest length
is too sure there. Posterior samples of e on places covering the whole face, its edges
included (the tolerance holds to the edges, which the probe keeps its offset from), are each
aligned by the rigid motion that makes its largest deviation smallest (the minimum zone, as the
inspection aligns: :func:`minimum_zones`), and a sample's profile is twice that largest
deviation (ISO 1101's zone about the nominal, no datums). With the measurement's expanded
uncertainty U, ISO 14253-1's rule decides per sample: conformance where the profile + U <= t,
non-conformance where the profile - U > t. The face is decided when one of the two holds for
all but a share ``risk`` of the samples; its verdict is then wrong with a probability below risk
under the model (Dumas et al., Precision Engineering 37, 2013: kriging that confirms a large
surface's conformity at a stated confidence with few points).

The next touch goes where the samples disagree most on whether the aligned deviation leaves
the half zone: each place's share q of samples beyond (t - U) / 2, scored q (1 - q) (the AK-ILS
learning function's spirit: the place whose side of the limit is least known), divided by 1 +
the travel from the last touch over the face's extent; a place the probe may not touch (near
an edge) lends its score to the nearest place it may. Where the samples already say "does not
conform", the touch goes where q is largest, to measure the excess itself.
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import cho_factor, cho_solve, cholesky, eigh, solve
from scipy.spatial import cKDTree

from ..fitting.series import matern
from ..geometry.validation import InputError

# Posterior samples of the field drawn per decision; the fewest points a belief is formed from
# (the rigid motions, any trend and the field's scale need more than six); the length scales weighed, from
# the places' spacing to twice their extent; the probing noise weighed, as shares of the
# field's variance; the share of the weight the likeliest (length, noise) pairs must hold
# between them to be the ones sampled.
SAMPLES = 400
FEWEST_POINTS = 12
LENGTHS = 16
NOISE_RATIOS = (1e-4, 1e-3, 1e-2, 0.1)
WEIGHT_KEPT = 0.999
JITTER = 1e-10
# Rounds of Lawson's algorithm that bring each sample near its minimum zone.
LAWSON_STEPS = 30


@dataclass(frozen=True)
class Candidates:
    """The places on a face the belief weighs: points (M, 3) mm on the nominal face, normals
    (M, 3) unit out of the material, x (M, 2) mm the face's plane coordinates there, touchable
    (M,) bool where the probe may touch (the others, nearer the edges than the probe's offset,
    are judged but not touched); trend: (M, q) mm shapes the deviation is expected to hold in
    unknown amounts (a series' systematic error: flat priors, as the rigid motions), or None;
    motions: (M, k) the deviation per unit of each motion the part is free to make (the ones a
    datum reference frame leaves free; k may be 0), or None: every rigid motion."""

    points: np.ndarray
    normals: np.ndarray
    x: np.ndarray
    touchable: np.ndarray
    trend: np.ndarray | None = None
    motions: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.points)

    @property
    def extent(self) -> float:
        """mm: the largest side of the places' bounding box (at least 1e-9)."""
        return max(float(np.ptp(self.points, axis=0).max()), 1e-9)

    @functools.cached_property
    def nearest_touch(self) -> np.ndarray:
        """(M,) int: each place's nearest touchable place (itself where it is one)."""
        rows = np.flatnonzero(self.touchable)
        if len(rows) == 0:
            raise InputError("no place on the face is far enough from its edges to be touched: "
                             "give a smaller edge offset")
        return rows[cKDTree(self.points[rows]).query(self.points)[1]]

    @functools.cached_property
    def rigid(self) -> np.ndarray:
        """(M, p): each place's deviation along its normal per small rigid motion of the part
        (those ``motions`` leaves free), the p <= 6 motions that move the face at all (a plane's
        own slides and turn do not), columns orthonormal."""
        if self.motions is None:
            arm = (self.points - self.points.mean(axis=0)) / self.extent
            basis = np.hstack([self.normals, np.cross(arm, self.normals)])
        else:
            basis = np.asarray(self.motions, float).reshape(len(self), -1)
        if not basis.shape[1]:
            return basis
        vectors, sizes, _ = np.linalg.svd(basis, full_matrices=False)
        return vectors[:, sizes > 1e-9 * sizes.max()]

    @functools.cached_property
    def known(self) -> np.ndarray:
        """(M, p'): the shapes the deviation holds in unknown amounts, the rigid motions' and the
        trend's (less its rigid part; columns orthonormal, those that add nothing left out)."""
        if self.trend is None:
            return self.rigid
        trend = np.asarray(self.trend, float).reshape(len(self), -1)
        trend = trend - self.rigid @ (self.rigid.T @ trend)
        vectors, sizes, _ = np.linalg.svd(trend, full_matrices=False)
        scale = max(float(np.linalg.norm(trend)), 1e-300)
        return np.hstack([self.rigid, vectors[:, sizes > 1e-6 * scale]])

    @functools.cached_property
    def lengths(self) -> np.ndarray:
        """(LENGTHS,) mm: the field's length scales weighed, log-spaced from the places' median
        spacing (in plane coordinates) to twice their extent."""
        spacing = float(np.median(cKDTree(self.x).query(self.x, k=2)[0][:, 1]))
        extent = max(float(np.ptp(self.x, axis=0).max()), 1e-9)
        return np.geomspace(max(spacing, 1e-3 * extent), 2.0 * extent, LENGTHS)


@dataclass(frozen=True)
class Belief:
    """What the measured points say about the face: p_conform and p_nonconform, the shares of
    posterior samples that ISO 14253-1 judges conforming (profile + U <= t) and not (profile - U
    > t); profile: (S,) mm the samples' profiles; beyond: (M,) each place's share of samples
    whose aligned deviation leaves the half zone (t - U) / 2; spread: (M,) mm the aligned
    deviation's posterior standard deviation at each place."""

    p_conform: float
    p_nonconform: float
    profile: np.ndarray
    beyond: np.ndarray
    spread: np.ndarray

    def decision(self, risk: float) -> str | None:
        """'conforms' or 'does not conform' where that side holds with probability 1 - risk at
        least, else None."""
        if self.p_conform >= 1.0 - risk:
            return "conforms"
        if self.p_nonconform >= 1.0 - risk:
            return "does not conform"
        return None


@dataclass(frozen=True)
class _Field:
    """One (length mm, noise ratio) of the field and what the points say under it: weight (its
    posterior share), scale (mm^2, the residual sum of squares the variance is drawn from), and
    the pieces of its posterior given the points."""

    length: float
    ratio: float
    log_weight: float
    scale: float
    factor: tuple
    motion: np.ndarray
    residual: np.ndarray
    information: np.ndarray


def belief(candidates: Candidates, rows: np.ndarray, deviations: np.ndarray, tolerance: float,
           uncertainty: float = 0.0, samples: int = SAMPLES, seed: int = 0) -> Belief:
    """The Belief of a face from deviations (n,) mm along the normals measured at candidate rows
    (n,) (FEWEST_POINTS at least), to the profile tolerance t mm with the expanded uncertainty U
    mm; seed: the posterior samples' random generator (the same inputs give the same belief)."""
    rows, d = np.asarray(rows, dtype=int), np.asarray(deviations, dtype=float)
    if len(rows) < FEWEST_POINTS:
        raise InputError(f"a face's belief needs {FEWEST_POINTS} measured points at least, got {len(rows)}")
    rng = np.random.default_rng(seed)
    fields = _weighed_fields(candidates, rows, d)
    shares = np.exp(np.array([found.log_weight for found in fields]))
    counts = rng.multinomial(samples, shares / shares.sum())
    drawn = np.vstack([_draw(candidates, rows, found, count, rng) for found, count in zip(fields, counts) if count])
    profile, aligned = minimum_zones(drawn, candidates.rigid)
    half = 0.5 * max(tolerance - uncertainty, 0.0)
    return Belief(float(np.mean(profile + uncertainty <= tolerance)), float(np.mean(profile - uncertainty > tolerance)),
                  profile, (np.abs(aligned) > half).mean(axis=0), aligned.std(axis=0))


def _weighed_fields(candidates: Candidates, rows: np.ndarray, d: np.ndarray) -> list[_Field]:
    """The likeliest (length, noise ratio) pairs of the grid that hold WEIGHT_KEPT of the
    posterior weight between them (a flat prior over the grid), each with its log weight
    (normalised to the largest 0) and posterior pieces."""
    motions = candidates.known[rows]
    freedom = len(rows) - motions.shape[1]
    fields = []
    for length in candidates.lengths:
        correlation = matern(candidates.x[rows], candidates.x[rows], float(length), 1.0)
        for ratio in NOISE_RATIOS:
            try:
                factor = cho_factor(correlation + (ratio + JITTER) * np.eye(len(rows)))
            except np.linalg.LinAlgError:
                continue
            across = cho_solve(factor, np.column_stack([d, motions]))
            information = motions.T @ across[:, 1:]
            motion = _solved(information, motions.T @ across[:, 0])
            residual = d - motions @ motion
            scale = max(float(residual @ cho_solve(factor, residual)), 1e-300)
            log_weight = (-np.log(np.diag(factor[0])).sum() - 0.5 * np.linalg.slogdet(information)[1]
                          - 0.5 * freedom * np.log(scale))
            fields.append(_Field(float(length), ratio, float(log_weight), scale, factor, motion, residual, information))
    if not fields:
        raise InputError(f"no deviation field fits these {len(rows)} points (no covariance was positive definite): "
                         "check for repeated points")
    fields.sort(key=lambda found: -found.log_weight)
    weights = np.exp(np.array([found.log_weight for found in fields]) - fields[0].log_weight)
    kept = int(np.searchsorted(np.cumsum(weights) / weights.sum(), WEIGHT_KEPT)) + 1
    return [replace(found, log_weight=float(weight)) for found, weight in zip(fields[:kept], np.log(weights[:kept]))]


def _draw(candidates: Candidates, rows: np.ndarray, found: _Field, count: int,
          rng: np.random.Generator) -> np.ndarray:
    """(count, M) mm posterior samples of the deviation at every place under one field: the
    universal kriging mean and covariance (the unknown amounts' uncertainty included) at unit
    variance, times a variance drawn from its posterior, scale / chi^2 with n - p degrees of
    freedom."""
    motions, every = candidates.known[rows], candidates.known
    across = matern(candidates.x, candidates.x[rows], found.length, 1.0)
    weighted = cho_solve(found.factor, across.T)                    # (n, M)
    mean = every @ found.motion + weighted.T @ found.residual
    left = every - weighted.T @ motions                             # (M, p)
    covariance = (matern(candidates.x, candidates.x, found.length, 1.0) - across @ weighted
                  + left @ _solved(found.information, left.T))
    root = _root(0.5 * (covariance + covariance.T))
    variance = found.scale / rng.chisquare(len(rows) - motions.shape[1], count)
    return mean + np.sqrt(variance)[:, None] * (rng.standard_normal((count, len(mean))) @ root.T)


def _solved(information: np.ndarray, right: np.ndarray) -> np.ndarray:
    """information^-1 right for a positive definite (p, p) information, p = 0 included."""
    if not len(information):
        return np.zeros(right.shape)
    return solve(information, right, assume_a="pos")


def _root(covariance: np.ndarray) -> np.ndarray:
    """(M, M) R with R R^T = covariance (a positive semi-definite (M, M)): Cholesky's with a
    small jitter, or the eigenvectors' where that fails."""
    try:
        return cholesky(covariance + JITTER * max(float(np.trace(covariance)) / len(covariance), 1e-30)
                        * np.eye(len(covariance)), lower=True)
    except np.linalg.LinAlgError:
        values, vectors = eigh(covariance)
        return vectors * np.sqrt(np.clip(values, 0.0, None))


def minimum_zones(fields: np.ndarray, basis: np.ndarray, steps: int = LAWSON_STEPS) -> tuple[np.ndarray, np.ndarray]:
    """(profiles (S,) mm, aligned fields (S, M) mm): each field (S, M) mm aligned by the rigid
    motion (basis (M, 6)) that makes its largest deviation smallest, by Lawson's reweighted least
    squares (steps rounds, all fields at once; each round's alignment is a real one, so the
    smallest zone found is never below the minimum zone), its profile twice that largest
    deviation (ISO 1101's zone about the nominal); with no motion (basis (M, 0)), as they are."""
    if not basis.shape[1]:
        return 2.0 * np.abs(fields).max(axis=1), fields.copy()
    weights = np.full(fields.shape, 1.0 / fields.shape[1])
    best, aligned = np.full(len(fields), np.inf), fields.copy()
    ridge = 1e-12 * np.eye(basis.shape[1])
    for _ in range(steps):
        weighted = weights[:, :, None] * basis          # (S, M, 6)
        normal = np.swapaxes(weighted, 1, 2) @ basis + ridge
        motion = np.linalg.solve(normal, ((weights * fields) @ basis)[..., None])[..., 0]
        residual = fields - motion @ basis.T
        size = np.abs(residual)
        zone = 2.0 * size.max(axis=1)
        better = zone < best
        best[better], aligned[better] = zone[better], residual[better]
        weights = weights * size
        weights /= np.maximum(weights.sum(axis=1, keepdims=True), 1e-300)
    return best, aligned


def next_row(candidates: Candidates, found: Belief, measured: np.ndarray, last: int | None,
             seek_excess: bool = False, travel: Callable[[int], np.ndarray] | None = None) -> int:
    """The touchable row to touch next: the largest q (1 - q) (q: found.beyond), or with
    seek_excess the largest q (where the zone is most likely left: to measure it), each place
    lending its score to its nearest touchable place, over 1 + the travel from row last (mm)
    over the face's extent; where every score is 0, the largest posterior spread; never a row
    already measured. travel(last): (M,) mm from row last to every place, inf where the probe
    cannot go (None: straight)."""
    score = _lent(candidates, found.beyond if seek_excess else found.beyond * (1.0 - found.beyond))
    if last is not None:
        moved = np.linalg.norm(candidates.points - candidates.points[last], axis=1) if travel is None else travel(last)
        goes = np.isfinite(moved)
        score = np.where(goes, score / (1.0 + np.where(goes, moved, 0.0) / candidates.extent), -np.inf)
    score[np.asarray(measured, dtype=int)] = -np.inf
    if not np.isfinite(score.max()) or score.max() <= 0.0:
        score = np.where(np.isfinite(score), _lent(candidates, found.spread), -np.inf)
    return int(np.argmax(score))


def _lent(candidates: Candidates, score: np.ndarray) -> np.ndarray:
    """(M,): at each touchable place the largest score (M,) of the places nearest it, -inf at
    the others."""
    lent = np.full(len(candidates), -np.inf)
    np.maximum.at(lent, candidates.nearest_touch, score)
    return lent


def spread_design(candidates: Candidates, n: int) -> np.ndarray:
    """(n,) touchable rows spread over the face: the farthest-point order in plane coordinates
    from the touchable place nearest the centre."""
    rows = np.flatnonzero(candidates.touchable)
    if n > len(rows):
        raise InputError(f"{n} first points asked for on a face with {len(rows)} places the probe may touch")
    x = candidates.x[rows]
    start = int(np.argmin(np.linalg.norm(x - candidates.x.mean(axis=0), axis=1)))
    chosen, distance = [start], np.linalg.norm(x - x[start], axis=1)
    for _ in range(n - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(x - x[chosen[-1]], axis=1))
    return rows[np.array(chosen)]
