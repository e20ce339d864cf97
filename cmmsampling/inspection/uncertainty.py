"""The uncertainty of a profile verdict, and the decision ISO 14253-1 takes with it.

The CMM's probing error (standard uncertainty u per point, mm, isotropic: an MPE_P read as the
bound of a rectangular distribution gives u = MPE_P / sqrt(3), GUM 4.3.7) is carried through
the whole chain by Monte Carlo (GUM Supplement 1): each trial adds independent normal errors to
every measured point, datum points included, re-associates every datum and re-fits the
toleranced surface in the order the inspection did, and takes the profile again. Each trial
solves its fits on the chain's linear model at the inspection's solution (the point-to-plane
model whose steps found it, exact for planes; for a curved face the error it makes is of the
order u^2 times the curvature, far below u): least squares in closed form for all trials at
once, the tangent and minimum-zone fits as one linear programme each.

The expanded uncertainty is U = k s with k = 2 and s the trials' standard deviation. The
trials run in batches until the Monte Carlo's own relative error of s (1/2 sqrt((kurtosis - 1)
/ n)) is below SAMPLING_ERROR, at most MAX_TRIALS. Seeded: the same call gives the same U.

ISO 14253-1's decision for a profile tolerance t (an upper limit): 'conforms' where profile + U
<= t, 'does not conform' where profile - U > t, else 'undecided'.
"""
from __future__ import annotations

import time

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.optimize import linprog

from .align import chebyshev_programme, tangent_choice

if TYPE_CHECKING:   # for the annotations only
    from .datums import Frame, Link

COVERAGE_FACTOR = 2.0
SAMPLING_ERROR = 0.05
BATCH = 250
MAX_TRIALS = 20000
# A run's Cancel is asked this often (trials) inside a batch's linear programmes.
CHECK_EVERY = 25
# The first CHECKED_TRIALS trials are solved again by the full nonlinear inspection where the
# caller gives one (a Recheck); where one of them differs from it by more than LINEAR_SLACK of U,
# the linear model does not hold there, and U is that of FULL_TRIALS full re-inspections.
CHECKED_TRIALS = 3
LINEAR_SLACK = 0.1
FULL_TRIALS = 200
# recheck(errors (P, 3) mm, along the CAD axes, on every point in the links' order) -> (F,) mm,
# each face's profile found by the whole inspection of the points with those errors added.
Recheck = Callable[[np.ndarray], np.ndarray]
CONFORMS, DOES_NOT_CONFORM, UNDECIDED = "conforms", "does not conform", "undecided"
DECISIONS = (CONFORMS, DOES_NOT_CONFORM, UNDECIDED)
NO_UNCERTAINTY = "no uncertainty given: the verdict takes the measured profile as exact"


@dataclass
class ProfileUncertainty:
    """The Monte Carlo's result. probing: u per point, mm; expanded: U = k s, mm, of the
    profile; faces: {face name: its U, mm}; trials: how many were run; mean_shift: mm, the
    trials' mean profile less the measured one (how much the probing error widens a profile on
    average); relative_error: the Monte Carlo's own relative error of U; seed; coverage: k;
    profiles: (trials,) mm, each trial's profile (None once saved and read back); checked: mm,
    the most one of the first CHECKED_TRIALS trials differed from the full inspection of the same
    points (None: not checked); full: U is that of FULL_TRIALS full re-inspections, the linear
    model having failed that check."""

    probing: float
    expanded: float
    faces: dict
    trials: int
    mean_shift: float
    relative_error: float
    seed: int
    coverage: float = COVERAGE_FACTOR
    notes: list = field(default_factory=list)
    profiles: np.ndarray | None = None
    checked: float | None = None
    full: bool = False

    def as_record(self) -> dict[str, Any]:
        """The figures as a JSON-friendly dict (the trials' profiles left out)."""
        return {key: value for key, value in vars(self).items() if key != "profiles"}

    @classmethod
    def from_record(cls, record: dict[str, Any]) -> ProfileUncertainty:
        """The ProfileUncertainty of :meth:`as_record`'s dict."""
        return cls(**record)

    def text(self) -> str:
        """'U = 0.0042 mm (k = 2; u = 0.001 mm per point, 750 Monte Carlo trials, its own error 3.1 %)'."""
        how = "full re-inspections" if self.full else "Monte Carlo trials"
        checked = ("" if self.checked is None or self.full else
                   f"; {CHECKED_TRIALS} of them met full re-inspections to {1000 * self.checked:.3f} um")
        return (f"U = {self.expanded:.4f} mm (k = {self.coverage:g}; probing u = {self.probing:g} mm per point, "
                f"{self.trials} {how}, their own error {100 * self.relative_error:.1f} %{checked})")


def decide(profile: float, expanded: float, tolerance: float) -> str:
    """ISO 14253-1's decision for a profile (mm) with expanded uncertainty U (mm) against an
    upper limit t (mm): CONFORMS (profile + U <= t), DOES_NOT_CONFORM (profile - U > t) or
    UNDECIDED."""
    if profile + expanded <= tolerance:
        return CONFORMS
    if profile - expanded > tolerance:
        return DOES_NOT_CONFORM
    return UNDECIDED


def profile_uncertainty(frame: Frame, owner: np.ndarray, names: list[str], probing: float, seed: int = 0,
                        check: Callable[[int], None] | None = None,
                        recheck: Recheck | None = None) -> ProfileUncertainty:
    """The ProfileUncertainty of a Frame (cmmsampling.inspection.datums: its Links, the datums'
    then the toleranced surface's, the last one's deviations from the zone's centre) under
    probing error u = probing mm per point and axis, taken along the outward normals each
    link's model holds (its Jacobian's shift columns).

    owner: (N,) int, the face of each toleranced point (the last link's rows); names: the faces' names;
    check: callable(trials done) before each batch and every CHECK_EVERY trials of a batch's
    linear programmes (it may raise to stop the run: the inspection's Cancel); recheck: the full
    inspection of points with errors added (a Recheck), which the first CHECKED_TRIALS trials
    must meet to LINEAR_SLACK of U, else U is that of FULL_TRIALS of it (None: no check)."""
    rng = np.random.default_rng(seed)
    normals = np.vstack([link.jacobian[:, 3:] for link in frame.links])
    faces = [np.flatnonzero(owner == index) for index in range(len(names))]
    profiles, first = np.empty((0, len(names))), None
    while True:
        done = len(profiles)
        asked = None if check is None else lambda trials: check(done + trials)
        if asked is not None:
            asked(0)
        noise = rng.normal(0.0, probing, size=(BATCH, len(normals), 3))
        first = noise[:CHECKED_TRIALS] if first is None else first
        profiles = np.vstack([profiles, trial_profiles(frame.links, np.einsum("tpi,pi->tp", noise, normals), faces,
                                                       asked)])
        error = relative_error(profiles.max(axis=1))
        if error <= SAMPLING_ERROR or len(profiles) >= MAX_TRIALS:
            break
    notes = [] if error <= SAMPLING_ERROR else [
        f"the Monte Carlo stopped at {MAX_TRIALS} trials with its own error {100 * error:.1f} %"]
    checked, full = None, False
    if recheck is not None:
        checked = float(np.abs(np.array([recheck(draw).max() for draw in first]) - profiles[:CHECKED_TRIALS].max(axis=1)).max())
        if checked > LINEAR_SLACK * COVERAGE_FACTOR * float(profiles.max(axis=1).std(ddof=1)):
            began = time.monotonic()
            profiles, full = _full_trials(recheck, rng, probing, len(normals), check), True
            error = relative_error(profiles.max(axis=1))
            notes = [f"the linear model's trials differed from full re-inspections by up to {checked:.2g} mm, more "
                     f"than {LINEAR_SLACK:g} of U: U is that of {FULL_TRIALS} full re-inspections "
                     f"({time.monotonic() - began:.0f} s)"]
    whole = profiles.max(axis=1)
    measured = 2.0 * float(np.abs(frame.links[-1].deviations).max())
    return ProfileUncertainty(probing, COVERAGE_FACTOR * float(whole.std(ddof=1)),
                              {name: COVERAGE_FACTOR * float(profiles[:, index].std(ddof=1))
                               for index, name in enumerate(names) if faces[index].size},
                              len(whole), float(whole.mean()) - measured, float(error), seed, notes=notes,
                              profiles=whole, checked=checked, full=full)


def _full_trials(recheck: Recheck, rng: np.random.Generator, probing: float, count: int,
                 check: Callable[[int], None] | None) -> np.ndarray:
    """(FULL_TRIALS, F) mm: each face's profile from full re-inspections of the points (count of
    them) with normal errors (probing mm per axis) drawn from rng; check(trials done) before each."""
    profiles = []
    for trial in range(FULL_TRIALS):
        if check is not None:
            check(trial)
        profiles.append(recheck(rng.normal(0.0, probing, size=(count, 3))))
    return np.array(profiles)


def relative_error(values: np.ndarray) -> float:
    """The relative standard error of the standard deviation of values (T,): 1/2 sqrt((b - 1)
    / T) with b their kurtosis (3 for a normal distribution); 0 where they do not vary."""
    spread = values.std()
    if spread == 0.0:
        return 0.0
    kurtosis = float((((values - values.mean()) / spread) ** 4).mean())
    return 0.5 * np.sqrt(max(kurtosis - 1.0, 0.0) / len(values))


def trial_profiles(links: list[Link], errors: np.ndarray, faces: list[np.ndarray],
                   check: Callable[[int], None] | None = None) -> np.ndarray:
    """(T, F) mm: each trial's profile per face (2 max |d - o| over its rows of the last link;
    faces: F arrays of row numbers), the links solved in order on their linear models with the
    errors (T, P) mm along the normals of all P points added to their deviations; check:
    callable(trials done) every CHECK_EVERY trials of a linear programme's link, or None."""
    twist = np.zeros((len(errors), 6))
    for link in links:
        deviations = link.deviations + errors[:, link.rows] + twist @ link.jacobian.T
        if link.held.shape[1] and link.criterion != "none":
            step = _solve(link.criterion, deviations, link.jacobian @ link.held, check)
            twist = twist + step @ link.held.T
            deviations = deviations + step @ (link.jacobian @ link.held).T
    reach = np.abs(deviations)
    return np.column_stack([2.0 * reach[:, rows].max(axis=1) if rows.size else np.zeros(len(reach))
                            for rows in faces])


def _solve(criterion: str, deviations: np.ndarray, jacobian: np.ndarray,
           check: Callable[[int], None] | None = None) -> np.ndarray:
    """(T, H): each trial's step x minimising the criterion of deviations (T, M) + jacobian (M,
    H) x: least squares for all trials at once, a linear programme per trial otherwise (check
    called with the trials done every CHECK_EVERY of them)."""
    if criterion in ("least_squares", "best_fit"):
        return -np.linalg.lstsq(jacobian, deviations.T, rcond=None)[0].T
    step = _tangent_programme if criterion == "tangent" else _chebyshev_programme
    steps = []
    for start in range(0, len(deviations), CHECK_EVERY):
        if check is not None and start:
            check(start)
        steps += [step(row, jacobian) for row in deviations[start:start + CHECK_EVERY]]
    return np.array(steps)


def _chebyshev_programme(deviations: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """x (H,) minimising max |d + J x| (d (M,), J (M, H)), unbounded (align's programme)."""
    return _solved(chebyshev_programme(deviations, jacobian, [(None, None)] * jacobian.shape[1]))


def _tangent_programme(deviations: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """x (H,) minimising max -(d + J x) with every d + J x <= 0 (minimise s, -s <= d + J x <= 0),
    the least squares among the solutions where they are many (align.tangent_choice), as the
    inspection chose its datum."""
    count, size = jacobian.shape
    upper = np.vstack([np.hstack([jacobian, np.zeros((count, 1))]), np.hstack([-jacobian, -np.ones((count, 1))])])
    solved = linprog(np.r_[np.zeros(size), 1.0], A_ub=upper, b_ub=np.concatenate([-deviations, deviations]),
                     bounds=[(None, None)] * size + [(0, None)], method="highs")
    step = _solved(solved.x[:size] if solved.success else None)
    return step + tangent_choice(deviations + jacobian @ step, jacobian)


def _solved(step: np.ndarray | None) -> np.ndarray:
    """A trial's step, or ArithmeticError where its programme had no solution."""
    if step is None:
        raise ArithmeticError("a Monte Carlo trial's fit has no solution")
    return step
