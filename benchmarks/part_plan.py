"""Part plans: parallel speed-up, and the points a tolerance needs with each strategy.

    /usr/bin/python3 benchmarks/part_plan.py speed      # a 20-face plan on 1 and 2 local
                                                        # processes and a 2-worker LocalCluster
    /usr/bin/python3 benchmarks/part_plan.py points     # total points for a tolerance: optimal
                                                        # against uniform parametric
    /usr/bin/python3 benchmarks/part_plan.py ventilator # every face of Ventilator.stp on 2 local
                                                        # processes and a 2-worker LocalCluster

Prints figures; asserts nothing. The 20 faces are rational and non-rational bicubic patches
made here from seeds; ``points`` also plans faces of ../shared/testdata/Ventilator.stp when the
file is there.
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import cmmsampling  # noqa: E402
from cmmsampling.geometry.surface import make_bspline_surface  # noqa: E402

VENTILATOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "testdata",
                          "Ventilator.stp")


def patch(seed):
    """A bicubic patch about 60 x 40 mm with random bumps; rational for odd seeds."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 60, 6), np.linspace(0, 40, 5), indexing="ij")
    z = 6 * np.sin(x / (10 + seed)) * np.cos(y / 9) + rng.normal(0, 1.0, x.shape)
    weights = rng.uniform(0.6, 1.8, x.shape) if seed % 2 else None
    return make_bspline_surface(np.stack([x, y, z], -1), (3, 3), weights=weights).toShape()


def twenty_faces():
    return [(f"Patch{seed}", patch(seed)) for seed in range(20)]


def timed(label, **arguments):
    start = time.perf_counter()
    plan = cmmsampling.plan(twenty_faces(), **arguments)
    seconds = time.perf_counter() - start
    print(f"{label:<28} {seconds:7.1f} s  {plan.n_total:5d} points  worst {plan.worst:.4f} mm", flush=True)
    return seconds, plan


def speed(args):
    import distributed

    settings = dict(tolerance=args.tolerance, strategy=args.strategy, grid=args.grid, edge_offset=1.5, n_max=200)
    print(f"20 faces, tolerance {args.tolerance} mm, {args.strategy}, grid {args.grid}, {os.cpu_count()} cores")
    one, first = timed("1 process (this one)", processes=1, **settings)
    two, second = timed("2 local processes", processes=2, **settings)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            dask, third = timed("2-worker Dask LocalCluster", scheduler=client, **settings)
    same = all(a.n == b.n == c.n for a, b, c in zip(first.faces, second.faces, third.faces))
    print(f"speed-up: 2 processes {one / two:.2f}x, LocalCluster {one / dask:.2f}x; same plan: {same}")


def points(args):
    parts = [("built: 20 patches", twenty_faces(), None)]
    if os.path.isfile(VENTILATOR):
        import Part

        parts.append(("Ventilator.stp", Part.read(VENTILATOR), args.ventilator_faces))
    print(f"tolerance {args.tolerance} mm, grid {args.grid}, optimal time limit {args.time_limit} s per run")
    for name, shape, faces in parts:
        totals = {}
        for strategy, options in (("uniform_parametric", {}), ("optimal", {"time_limit": args.time_limit})):
            start = time.perf_counter()
            plan = cmmsampling.plan(shape, tolerance=args.tolerance, strategy=strategy, faces=faces, grid=args.grid,
                                    n_max=args.n_max, **options)
            met = [f for f in plan.faces if f.met]
            totals[strategy] = {f.name: f.n for f in met}
            print(f"{name:<20} {strategy:<20} {plan.n_total:5d} points, {len(met)} of {len(plan.faces)} faces "
                  f"meet it, {len(plan.refused)} hold none, {time.perf_counter() - start:.0f} s", flush=True)
            print(plan.table(), flush=True)
        summarise(name, totals, args.n_max)


def ventilator(args):
    """The whole Ventilator to a tolerance with each strategy asked, on 2 local processes (and
    on a 2-worker LocalCluster with --dask): seconds, points, faces that meet it, faces that hold
    none; the per-face times (median, 90th percentile, the slowest and what it ran)."""
    if not os.path.isfile(VENTILATOR):
        print(f"{VENTILATOR} is not there: nothing to plan")
        return
    import Part

    shape = Part.read(VENTILATOR)
    print(f"Ventilator.stp: {len(shape.Faces)} faces, tolerance {args.tolerance} mm, grid {args.grid}, "
          f"optimal time limit {args.time_limit} s per run, {os.cpu_count()} cores")
    for strategy in args.strategies.split(","):
        options = {"time_limit": args.time_limit} if strategy == "optimal" else {}
        ways = [("2 local processes", {"processes": 2})]
        if args.dask:
            ways.append(("2-worker Dask LocalCluster", {"scheduler": "local"}))
        for label, where in ways:
            plan_whole(shape, strategy, label, where, args, options)


def plan_whole(shape, strategy, label, where, args, options):
    """Plan every face of shape one way and print what the ventilator benchmark prints."""
    if where.get("scheduler") == "local":
        import distributed

        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster, distributed.Client(cluster) as client:
            return plan_whole(shape, strategy, label, {"scheduler": client}, args, options)
    start = time.perf_counter()
    plan = cmmsampling.plan(shape, tolerance=args.tolerance, strategy=strategy, grid=args.grid, n_max=args.n_max,
                            **where, **options)
    seconds = time.perf_counter() - start
    met = sum(1 for face in plan.faces if face.met)
    print(f"{strategy:<20} {label:<28} {seconds:7.0f} s  {plan.n_total:6d} points  {met} of {len(plan.faces)} "
          f"faces meet it, {len(plan.refused)} hold none", flush=True)
    times = np.array([face.seconds for face in plan.faces])
    slowest = plan.faces[int(times.argmax())]
    tried = ", ".join(f"{t.n}: {t.seconds:.1f} s" for t in slowest.tried)
    print(f"  per face: median {np.median(times):.2f} s, 90th percentile {np.percentile(times, 90):.2f} s, "
          f"slowest {slowest.name} {times.max():.1f} s ({slowest.area:.0f} mm^2, N tried {tried or 'none'}; "
          f"{slowest.line})", flush=True)
    copies = np.array([bool(face.copy_of) for face in plan.faces])
    print(f"  {copies.sum()} faces are rigid copies that took their original's points ({times[copies].sum():.0f} s "
          f"of the faces' {times.sum():.0f} s); every other face ran a search of its own", flush=True)


def summarise(name, totals, n_max):
    """Print the points each strategy needs, and the ratio: on the faces both meet, and over
    all faces counting a face uniform parametric does not meet as n_max + 1 (it needs more:
    none of the N tried up to n_max met), which makes that ratio a lower bound."""
    uniform, optimal = totals["uniform_parametric"], totals["optimal"]
    both = set(uniform) & set(optimal)
    if both:
        on_both = sum(uniform[f] for f in both), sum(optimal[f] for f in both)
        print(f"{name}: on the {len(both)} faces both meet, uniform parametric needs {on_both[0]} points, "
              f"optimal {on_both[1]}: {on_both[0] / on_both[1]:.2f}x", flush=True)
    missed = set(optimal) - set(uniform)
    if missed and len(optimal) == len(set(uniform) | set(optimal)):
        at_least = sum(uniform.values()) + len(missed) * (n_max + 1)
        print(f"{name}: optimal meets it on all {len(optimal)} faces with {sum(optimal.values())} points; uniform "
              f"parametric misses it on {len(missed)} with up to {n_max} points, so it needs at least {at_least}: "
              f"at least {at_least / sum(optimal.values()):.2f}x", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=["speed", "points", "ventilator"])
    parser.add_argument("--strategies", default="uniform_parametric,optimal")
    parser.add_argument("--dask", action="store_true", help="ventilator: also on a 2-worker LocalCluster")
    parser.add_argument("--tolerance", type=float, default=0.05)
    parser.add_argument("--strategy", default="uniform_parametric")
    parser.add_argument("--grid", type=int, default=30)
    parser.add_argument("--time-limit", type=float, default=5.0)
    parser.add_argument("--n-max", type=int, default=200)
    parser.add_argument("--ventilator-faces", type=lambda t: [int(k) for k in t.split(",")],
                        default=[11, 61, 101, 151, 201, 251])
    args = parser.parse_args()
    {"speed": speed, "points": points, "ventilator": ventilator}[args.what](args)


if __name__ == "__main__":
    main()
