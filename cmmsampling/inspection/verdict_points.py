"""How many points a verdict needs: the profile's uncertainty from sampling.

A profile measured at N points is the width of the zone that holds those N: where the points
miss the part's highest and lowest places the profile comes out narrower than the part's own.
That gap is a second uncertainty beside the CMM's probing error (cmmsampling.inspection.
uncertainty), one more points shrink. It is found on simulated parts: each a smooth form error
of the size expected (cmmsampling.inspection.simulate's waves, sized by the face, one field per
part whatever the points), its true profile the minimum zone of the face's dense raster and
edge nodes, its sampled profile the minimum zone of the N planned points on the same part. The
gaps have a long tail (a part whose peak falls between the points), so the uncertainty from
sampling is their COVERAGE quantile over the simulated parts (95 %, as U's k = 2), and the points
a verdict needs are the fewest N tried whose quantile is below a share of the tolerance.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..formats.pointset import PointSet
from ..geometry.freecad_env import import_part
from ..geometry.validation import InputError, check_real
from ..strategies.face_setup import reused
from ..strategies.registry import baseline
from ..strategies.sampling import sample
from .align import align
from .closest import FaceCloser, dense_nodes
from .simulate import form_waves

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part
else:
    Part = import_part()

# The counts of points tried, the simulated parts and the share of the tolerance by default;
# the quantile of the gaps taken as the uncertainty from sampling.
COUNTS = (9, 16, 25, 36, 49, 64, 81, 100, 144, 196)
PARTS = 40
SHARE = 0.1
COVERAGE = 0.95
MIN_PARTS = 20


@dataclass
class VerdictPoints:
    """What points_for_verdict found. n: the fewest points tried whose sampling uncertainty (the
    COVERAGE quantile of the gaps) stays below share x tolerance (None where none of counts
    does); counts: the N tried; gaps: (len(counts), parts) mm, the true profile less the sampled
    one per N and simulated part; true_profiles: (parts,) mm; tolerance, share, form_error (mm),
    strategy."""

    n: int | None
    counts: tuple
    gaps: np.ndarray
    true_profiles: np.ndarray
    tolerance: float
    share: float
    form_error: float
    strategy: str

    @property
    def uncertainties(self) -> np.ndarray:
        """(len(counts),) mm: each N's uncertainty from sampling, the COVERAGE quantile of its gaps."""
        return np.quantile(self.gaps, COVERAGE, axis=1)

    def text(self) -> str:
        """The finding in a line, with the uncertainty from sampling of each N tried."""
        limit = self.share * self.tolerance
        table = ", ".join(f"{count}: {gap:.4f}" for count, gap in zip(self.counts, self.uncertainties))
        found = (f"{self.n} {self.strategy} points keep the profile's sampling gap below {limit:g} mm"
                 if self.n is not None else f"no N up to {self.counts[-1]} keeps the sampling gap below {limit:g} mm")
        return (f"{found} ({100 * self.share:g} % of the tolerance {self.tolerance:g} mm) on {self.gaps.shape[1]} "
                f"simulated parts with a {self.form_error:g} mm form error; the gap's {100 * COVERAGE:g} % quantile "
                f"(mm) per N: {table}")


def points_for_verdict(face: Part.Face, tolerance: float, form_error: float, *, share: float = SHARE,
                       strategy: str | None = None, counts: tuple = COUNTS, parts: int = PARTS, seed: int = 0,
                       alignment: str = "min_max") -> VerdictPoints:
    """The VerdictPoints of a face (Part.Face): the fewest N of ``counts`` that ``strategy`` (None:
    the registry's baseline, uniform parametric) places so that, on ``parts`` simulated parts with a form error of at most form_error mm
    (seeded from seed), the profile the N points give (aligned by ``alignment``) misses the
    part's true profile by less than share x tolerance (tolerance mm) on COVERAGE of the parts."""
    strategy = baseline() if strategy is None else strategy
    tolerance = check_real("tolerance", tolerance, above=0.0)
    form_error = check_real("form_error", form_error, above=0.0)
    share = check_real("share", share, above=0.0)
    counts = tuple(sorted(set(int(count) for count in counts)))
    if not counts or counts[0] < 4 or int(parts) < MIN_PARTS:
        raise InputError(f"points_for_verdict needs counts of at least 4 points and at least {MIN_PARTS} simulated "
                         "parts (for the gaps' 95 % quantile)")
    with reused():
        closer = FaceCloser(face)
        planned = [PointSet.from_result(sample(face, count, strategy, seed=seed, occ_check=False)) for count in counts]
    dense_points, dense_normals = dense_nodes(closer)
    fields = [form_waves(dense_points, form_error, seed + part) for part in range(int(parts))]
    true = np.array([zone_width(dense_points + field(dense_points)[:, None] * dense_normals, closer, alignment)
                     for field in fields])
    gaps = np.array([[truth - zone_width(points.points + field(points.points)[:, None] * points.normals, closer,
                                         alignment) for truth, field in zip(true, fields)] for points in planned])
    enough = np.flatnonzero(np.quantile(gaps, COVERAGE, axis=1) < share * tolerance)
    return VerdictPoints(counts[enough[0]] if enough.size else None, counts, gaps, true, tolerance, share,
                         form_error, strategy)


def zone_width(points: np.ndarray, closer: FaceCloser, alignment: str) -> float:
    """mm: the profile 2 max |d| of points (M, 3) mm on the face closer measures, aligned by
    ``alignment`` from where they are."""
    return 2.0 * float(np.abs(align(points, closer, alignment).deviations).max())
