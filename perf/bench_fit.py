"""Time the coefficient fit against the published formulation (dense P, cvxopt).

Each measurement runs in a fresh subprocess so that peak memory (max RSS above
the process's size before the fit, which includes C allocations that
tracemalloc cannot see) belongs to that method alone.  Problems: FLAME head
size (4580 vertices), 32 shapes, T frames of a smooth track with noise and
out-of-range targets so that all three constraint kinds are active.

    python perf/bench_fit.py                    # 120 and 240 frames, all methods
    python perf/bench_fit.py --frames 240 --skip-published
    python perf/bench_fit.py --floor-only       # ratio to the least-squares floor

The floor section times (the measurements taking turns, minimum of 7 each, three
runs), in one process with one BLAS thread, two floors and the constrained fit:

* the raw floor: ``numpy.linalg.solve(B.T @ B, B.T @ R)`` with ``R`` the (3V, T)
  offsets of all frames, both products formed, no checks, not through the library;
* the entry-point floor: the unconstrained least-squares fit of the same problem
  through ``fit_coefficients(..., bounds=False, rate=False)`` (its checks included);

and prints the fit's ratio to each, with a breakdown (normal equations, QP solve,
banded factorizations).
CPU time (``time.process_time``) and wall time are both shown: on a shared
machine the CPU-time ratio is the steadier one.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def make_problem(num_frames, num_vertices=4580, num_shapes=32, seed=0):
    rng = np.random.default_rng(seed)
    neutral = rng.normal(size=(num_vertices, 3)) * 0.05
    # Localised, overlapping shapes (like ARKit): each moves a random patch of vertices.
    deltas = np.zeros((num_shapes, num_vertices, 3))
    for k in range(num_shapes):
        patch = rng.choice(num_vertices, size=num_vertices // 4, replace=False)
        deltas[k, patch] = rng.normal(size=(len(patch), 3)) * 3e-3
    t = np.arange(num_frames)[:, None] / 60.0
    target = 0.4 + 0.7 * np.sin(2 * np.pi * rng.uniform(0.3, 4.0, num_shapes) * t + rng.uniform(0, 6, num_shapes))
    frames = neutral + np.einsum("tk,kvc->tvc", target, deltas) + rng.normal(size=(num_frames, num_vertices, 3)) * 2e-4
    return neutral, deltas, frames


def _rss_now_kb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() // 1024


def child(method, num_frames, threads):
    from blendvoca.runtime.threads import limited_threads

    neutral, deltas, frames = make_problem(num_frames)
    from blendvoca.fit import fit_coefficients, normal_equations, solve_published_qp

    with limited_threads(threads):
        before = _rss_now_kb()
        start = time.perf_counter()
        if method == "published":
            coeffs = solve_published_qp(neutral, deltas, frames, rate_bound=0.1)
        else:
            coeffs = fit_coefficients(neutral, deltas, frames, rate_bound=0.1, solver=method)
        elapsed = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    objective = normal_equations(neutral, deltas, frames).objective(coeffs)
    print(json.dumps({"method": method, "frames": num_frames, "seconds": elapsed,
                      "peak_mb": max(peak - before, 0) / 1024, "objective": objective,
                      "coeffs": np.round(coeffs, 8).tolist()}))


def run_child(method, num_frames, threads):
    out = subprocess.run([sys.executable, __file__, "--child", method, "--frames", str(num_frames),
                          "--threads", str(threads)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _best_interleaved(functions, repeats):
    """Smallest (cpu, wall) seconds of ``repeats`` calls of each function, the functions taking turns
    (so that a machine whose speed drifts affects all of them alike)."""
    cpu, wall = [[] for _ in functions], [[] for _ in functions]
    for _ in range(repeats):
        for i, function in enumerate(functions):
            c, w = time.process_time(), time.perf_counter()
            function()
            cpu[i].append(time.process_time() - c)
            wall[i].append(time.perf_counter() - w)
    return [(min(c), min(w)) for c, w in zip(cpu, wall)]


def raw_floor(neutral, deltas, frames):
    """``solve(B^T B, B^T R)`` for all frames: the unconstrained fit with nothing around it."""
    basis = deltas.reshape(deltas.shape[0], -1).T  # (3V, K)
    offsets = (frames - neutral[None]).reshape(frames.shape[0], -1).T  # (3V, T)
    return np.linalg.solve(basis.T @ basis, basis.T @ offsets).T


def floor_ratio(num_frames, repeats=7):
    """Print the constrained fit against both least-squares floors, with a breakdown."""
    from blendvoca.fit import banded_qp, fit_coefficients, normal_equations, solve_banded_qp
    from blendvoca.runtime.threads import limited_threads

    neutral, deltas, frames = make_problem(num_frames)
    counts = {"factor": 0, "solve": 0}
    factor, solve = banded_qp._Problem.factor, banded_qp._Problem.solve

    def counted_factor(self, weights):
        counts["factor"] += 1
        return factor(self, weights)

    def counted_solve(self, chol, vec):
        counts["solve"] += 1
        return solve(self, chol, vec)

    with limited_threads(1):
        system = normal_equations(neutral, deltas, frames)
        raw, floor, fit, normal, qp = _best_interleaved([
            lambda: raw_floor(neutral, deltas, frames),
            lambda: fit_coefficients(neutral, deltas, frames, bounds=False, rate=False),
            lambda: fit_coefficients(neutral, deltas, frames, rate_bound=0.1),
            lambda: normal_equations(neutral, deltas, frames),
            lambda: solve_banded_qp(system.gram, system.rhs, rate_bound=0.1),
        ], repeats)
        banded_qp._Problem.factor, banded_qp._Problem.solve = counted_factor, counted_solve
        try:
            sol = solve_banded_qp(system.gram, system.rhs, rate_bound=0.1)
        finally:
            banded_qp._Problem.factor, banded_qp._Problem.solve = factor, solve
    print(f"{num_frames:>6} frames  raw floor {1e3 * raw[0]:7.1f} ms cpu ({1e3 * raw[1]:7.1f} wall)  "
          f"entry-point floor {1e3 * floor[0]:7.1f} ms cpu ({1e3 * floor[1]:7.1f} wall)  "
          f"fit {1e3 * fit[0]:7.1f} ms cpu ({1e3 * fit[1]:7.1f} wall)")
    print(f"        ratio to the raw floor {fit[0] / raw[0]:.2f} cpu / {fit[1] / raw[1]:.2f} wall; "
          f"to the entry-point floor {fit[0] / floor[0]:.2f} cpu / {fit[1] / floor[1]:.2f} wall")
    print(f"        breakdown: normal equations {1e3 * normal[0]:.1f} ms, QP solve {1e3 * qp[0]:.1f} ms "
          f"({sol.solver}, {sol.iterations} interior-point iterations, {counts['factor']} banded "
          f"factorizations, {counts['solve']} banded solves)")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, nargs="+", default=[120, 240])
    parser.add_argument("--methods", nargs="+", default=["banded", "piqp", "clarabel", "osqp"])
    parser.add_argument("--skip-published", action="store_true")
    parser.add_argument("--threads", type=int, default=1, help="BLAS threads in each measurement")
    parser.add_argument("--scaling", type=int, nargs="+", default=[120, 240, 480, 960],
                        help="frame counts for the linear-growth check of the banded method")
    parser.add_argument("--floor-frames", type=int, nargs="+", default=[240, 960],
                        help="frame counts of the ratio to the least-squares floor")
    parser.add_argument("--floor-runs", type=int, default=3, help="runs of the floor section")
    parser.add_argument("--floor-only", action="store_true", help="only the floor section")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.child, args.frames[0], args.threads)
        return
    print(f"problem: 4580 vertices, 32 shapes, delta 0.1; BLAS threads {args.threads}")
    print("\nconstrained fit / unconstrained least squares of the same problem (one BLAS thread, same process)")
    for run in range(args.floor_runs):
        print(f"run {run + 1} of {args.floor_runs}")
        for num_frames in args.floor_frames:
            floor_ratio(num_frames)
    if args.floor_only:
        return
    for num_frames in args.frames:
        results = {m: run_child(m, num_frames, args.threads) for m in args.methods}
        if not args.skip_published:
            results["published"] = run_child("published", num_frames, args.threads)
        ref = results["published" if "published" in results else args.methods[0]]
        print(f"\n{num_frames} frames")
        print(f"{'method':<12}{'seconds':>10}{'peak MB':>10}{'speed-up':>10}{'max |du|':>12}{'rel. objective':>16}")
        for method, r in results.items():
            du = np.abs(np.array(r["coeffs"]) - np.array(results[args.methods[0]]["coeffs"])).max()
            rel = (r["objective"] - results[args.methods[0]]["objective"]) / results[args.methods[0]]["objective"]
            print(f"{method:<12}{r['seconds']:>10.4f}{r['peak_mb']:>10.1f}{ref['seconds'] / r['seconds']:>10.1f}"
                  f"{du:>12.2e}{rel:>16.2e}")
    print("\nlinear growth of the banded method (seconds per frame should stay flat)")
    for num_frames in args.scaling:
        r = run_child("banded", num_frames, args.threads)
        print(f"{num_frames:>6} frames {r['seconds']:.4f} s  {1000 * r['seconds'] / num_frames:.3f} ms/frame  "
              f"peak {r['peak_mb']:.1f} MB")


if __name__ == "__main__":
    main()
