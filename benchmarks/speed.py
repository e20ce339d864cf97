"""Speed of the fitness evaluation and of the paper's PSO on the reference surface.

Prints, in one run:
  * the paper's full PSO (N = 81, population 25, 3000 iterations, 60 x 60 grid) with the default
    processes (the swarm split over two where measured faster), always two, and one: wall time (median of three), fitness evaluations per second, best
    maximum deviation, and the worker process's start-up apart;
  * the same fitness for the same swarms three ways: batched (this engine), one particle at a time
    in a Python loop, and through pyswarms' GlobalBestPSO (if installed), with ratios;
  * time per PSO iteration against N, grid size and substitute pole count;
  * one against two BLAS threads for the batched fitness;
  * peak memory (resident set) of this process and of the worker.
With --beside-busy all of it runs beside a CPU-bound process (a desktop is never idle).
Run with benchmarks/run.sh (which installs pyswarms in a separate virtual environment).
"""
import argparse
import contextlib
import subprocess
import logging
import os
import resource
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import cmmsampling  # noqa: E402
from cmmsampling.fitting.deviation import curvature_matrices  # noqa: E402
from cmmsampling.strategies.sampling import make_problem  # noqa: E402
from cmmsampling.runtime.threads import ThreadpoolController, blas_threads  # noqa: E402


def timed(function, repeat=1):
    """(seconds per call, last value) of ``function`` called ``repeat`` times."""
    start = time.perf_counter()
    for _ in range(repeat):
        value = function()
    return (time.perf_counter() - start) / repeat, value


def full_runs(face, repeat=3):
    """The paper's full run on two processes and on one, medians of ``repeat`` runs each.

    The worker process is started once per session (as in the workbench); its start-up is
    timed apart, with a two-iteration run.
    """
    seconds, _ = timed(lambda: cmmsampling.sample(face, 25, "pso", iterations=2, occ_check=False, workers=2))
    print(f"Worker process start-up (once per session): {seconds:.2f} s")
    print(f"The paper's PSO: N = 81, population 25, 3000 iterations, 60 x 60 grid, seed 0; median of {repeat}")
    print(f"{'processes':>10} {'wall s':>8} {'min s':>7} {'max s':>7} {'evals/s':>9} {'best max mm':>18}")
    medians = {}
    for label, workers in (("default", None), ("2", 2), ("1", 1)):
        runs = [timed(lambda: cmmsampling.sample(face, 81, "pso", occ_check=False, workers=workers))
                for _ in range(repeat)]
        times = sorted(seconds for seconds, _ in runs)
        result = runs[0][1]
        medians[label] = median = times[len(times) // 2]
        print(f"{label:>10} {median:>8.2f} {times[0]:>7.2f} {times[-1]:>7.2f} "
              f"{result.evaluations / median:>9.0f} {result.deviation.maximum:>18.12f}")
    print(f"against one process: the default (2 where measured faster) {medians['default'] / medians['1']:.2f}x, "
          f"always 2 {medians['2'] / medians['1']:.2f}x")


def swarm_positions(problem, iterations, population=25, seed=1):
    """Random swarms: (iterations, population, N, 2) inside the face's box."""
    rng = np.random.default_rng(seed)
    shape = (iterations, population, problem.n, 2)
    return problem.domain.lower + rng.random(shape) * (problem.domain.upper - problem.domain.lower)


def straightforward_fitness(problem, uv):
    """The fitness as a plain implementation computes it, one point set uv: (N, 2) at a time.

    The face's points one by one from OpenCASCADE, scipy's B-spline design matrices, the smoothed
    least-squares fit by np.linalg.lstsq, the fitted surface on the grid, and the expanded
    deviation n . e - e^T K e / 2 at each node with full 3 x 3 matrices K (the nodes, their
    normals, K and the grid's design matrices computed once, as any implementation would), and
    the edge nodes' offsets along their normal and conormal.
    """
    from scipy.interpolate import BSpline

    space, face = problem.space, problem.model.face
    points = np.array([tuple(face.valueAt(u, v)) for u, v in uv])
    bu = BSpline.design_matrix(uv[:, 0], space.uknots, space.degrees[0]).toarray()
    bv = BSpline.design_matrix(uv[:, 1], space.vknots, space.degrees[1]).toarray()
    rows = np.einsum("ni,nj->nij", bu, bv).reshape(len(uv), -1)
    weight = np.sqrt(space.smoothing * len(uv) / space.size)
    lhs = np.vstack([rows, weight * np.linalg.cholesky(space.regulariser).T])
    rhs = np.vstack([points, np.zeros((space.size, 3))])
    poles = np.linalg.lstsq(lhs, rhs, rcond=None)[0].reshape(space.poles + (3,))
    grid_u, grid_v, nodes, normals, curvature, counted = _straightforward_grid(problem)
    error = np.einsum("ia,abc,jb->ijc", grid_u, poles, grid_v) - nodes
    deviation = (error * normals).sum(-1) - 0.5 * np.einsum("ijc,ijcd,ijd->ij", error, curvature, error)
    edges = problem.objective.nodes
    offset = space.evaluate(poles, edges.edge_uv) - edges.edge_points
    across = np.concatenate([edges.edge_normals[:, None, :], edges.edge_across], axis=1)
    at_edges = np.sqrt((np.einsum("ec,ekc->ek", offset, across) ** 2).sum(-1))
    return max(np.abs(deviation[counted]).max(), at_edges.max(initial=0.0))


def _straightforward_grid(problem, cache={}):
    """The plain implementation's fixed arrays, computed once: the grid's design matrices, the
    objective's nodes (g_u, g_v, 3) mm, normals, K (g_u, g_v, 3, 3) 1/mm and counted mask."""
    if id(problem) not in cache:
        from scipy.interpolate import BSpline

        space, grid, feet = problem.space, problem.grid, problem.objective.nodes
        u, v = grid.uv[:, 0, 0], grid.uv[0, :, 1]
        curvature = curvature_matrices(problem.model, feet.uv.reshape(-1, 2), feet.normals.reshape(-1, 3))
        cache[id(problem)] = (BSpline.design_matrix(u, space.uknots, space.degrees[0]).toarray(),
                              BSpline.design_matrix(v, space.vknots, space.degrees[1]).toarray(),
                              feet.points, feet.normals, curvature.reshape(feet.points.shape + (3,)),
                              feet.counted)
    return cache[id(problem)]


def three_ways(face, iterations):
    """The same fitness for the same swarms: batched, looped and through pyswarms."""
    problem = make_problem(face, 81, workers=1)
    objective = problem.objective
    swarms = swarm_positions(problem, iterations)
    evaluations = swarms.shape[0] * swarms.shape[1]
    plain = swarms[: max(1, iterations // 10)]
    with blas_threads(1):
        batched, _ = timed(lambda: [objective(s) for s in swarms])
        looped, _ = timed(lambda: [[objective(p[None]) for p in s] for s in swarms])
        straight, _ = timed(lambda: [[straightforward_fitness(problem, p) for p in s] for s in plain])
        library = _pyswarms_time(objective, problem, iterations)
    # the engine fits a swarm at its parameters rounded to the fits' lattice
    # (cmmsampling.fitting.lattice): the plain fitness is checked there
    rounded = objective.lattice.rounded if objective.lattice is not None else np.asarray
    check = [straightforward_fitness(problem, p) for p in rounded(swarms[0, :3])]
    # the engine's swarm fitness runs in single precision: 1e-5 relative
    assert np.allclose(check, objective(swarms[0, :3]), rtol=1e-5), "the plain fitness disagrees"
    straight *= iterations / len(plain)
    print(f"\nFitness of {evaluations} point sets (N = 81), {iterations} iterations of 25 particles, one process")
    print(f"{'way':<44} {'s':>8} {'evals/s':>9} {'x batched':>10}")
    rows = [("batched (this engine)", batched),
            ("this engine, one particle at a time", looped),
            ("plain per-particle (OCC points, scipy, lstsq)", straight)]
    if library is not None:
        rows.append(("pyswarms GlobalBestPSO, batched fitness", library))
    for name, seconds in rows:
        print(f"{name:<44} {seconds:>8.3f} {evaluations / seconds:>9.0f} {seconds / batched:>10.1f}")
    print(f"(the plain way timed on {len(plain) * 25} point sets and scaled)")
    if library is None:
        print("(pyswarms not installed: run benchmarks/run.sh)")


def _pyswarms_time(objective, problem, iterations):
    """Seconds for pyswarms' GlobalBestPSO with the same fitness, or None without pyswarms.

    pyswarms writes a report.log into the working folder when it is imported and when it runs;
    both happen in a temporary folder.
    """
    here = os.getcwd()
    os.chdir(tempfile.mkdtemp())
    try:
        import pyswarms

        logging.getLogger("pyswarms").setLevel(logging.ERROR)
        dimensions = 2 * problem.n
        bounds = (np.tile(problem.domain.lower, problem.n), np.tile(problem.domain.upper, problem.n))
        optimizer = pyswarms.single.GlobalBestPSO(25, dimensions, {"c1": 2.0, "c2": 2.0, "w": 0.5},
                                                  bounds=bounds)
        cost = lambda x: objective(x.reshape(len(x), problem.n, 2))  # noqa: E731
        seconds, _ = timed(lambda: optimizer.optimize(cost, iters=iterations, verbose=False))
        return seconds
    except ImportError:
        return None
    finally:
        os.chdir(here)


def per_iteration(face, n, grid, poles, iterations):
    """Milliseconds of fitness per PSO iteration (25 particles, one process)."""
    problem = make_problem(face, n, grid=grid, fit_poles=poles, workers=1)
    swarms = swarm_positions(problem, iterations)
    with blas_threads(1):
        problem.objective(swarms[0])
        seconds, _ = timed(lambda: [problem.objective(s) for s in swarms])
    return 1e3 * seconds / iterations


def scaling(face, iterations):
    """Tables of time per iteration against N, grid and pole count."""
    print("\nTime per iteration (25 particles, one process), ms; default poles grow with N")
    print(f"{'N':>5} {'poles':>6} {'ms':>8} {'ms/point':>9} {'6x6: ms':>8} {'ms/point':>9}")
    for n in (25, 49, 81, 144, 256, 400):
        ms = per_iteration(face, n, 60, None, iterations)
        fixed = per_iteration(face, n, 60, 6, iterations)
        poles = cmmsampling.default_pole_count(n)
        print(f"{n:>5} {poles:>6} {ms:>8.2f} {ms / n:>9.4f} {fixed:>8.2f} {fixed / n:>9.4f}")
    print(f"{'grid':>5} {'ms':>8}   (N = 81)")
    for grid in (30, 60, 120):
        print(f"{grid:>5} {per_iteration(face, 81, grid, None, iterations):>8.2f}")
    print(f"{'poles':>5} {'ms':>8}   (N = 81, grid 60)")
    for poles in (4, 6, 8, 10):
        print(f"{poles:>5} {per_iteration(face, 81, 60, poles, iterations):>8.2f}")


def blas_effect(face, iterations):
    """Batched fitness with one and with two BLAS threads."""
    if ThreadpoolController is None:
        print("\n(threadpoolctl missing: BLAS threads not compared)")
        return
    problem = make_problem(face, 81, workers=1)
    swarms = swarm_positions(problem, iterations)
    print("\nBLAS threads for the batched fitness (N = 81, 25 particles)")
    for threads in (1, 2):
        with blas_threads(threads):
            seconds, _ = timed(lambda: [problem.objective(s) for s in swarms])
        print(f"{threads:>3} thread(s): {1e3 * seconds / iterations:.2f} ms per iteration")


def peak_memory():
    """Peak resident set of this process and of its finished or running children, MiB."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    from cmmsampling.runtime import parallel

    if parallel._worker is not None:
        with open(f"/proc/{parallel._worker.process.pid}/status") as status:
            line = next(line for line in status if line.startswith("VmHWM"))
        children = max(children, int(line.split()[1]) / 1024)
    print(f"\nPeak memory: {own:.0f} MiB this process, {children:.0f} MiB worker process")


@contextlib.contextmanager
def busy_neighbour(wanted):
    """While active and ``wanted``, one CPU-bound process runs beside this one."""
    if not wanted:
        yield
        return
    neighbour = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        yield
    finally:
        neighbour.kill()
        neighbour.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--iterations", type=int, default=200, help="iterations for the comparisons")
    parser.add_argument("--skip-full", action="store_true", help="skip the paper's full runs")
    parser.add_argument("--beside-busy", action="store_true", help="run beside a CPU-bound process")
    args = parser.parse_args()
    face = cmmsampling.reference_face()
    print(f"numpy {np.__version__}, {os.cpu_count()} cores"
          + (", one CPU-bound process running beside" if args.beside_busy else ""))
    with busy_neighbour(args.beside_busy):
        if not args.skip_full:
            full_runs(face)
        three_ways(face, args.iterations)
        scaling(face, max(20, args.iterations // 4))
        blas_effect(face, args.iterations)
        peak_memory()


if __name__ == "__main__":
    main()
