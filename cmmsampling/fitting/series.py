"""The error of a series of parts: what repeats from part to part, and what the next part leaves open.

A CMM measures manufactured parts, whose surfaces depart from the CAD face by a machining error.
In series production much of that error repeats (a tool's deflection, a fixture's tilt, a worn
tool's bump near an edge), so the first parts, measured densely, tell where the next parts will
be wrong, and a few well-placed points pin down each next part (Poniatowska, Measurement 45, 2012:
a dense first part, a deviation model, the critical regions on the next; Gaussian-process sampling
of machining error, ASME MSEC 2018).

Every field here is a function of the face's parameters uv, through plane coordinates x in mm
(uv scaled by the face's mean lengths along u and v, :func:`mm_per_parameter`), so that one
length scale serves both directions.

* **One part** (:func:`fit_field`): Gaussian-process regression (kriging) of its signed deviations,
  a constant mean and a Matern 5/2 covariance whose length scale, variance and noise are chosen by
  maximum likelihood over a grid (:data:`LENGTH_STEPS` length scales, :data:`NOISE_RATIOS`). This
  is the error map of a part measured without a series model.
* **The series** (:class:`SeriesModel`): the earlier parts' fields f_k. The systematic error is
  their mean m; the next part's error is m plus a zero-mean Gaussian field whose covariance is
  the sum of: the part-to-part scatter the earlier parts showed (their fields less m, an empirical
  covariance of rank K - 1); a change of the systematic error's size (``SIZE_SCATTER`` times m, as
  a scaled copy); an offset and tilt of the whole face (a plane whose coefficients have the
  spread of the earlier parts' least-squares planes, at least ``PLANE_SHARE`` of their error);
  what no earlier part showed (a Matern field of the parts' median length scale with
  ``RESIDUAL_SHARE`` of their standard deviation); and the probing noise (the parts' mean fitted
  noise). The error map of a part given the series is that field's posterior mean at the points
  measured on it, and its posterior standard deviation says how well each place is known.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..geometry.validation import InputError

# Length scales tried by the maximum likelihood, log-spaced between half the points' typical
# spacing and twice the face's extent; noise variance as a share of the field's variance.
LENGTH_STEPS = 14
NOISE_RATIOS = (1e-6, 1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3)
# The series' covariance: a part's systematic error may be this much larger or smaller than the
# series' mean; a plane's coefficients vary at least this share of the parts' RMS error; what
# no earlier part showed has this share of their RMS error.
SIZE_SCATTER = 0.3
PLANE_SHARE = 0.1
RESIDUAL_SHARE = 0.1
SCATTER_INFLATION = 1.0
# Raster per direction over which a face's mean lengths and the parts' RMS errors are taken.
RASTER = 25
JITTER = 1e-10


def mm_per_parameter(model: Any, raster: int = 9) -> np.ndarray:
    """(2,) mm per unit of u and of v: the face's mean speed along each direction."""
    uv = model.raster((raster, raster)).reshape(-1, 2)
    d = model.derivatives(uv, 1)
    return np.array([np.linalg.norm(d[(1, 0)], axis=1).mean(), np.linalg.norm(d[(0, 1)], axis=1).mean()])


class PlaneCoordinates:
    """Plane coordinates (M, 2) mm of a face's parameters uv (M, 2): uv from the range's lower
    corner scaled by :func:`mm_per_parameter`."""

    def __init__(self, model: Any) -> None:
        self.lower = np.array([model.bounds[0], model.bounds[2]])
        self.scale = mm_per_parameter(model)

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        return (np.asarray(uv, float).reshape(-1, 2) - self.lower) * self.scale


def error_map(model: Any, uv: np.ndarray, deviations: np.ndarray, query: np.ndarray) -> np.ndarray:
    """One part's error map without a series: the kriging of deviations (N,) mm measured at uv
    (N, 2) (:func:`fit_field`), at query (Q, 2): (Q,) mm. model: the face's SurfaceModel."""
    plane = PlaneCoordinates(model)
    return fit_field(plane(uv), deviations)(plane(query))


def matern(a: np.ndarray, b: np.ndarray, length: float, variance: float) -> np.ndarray:
    """Matern 5/2 covariance between plane points a (A, 2) and b (B, 2) mm: (A, B) mm^2."""
    r = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1]) * (np.sqrt(5.0) / length)
    return variance * (1.0 + r + r * r / 3.0) * np.exp(-r)


@dataclass(frozen=True)
class FieldFit:
    """One part's deviation field by kriging: x: (M, 2) mm where it was measured; weights: (M,)
    the posterior mean's weights; mean: mm, its constant mean; length: mm; variance: mm^2 of the
    field; noise: mm^2 of the probing (and what the field does not follow)."""

    x: np.ndarray
    weights: np.ndarray
    mean: float
    length: float
    variance: float
    noise: float

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The field's posterior mean at plane points x (Q, 2) mm: (Q,) mm."""
        return self.mean + matern(np.asarray(x, float), self.x, self.length, self.variance) @ self.weights


def fit_field(x: np.ndarray, deviations: np.ndarray) -> FieldFit:
    """The FieldFit of deviations (M,) mm measured at plane points x (M, 2) mm, hyper-parameters
    by maximum likelihood (constant mean by generalised least squares, variance in closed form)."""
    x, d = np.asarray(x, float), np.asarray(deviations, float)
    if len(d) < 3:
        raise InputError(f"an error map needs at least 3 measured points on the face, got {len(d)}")
    if not (np.isfinite(x).all() and np.isfinite(d).all()):
        raise InputError("an error map needs finite points and deviations: drop the points the CMM did not measure")
    distance = np.sqrt(((x[:, None] - x[None]) ** 2).sum(-1))
    np.fill_diagonal(distance, np.inf)
    spacing = float(np.median(distance.min(1)))
    extent = float(np.ptp(x, axis=0).max())
    best: Any = None   # (log likelihood, mean, variance, length, ratio) of the best fit so far
    for length in np.geomspace(max(0.5 * spacing, 1e-3 * extent), 2.0 * max(extent, 1e-9), LENGTH_STEPS):
        base = matern(x, x, length, 1.0)
        for ratio in NOISE_RATIOS:
            found = _likelihood(base, ratio, d)
            if found is not None and (best is None or found[0] > best[0]):
                best = found + (length, ratio)
    if best is None:
        raise InputError(f"no error map fits these {len(d)} deviations (no covariance was positive definite): "
                         "check for repeated points")
    _, mean, variance, length, ratio = best
    factor = cho_factor(matern(x, x, length, variance) + (ratio * variance + JITTER) * np.eye(len(d)))
    return FieldFit(x, cho_solve(factor, d - mean), mean, float(length), float(variance), float(ratio * variance))


def _likelihood(base: np.ndarray, ratio: float, d: np.ndarray) -> tuple[float, float, float] | None:
    """(log likelihood, mean mm, variance mm^2) of d under correlation ``base`` (M, M) plus
    ``ratio`` noise, both scaled by the variance; None where the matrix is not positive definite."""
    try:
        factor = cho_factor(base + (ratio + JITTER) * np.eye(len(d)))
    except np.linalg.LinAlgError:
        return None
    ones = np.ones(len(d))
    solved = cho_solve(factor, np.column_stack([d, ones]))
    mean = float(ones @ solved[:, 0]) / float(ones @ solved[:, 1])
    residual = d - mean
    variance = max(float(residual @ (solved[:, 0] - mean * solved[:, 1])) / len(d), 1e-30)
    log_det = 2.0 * np.log(np.diag(factor[0])).sum()
    return -0.5 * len(d) * np.log(variance) - 0.5 * log_det, mean, variance


class SeriesModel:
    """The error of a series on one face, from its earlier parts (see the module docstring).

    model: the face's SurfaceModel; parts: per earlier part (at least one), (uv (M, 2) in the
    face's parameter range, signed deviations (M,) mm) of the points measured on it.
    """

    def __init__(self, model: Any, parts: Sequence[tuple[np.ndarray, np.ndarray]]) -> None:
        if not parts:
            raise InputError("a series model needs at least one earlier part's inspection: give prior=[...]")
        self.model, self.plane = model, PlaneCoordinates(model)
        self.fields = [fit_field(self.plane(uv), deviations) for uv, deviations in parts]
        raster = self.plane(model.raster((RASTER, RASTER)).reshape(-1, 2))
        self.centre = raster.mean(0)
        self.half = np.maximum(np.ptp(raster, axis=0) / 2.0, 1e-9)
        values = self._values(raster)
        rms = float(np.sqrt((values ** 2).mean()))
        coefficients = np.linalg.lstsq(self._plane_rows(raster), values, rcond=None)[0]
        spread = coefficients.var(axis=1, ddof=1) if len(self.fields) > 1 else np.zeros(3)
        self.plane_variances = np.maximum(spread, (PLANE_SHARE * rms) ** 2)
        self.length = float(np.median([field.length for field in self.fields]))
        self.residual_variance = (RESIDUAL_SHARE * rms) ** 2 + 1e-30
        self.noise = float(np.mean([field.noise for field in self.fields])) + 1e-30

    @property
    def parts(self) -> int:
        """How many earlier parts the model holds."""
        return len(self.fields)

    def _values(self, x: np.ndarray) -> np.ndarray:
        """(M, K) mm: every earlier part's field at plane points x (M, 2)."""
        return np.column_stack([field(x) for field in self.fields])

    def _plane_rows(self, x: np.ndarray) -> np.ndarray:
        """(M, 3) the plane's basis at x: 1 and the two coordinates scaled to [-1, 1]."""
        return np.column_stack([np.ones(len(x)), (x - self.centre) / self.half])

    def systematic(self, uv: np.ndarray) -> np.ndarray:
        """The systematic error at uv (M, 2): (M,) mm, the mean of the earlier parts' fields."""
        return self._values(self.plane(uv)).mean(1)

    def _features(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M, F) rows whose products give the covariance's low-rank part at plane points x."""
        values = self._values(x)
        mean = values.mean(1, keepdims=True)
        scatter = (values - mean) * np.sqrt(SCATTER_INFLATION / max(len(self.fields) - 1, 1))
        plane = self._plane_rows(x) * np.sqrt(self.plane_variances)
        return np.column_stack([scatter, SIZE_SCATTER * mean, plane]), mean[:, 0]

    def covariance(self, uv_a: np.ndarray, uv_b: np.ndarray) -> np.ndarray:
        """The next part's error covariance between uv_a (A, 2) and uv_b (B, 2): (A, B) mm^2."""
        a, b = self.plane(uv_a), self.plane(uv_b)
        return self._covariance(a, self._features(a)[0], b, self._features(b)[0])

    def _covariance(self, a: np.ndarray, features_a: np.ndarray, b: np.ndarray, features_b: np.ndarray) -> np.ndarray:
        """(A, B) mm^2 between plane points a (A, 2) and b (B, 2) whose :meth:`_features` are given."""
        return features_a @ features_b.T + matern(a, b, self.length, self.residual_variance)

    def _variance(self, features: np.ndarray) -> np.ndarray:
        """(Q,) mm^2: the prior variance at the plane points whose :meth:`_features` are given."""
        return (features ** 2).sum(1) + self.residual_variance

    def variance(self, uv: np.ndarray) -> np.ndarray:
        """The next part's error variance at uv (Q, 2) before any point is measured on it: (Q,) mm^2."""
        return self._variance(self._features(self.plane(uv))[0])

    def predict(self, uv: np.ndarray, deviations: np.ndarray,
                uv_query: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The error map of a part measured at uv (N, 2) with signed deviations (N,) mm, at
        uv_query (Q, 2): (mean (Q,) mm, standard deviation (Q,) mm of the error there)."""
        d = np.asarray(deviations, float)
        x, query = self.plane(uv), self.plane(uv_query)
        (features, prior), (measured, systematic) = self._features(query), self._features(x)
        own = self._variance(features)
        if len(d) == 0:
            return prior, np.sqrt(np.maximum(own, 0.0))
        among = self._covariance(x, measured, x, measured)
        factor = cho_factor(among + self.noise * np.eye(len(d)))
        cross = self._covariance(query, features, x, measured)
        mean = prior + cross @ cho_solve(factor, d - systematic)
        return mean, np.sqrt(np.maximum(own - (cross * cho_solve(factor, cross.T).T).sum(1), 0.0))


def greedy_design(series: SeriesModel, candidates: np.ndarray, n: int,
                  spaced_out: Callable[[int], Any] | None = None,
                  judged: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The n candidates that leave the next part's error least known on average, chosen one at
    a time: each the candidate whose measurement lowers the sum of the posterior variances over
    the judged places most (integrated mean squared error, the RMS the error map is judged by).

    series: a SeriesModel; candidates: (C, 2) feasible uv; judged: (Q, 2) uv spread over the
    whole face, where the error map is wanted (None: the candidates themselves); spaced_out:
    callable(index) -> the candidate indices too close to a chosen one (None: only the chosen
    one itself).
    Returns (chosen indices (n,) int, the posterior variances (Q,) mm^2 at the judged places after them).
    Raises InputError when fewer than n candidates can be chosen.
    """
    judged = candidates if judged is None else judged
    # Rows: the judged places, then the candidates; columns: the candidates.
    posterior = series.covariance(np.vstack([judged, candidates]), candidates)
    count = len(judged)
    variances = series.variance(judged)
    free = np.ones(len(candidates), dtype=bool)
    chosen: list[int] = []
    for _ in range(n):
        if not free.any():
            raise InputError(f"only {len(chosen)} of {n} points fit on the face's feasible domain at the "
                             "strategy's spacing; lower n or min_spacing")
        own = np.diag(posterior[count:])
        gain = np.where(free, (posterior[:count] ** 2).sum(0) / (own + series.noise), -np.inf)
        best = int(np.argmax(gain))
        column = posterior[:, best].copy()
        posterior -= np.outer(column, column[count:]) / (column[count + best] + series.noise)
        variances -= column[:count] ** 2 / (column[count + best] + series.noise)
        chosen.append(best)
        free[best] = False
        if spaced_out is not None:
            free[spaced_out(best)] = False
    return np.array(chosen), np.maximum(variances, 0.0)
