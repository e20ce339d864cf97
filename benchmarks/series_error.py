"""Sampling aimed at a series' error: how many points a next part needs, with and without the
series model.

    /usr/bin/python3 benchmarks/series_error.py

For each error kind (a wave, a bump near an edge, a twist; cmmsampling.simulated_series: each
part's sizes scattered by 20 %, its face offset and tilted, probing noise), the first PRIOR parts
of a simulated series on the reference face are measured densely (DENSE points, uniform
parametric) and the series model is built from their inspections; the NEXT parts after them are
measured at each N with uniform parametric, Halton and part_error points. Each next part's
error map (Inspection.deviation_map) with the model (prior = the first parts) and without it is
compared with the part's true error over a RASTER x RASTER raster of the face: RMS and largest
error (mm), and how often the map's profile (2 max |map|) gives the wrong verdict against a
tolerance (the median true profile of the next parts, so about half of them pass). Then, for
each RMS asked, the fewest N reaching it: part_error with the model against uniform parametric
without it (the goal: a quarter of the points or fewer); and at each N, part_error with the model
less uniform parametric with it, part by part (the same parts, the same probing noise' seeds):
its mean and standard error over the NEXT parts (the goal: never above). The kinds run on
separate processes, BLAS on one thread each. Prints figures; asserts nothing.
"""
import argparse
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import cmmsampling  # noqa: E402
from cmmsampling.inspection.simulate import SERIES_KINDS  # noqa: E402
from cmmsampling.strategies.registry import baseline  # noqa: E402
from cmmsampling.runtime.threads import blas_threads  # noqa: E402

PRIOR, NEXT, DENSE, RASTER = 3, 32, 400, 40
COUNTS = (4, 9, 16, 25, 36, 49, 64, 100)
TARGETS_UM = (2.0, 1.0, 0.75, 0.5)


def raster(face):
    """(RASTER^2, 2) uv over the face's parameter range."""
    u0, u1, v0, v1 = face.ParameterRange
    u, v = np.meshgrid(np.linspace(u0, u1, RASTER), np.linspace(v0, v1, RASTER), indexing="ij")
    return np.column_stack([u.ravel(), v.ravel()])


def layouts(face, series, strategies):
    """{(strategy, N): uv (N, 2)} of every strategy at every N (the same points for every next part)."""
    found = {}
    for name in strategies:
        for n in COUNTS:
            options = {"prior": series} if cmmsampling.STRATEGIES[name].requires else {}
            found[name, n] = cmmsampling.sample(face, n, name, occ_check=False, **options).uv
    return found


def judged(face, part, uv, series, grid, noise, seed):
    """(RMS with, RMS without, max with, max without, profile with, profile without) of one
    next part measured at uv, in mm."""
    inspection = cmmsampling.inspect(face, cmmsampling.measured_part(face, uv, part, noise, seed), alignment="none")
    truth = part.error(grid)
    maps = (inspection.deviation_map(grid, prior=series), inspection.deviation_map(grid))
    errors = [m - truth for m in maps]
    return (*(float(np.sqrt((e ** 2).mean())) for e in errors), *(float(np.abs(e).max()) for e in errors),
            *(2 * float(np.abs(m).max()) for m in maps))


def one_kind(kind, args, strategies):
    """The table of one error kind: (its lines, {(strategy, with model?): {N: mean RMS mm}},
    {N: (NEXT,) mm, part_error with the model less uniform parametric with it, part by part})."""
    with blas_threads(1):
        return _one_kind(cmmsampling.reference_face(), kind, args, strategies)


def _one_kind(face, kind, args, strategies):
    """:func:`one_kind` on face."""
    parts = cmmsampling.simulated_series(face, PRIOR + NEXT, kind, args.size, seed=args.seed)
    dense = cmmsampling.sample(face, DENSE, baseline(), occ_check=False).uv
    prior = [cmmsampling.inspect(face, cmmsampling.measured_part(face, dense, part, args.noise, seed=k),
                                 alignment="none") for k, part in enumerate(parts[:PRIOR])]
    series = cmmsampling.series_model(face, prior)
    grid = raster(face)
    truths = [2 * float(np.abs(part.error(grid)).max()) for part in parts[PRIOR:]]
    tolerance = float(np.median(truths))
    points = layouts(face, series, strategies)
    true_rms = np.mean([np.sqrt((p.error(grid) ** 2).mean()) for p in parts[PRIOR:]])
    lines = [f"\n{kind}: size {args.size} mm, {PRIOR} first parts x {DENSE} points, {NEXT} next parts, noise "
             f"{args.noise} mm; true RMS error {true_rms:.4f} mm; tolerance {tolerance:.4f} mm (median true profile)",
             f"RMS error of the error map, um (largest error um; wrong verdicts of the map's profile of the {NEXT} "
             "parts), with the series model | without",
             f"{'N':>4}  " + "  ".join(f"{cmmsampling.STRATEGIES[name].label:>38}" for name in strategies)]
    rms, differences = {}, {}
    for n in COUNTS:
        cells, with_model = [], {}
        for name in strategies:
            figures = np.array([judged(face, part, points[name, n], series, grid, args.noise, 100 + k)
                                for k, part in enumerate(parts[PRIOR:])])
            wrong = [int(((figures[:, 4 + w] <= tolerance) != (np.array(truths) <= tolerance)).sum()) for w in (0, 1)]
            for w, label in ((0, True), (1, False)):
                rms.setdefault((name, label), {})[n] = figures[:, w].mean()
            with_model[name] = figures[:, 0]
            cells.append(f"{1e3 * figures[:, 0].mean():5.2f} ({1e3 * figures[:, 2].mean():5.1f}; {wrong[0]}) | "
                         f"{1e3 * figures[:, 1].mean():5.2f} ({1e3 * figures[:, 3].mean():5.1f}; {wrong[1]})")
        differences[n] = with_model[strategies[-1]] - with_model[baseline()]
        lines.append(f"{n:>4}  " + "  ".join(f"{cell:>38}" for cell in cells))
    return lines, rms, differences


def fewest(figures, target_mm):
    """The fewest N whose mean RMS is at most target_mm, or None."""
    return next((n for n in COUNTS if figures[n] <= target_mm), None)


def summary(kind, rms, differences, strategies):
    """The points each RMS needs, part_error with the model against uniform parametric without;
    part_error against uniform parametric, both with the model, at equal N."""
    uniform, aimed = baseline(), strategies[-1]
    for target in TARGETS_UM:
        without = fewest(rms[uniform, False], target / 1e3)
        with_model = fewest(rms[aimed, True], target / 1e3)
        uniform_with = fewest(rms[uniform, True], target / 1e3)
        ratio = f"{without / with_model:.1f}x fewer" if without and with_model else "n/a"
        print(f"{kind}: RMS <= {target:g} um: uniform parametric without the model needs "
              f"{without or f'more than {COUNTS[-1]}'}, with it {uniform_with or f'more than {COUNTS[-1]}'}; "
              f"part_error with it {with_model or f'more than {COUNTS[-1]}'} ({ratio})")
    means = {n: float(values.mean()) for n, values in differences.items()}
    errors = {n: float(values.std(ddof=1) / np.sqrt(len(values))) for n, values in differences.items()}
    print(f"{kind}: part_error less uniform parametric, both with the model, um (mean over the {NEXT} parts, "
          "standard error): " + ", ".join(f"N = {n} {1e3 * means[n]:+.3f} ({1e3 * errors[n]:.3f})" for n in COUNTS))
    above = [n for n in COUNTS if means[n] > 0]
    beyond = [n for n in above if means[n] > 2 * errors[n]]
    if not above:
        print(f"{kind}: at every N part_error with the model is at most uniform parametric with it")
    else:
        print(f"{kind}: at equal N part_error with the model is above uniform parametric with it at N = "
              f"{', '.join(map(str, above))}; beyond two standard errors at "
              f"{'N = ' + ', '.join(map(str, beyond)) if beyond else 'none'}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=float, default=0.02, help="the error's size, mm")
    parser.add_argument("--noise", type=float, default=0.0005, help="probing noise, mm (standard deviation)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    strategies = [baseline(), "halton", "part_error"]
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        tables = list(pool.map(one_kind, SERIES_KINDS, [args] * len(SERIES_KINDS), [strategies] * len(SERIES_KINDS)))
    for kind, (lines, rms, differences) in zip(SERIES_KINDS, tables):
        print("\n".join(lines))
        summary(kind, rms, differences, strategies)


if __name__ == "__main__":
    main()
