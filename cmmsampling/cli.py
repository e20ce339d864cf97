"""Command line: sample faces headless with ``/usr/bin/python3 -m cmmsampling`` or ``freecadcmd``."""
import argparse
import sys
import time

from . import STRATEGIES, reference_face, sample

DESCRIPTION = """Where should a CMM's contact probe touch a free-form face?

Places N probe points on a face with a sampling strategy, fits a least-squares B-spline
(the substitute geometry) to them and reports its deviation from the CAD face in mm."""


def build_parser():
    """The argument parser with its sub-commands."""
    parser = argparse.ArgumentParser(prog="python -m cmmsampling", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    demo = commands.add_parser(
        "demo", help="sample the built-in reference surface with every strategy and print a table")
    demo.add_argument("-n", "--points", type=int, default=81, help="probe points per strategy (default 81)")
    demo.add_argument("--iterations", type=int, default=3000,
                      help="PSO iterations (default 3000, the paper's)")
    demo.add_argument("--population", type=int, default=25, help="PSO particles (default 25, the paper's)")
    demo.add_argument("--seed", type=int, default=0, help="seed of the random parts (default 0)")
    return parser


class TerminalProgress:
    """A one-line progress bar on stderr for an optimiser run of ``total`` iterations."""

    def __init__(self, label, total, stream=sys.stderr, every_s=0.2):
        self.label, self.total, self.stream, self.every_s = label, total, stream, every_s
        self._last = 0.0

    def __call__(self, iteration, best):
        now = time.monotonic()
        if now - self._last >= self.every_s or iteration == self.total:
            self._last = now
            done = int(30 * iteration / self.total)
            self.stream.write(f"\r{self.label} [{'#' * done}{'.' * (30 - done)}] "
                              f"{iteration}/{self.total} best max {best:.4f} mm")
            if iteration == self.total:
                self.stream.write("\n")
            self.stream.flush()
        return False


def format_table(results):
    """Fixed-width table of results: strategy, max/mean/RMS (mm), ratio to uniform, time (s)."""
    uniform = next((r.deviation.maximum for r in results if r.strategy == "uniform_parametric"), None)
    lines = [f"{'strategy':<20} {'N':>4} {'max mm':>9} {'mean mm':>9} {'RMS mm':>9} "
             f"{'OCC max':>9} {'x uniform':>9} {'time s':>8}"]
    for r in results:
        d = r.deviation
        ratio = d.maximum / uniform if uniform else float("nan")
        lines.append(f"{r.strategy:<20} {r.n:>4} {d.maximum:>9.4f} {d.mean:>9.4f} {d.rms:>9.4f} "
                     f"{d.occ_maximum:>9.4f} {ratio:>9.3f} {r.timings['total_s']:>8.2f}")
    return "\n".join(lines)


def run_demo(args):
    """Every strategy on the reference surface; PSO with the paper's parameters."""
    face = reference_face()
    print(f"Reference surface: degree 5 x 5, 9 x 9 poles, 100 x 100 mm; N = {args.points}, "
          "substitute: bicubic, default poles; grid 60 x 60")
    results = []
    for name, strategy in STRATEGIES.items():
        options = {}
        if name == "pso":
            options = {"iterations": args.iterations, "population": args.population,
                       "progress": TerminalProgress("PSO", args.iterations)}
        results.append(sample(face, args.points, name, seed=args.seed, **options))
    print(format_table(results))
    return 0


def main(argv=None):
    """Entry point; returns the process exit code (2 for bad input)."""
    args = build_parser().parse_args(argv)
    try:
        return {"demo": run_demo}[args.command](args)
    except (ValueError, TypeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
