"""Measuring until the verdict is decided: how likely a face conforms to its profile tolerance
given the points measured so far, and where the next touch tells most about it.

The face's deviation along its normals, e(x), is a Gaussian field over plane coordinates x (mm,
:class:`cmmsampling.fitting.series.PlaneCoordinates`): a rigid motion of the part on the table
(its six components along the candidates' rigid basis J, a broad prior) plus a Matern 5/2 field
whose length scale, variance and probing noise are fitted by maximum likelihood to the measured
deviations less their least-squares rigid motion (:func:`cmmsampling.fitting.series.fit_field`).
Given the measured deviations, posterior samples of e on every candidate place are each aligned
by the rigid motion that makes its largest deviation smallest (the minimum zone, as the
inspection aligns: :func:`minimum_zones`), and a sample's profile is twice that largest
deviation over the face (ISO 1101's zone about the nominal, no datums). With the
measurement's expanded uncertainty U, ISO 14253-1's rule decides per sample: conformance where
the profile + U <= t, non-conformance where the profile - U > t. P(conforms) is the smaller of
the shares under the fitted field and under one of ROUGHER times its length (a length fitted to
a few points is often too long, and the field between them then too sure: a pass must not rest
on it). The face is decided when one of
the two holds for all but a share ``risk`` of the samples; its verdict is then wrong with a
probability below risk under the model (Dumas et al., Precision Engineering 37, 2013: kriging
that confirms a large surface's conformity at a stated confidence with few points).

The next touch goes where the samples disagree most on whether the aligned deviation leaves
the half zone: each candidate's share q of samples beyond (t - U) / 2, scored q (1 - q) (the
AK-ILS learning function's spirit: the place whose side of the limit is least known), divided
by 1 + the travel from the last touch over the face's extent. Where the samples already say
"does not conform", the touch goes where q is largest, to measure the excess itself.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import cho_factor, cho_solve, eigh

from ..fitting.series import FieldFit, fit_field, matern
from ..geometry.validation import InputError

# Posterior samples of the field drawn per decision; the fewest points a field is fitted from
# (the six rigid motions and three hyper-parameters need more); the rigid motion's prior spread,
# as a multiple of the largest measured deviation (plus the tolerance).
SAMPLES = 400
FEWEST_POINTS = 12
MOTION_SPREAD = 10.0
JITTER = 1e-12
# Rounds of Lawson's algorithm that bring each sample near its minimum zone.
LAWSON_STEPS = 30
# A pass must also hold for a field this much shorter in length than the fitted one (a length
# fitted to a few points can be too long, and the field between them too sure).
ROUGHER = 0.5


@dataclass(frozen=True)
class Candidates:
    """The places the probe may touch on a face: points (M, 3) mm on the nominal face, normals
    (M, 3) unit out of the material, x (M, 2) mm the face's plane coordinates there."""

    points: np.ndarray
    normals: np.ndarray
    x: np.ndarray

    def __len__(self) -> int:
        return len(self.points)

    @property
    def extent(self) -> float:
        """mm: the largest side of the candidates' bounding box (at least 1e-9)."""
        return max(float(np.ptp(self.points, axis=0).max()), 1e-9)

    def rigid_basis(self) -> np.ndarray:
        """(M, 6): each candidate's deviation along its normal per small rigid motion of the part
        (three shifts in mm, three turns in rad about the candidates' centroid scaled by the
        extent), columns of unit RMS."""
        arm = (self.points - self.points.mean(axis=0)) / self.extent
        basis = np.hstack([self.normals, np.cross(arm, self.normals)])
        return basis / np.maximum(np.sqrt((basis ** 2).mean(axis=0)), 1e-12)


@dataclass(frozen=True)
class Belief:
    """What the measured points say about the face: p_conform and p_nonconform, the shares of
    posterior samples that ISO 14253-1 judges conforming (profile + U <= t) and not (profile - U
    > t); profile: (S,) mm the samples' profiles; beyond: (M,) each candidate's share of samples
    whose aligned deviation leaves the half zone (t - U) / 2; spread: (M,) mm the aligned
    deviation's posterior standard deviation at each candidate."""

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


def belief(candidates: Candidates, rows: np.ndarray, deviations: np.ndarray, tolerance: float,
           uncertainty: float = 0.0, samples: int = SAMPLES, seed: int = 0) -> Belief:
    """The Belief of a face from deviations (n,) mm along the normals measured at candidate rows
    (n,) (FEWEST_POINTS at least), to the profile tolerance t mm with the expanded uncertainty U
    mm; seed: the posterior samples' random generator (the same inputs give the same belief)."""
    rows, d = np.asarray(rows, dtype=int), np.asarray(deviations, dtype=float)
    if len(rows) < FEWEST_POINTS:
        raise InputError(f"a face's belief needs {FEWEST_POINTS} measured points at least, got {len(rows)}")
    basis = candidates.rigid_basis()
    motion = np.linalg.lstsq(basis[rows], d, rcond=None)[0]
    field = fit_field(candidates.x[rows], d - basis[rows] @ motion)
    profile, aligned = _sampled_zones(candidates, basis, rows, d, field, tolerance, samples, seed)
    rougher = replace(field, length=ROUGHER * field.length)
    rough_profile = _sampled_zones(candidates, basis, rows, d, rougher, tolerance, samples, seed)[0]
    half = 0.5 * max(tolerance - uncertainty, 0.0)
    p_conform = min(np.mean(profile + uncertainty <= tolerance), np.mean(rough_profile + uncertainty <= tolerance))
    return Belief(float(p_conform), float(np.mean(profile - uncertainty > tolerance)),
                  profile, (np.abs(aligned) > half).mean(axis=0), aligned.std(axis=0))


def _sampled_zones(candidates: Candidates, basis: np.ndarray, rows: np.ndarray, d: np.ndarray, field: FieldFit,
                   tolerance: float, samples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(profiles (S,) mm, aligned samples (S, M) mm) of S posterior samples of the deviation at
    every candidate given d (n,) mm at rows, each at its minimum zone."""
    spread = MOTION_SPREAD * (np.abs(d).max() + tolerance)
    mean, covariance = _posterior(candidates, basis, rows, d, field, spread)
    # The rigid motions change no zone: their part of the field is left out before sampling.
    rigid_free = np.eye(len(candidates)) - basis @ np.linalg.pinv(basis)
    free_covariance = rigid_free @ covariance @ rigid_free.T
    values, vectors = eigh(0.5 * (free_covariance + free_covariance.T))
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    drawn = rigid_free @ mean + np.random.default_rng(seed).standard_normal((samples, len(values))) @ root.T
    return minimum_zones(drawn, basis)


def minimum_zones(fields: np.ndarray, basis: np.ndarray, steps: int = LAWSON_STEPS) -> tuple[np.ndarray, np.ndarray]:
    """(profiles (S,) mm, aligned fields (S, M) mm): each field (S, M) mm aligned by the rigid
    motion (basis (M, 6)) that makes its largest deviation smallest, by Lawson's reweighted least
    squares (steps rounds, all fields at once; each round's alignment is a real one, so the
    smallest zone found is never below the minimum zone), its profile twice that largest
    deviation (ISO 1101's zone about the nominal)."""
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


def _posterior(candidates: Candidates, basis: np.ndarray, rows: np.ndarray, d: np.ndarray, field: FieldFit,
               spread: float) -> tuple[np.ndarray, np.ndarray]:
    """(mean (M,) mm, covariance (M, M) mm^2) of the deviation at every candidate given d at rows:
    prior covariance the field's Matern plus spread^2 J J^T (the rigid motion), noise the
    field's."""
    prior = matern(candidates.x, candidates.x, field.length, field.variance) + spread ** 2 * basis @ basis.T
    measured = prior[np.ix_(rows, rows)] + (field.noise + JITTER) * np.eye(len(rows))
    factor = cho_factor(measured)
    across = prior[:, rows]
    return across @ cho_solve(factor, d), prior - across @ cho_solve(factor, across.T)


def next_row(candidates: Candidates, found: Belief, measured: np.ndarray, last: int | None,
             seek_excess: bool = False) -> int:
    """The candidate row to touch next: the largest q (1 - q) (q: found.beyond), or with
    seek_excess the largest q (where the zone is most likely left: to measure it), over 1 + the
    travel from row last (mm) over the face's extent; where every score is 0, the largest
    posterior spread; never a row already measured."""
    score = found.beyond.copy() if seek_excess else found.beyond * (1.0 - found.beyond)
    if last is not None:
        score = score / (1.0 + np.linalg.norm(candidates.points - candidates.points[last], axis=1) / candidates.extent)
    score[np.asarray(measured, dtype=int)] = -np.inf
    if not np.isfinite(score.max()) or score.max() <= 0.0:
        score = np.where(np.isfinite(score), found.spread, -np.inf)
    return int(np.argmax(score))


def spread_design(candidates: Candidates, n: int) -> np.ndarray:
    """(n,) candidate rows spread over the face: the farthest-point order in plane coordinates
    from the candidate nearest the centre."""
    if n > len(candidates):
        raise InputError(f"{n} first points asked for on a face with {len(candidates)} candidate places")
    start = int(np.argmin(np.linalg.norm(candidates.x - candidates.x.mean(axis=0), axis=1)))
    chosen, distance = [start], np.linalg.norm(candidates.x - candidates.x[start], axis=1)
    for _ in range(n - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(candidates.x - candidates.x[chosen[-1]], axis=1))
    return np.array(chosen)
