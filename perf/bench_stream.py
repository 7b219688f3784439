"""Time the streaming solver per frame, beside the offline QP, and compare their tracks.

The sentences are those of the bundled-default BlendVOCA (its FLAME rigs, fitted on
the 4580-vertex head crop; the 60 fps meshes of the bundled synthetic corpus, full
topology, unposed); both are made on first use (``BLENDVOCA_ASSETS`` must point at the
assets). Everything runs in one process with one BLAS thread (blendvoca.runtime.threads).

    python perf/bench_stream.py                  # per-frame times: streaming vs offline QP
    python perf/bench_stream.py --solvers        # the per-frame box QP by other solvers
    python perf/bench_stream.py --compare        # tracks: streaming against the offline QP

Default section: every frame of every sentence of ``--speakers`` speakers is solved by
:class:`blendvoca.fit.StreamingSolver` and timed alone (wall clock and this thread's CPU
time: on a shared machine the CPU time is the steadier; the target is a p99 under 8 ms,
half a 60 fps frame); each sentence is also fitted whole by the offline QP
(``fit_sequence``, the build's fit), whose time per frame is printed beside, with the ratio.

``--solvers``: the per-frame box QP alone (the SDK-default problem of each frame, in
stream order) by the hand-written active set, PIQP's dense solver (set up once, its
linear term updated per frame), ``scipy.optimize.lsq_linear`` (BVLS on the Cholesky
factor) and the offline fit's banded solver on one frame; the largest difference from
the active set's answer is shown.

``--compare``: on every sentence, the offline QP and the streaming solver under several
configurations: vertex RMSE against the meshes (head crop, mm, mean over frames),
smoothness (mean |u[t+1] - 2 u[t] + u[t-1]|), the mean step |u[t+1] - u[t]|, the
fraction of steps above the fit's rate bound 0.1 and the largest step, and the
distance to the offline track (mean, RMS and largest |difference|).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

RATE_BOUND = 0.1


def sentences(num_speakers=None):
    """Yield ``(subject, sentence, rig, frames)`` of the bundled default (frames float64, full topology)."""
    from benchmark.data import open_blendvoca
    from benchmark.protocol import default_data_root
    from blendvoca.runtime.progress import progress_bars
    from blendvoca.synthetic import default_corpus
    from blendvoca.vocaset import open_vocaset

    with progress_bars(False):
        data = open_blendvoca(default_data_root())
    corpus = open_vocaset(default_corpus())
    for subject in corpus.subjects[:num_speakers]:
        rig = data.rig(subject)
        for sentence in corpus.sentences(subject):
            yield subject, sentence, rig, corpus.frames(subject, sentence)


def configs():
    from blendvoca.fit import StreamingSolverConfig as C

    return {
        "SDK defaults": C(),
        "SDK defaults, rate bound 0.1": C(rate_bound=RATE_BOUND),
        "SDK defaults, temporal 1": C(temporal=1.0),
        "SDK objective (a2f)": C(objective="a2f"),
        "bounded least squares": C.bounded_least_squares(),
        "bounded least squares, rate bound 0.1": C.bounded_least_squares(rate_bound=RATE_BOUND),
    }


def _percentiles(values_ms):
    v = np.asarray(values_ms)
    return (f"mean {v.mean():6.3f}  p50 {np.percentile(v, 50):6.3f}  p99 {np.percentile(v, 99):6.3f}  "
            f"max {v.max():6.3f}")


def _machine():
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{os.cpu_count()} CPUs, load average {load:.1f} when done (other jobs lengthen the wall times, not the CPU times)"


def timing(num_speakers, crop):
    from blendvoca.assets import load_index_list
    from blendvoca.fit import StreamingSolver, fit_sequence
    from blendvoca.runtime.threads import limited_threads

    head = load_index_list("flame-head-idx")
    chosen = {k: v for k, v in configs().items() if k in ("SDK defaults", "SDK defaults, temporal 1",
                                                          "SDK objective (a2f)", "bounded least squares")}
    wall = {k: [] for k in chosen}
    cpu = {k: [] for k in chosen}
    offline_wall = offline_cpu = 0.0
    total_frames = 0
    with limited_threads(1):
        for _, _, rig, frames in sentences(num_speakers):
            inputs = np.take(frames, head, axis=1) if crop else frames  # C-contiguous crops
            for name, config in chosen.items():
                solver = StreamingSolver.from_rig(rig, config)
                for frame in inputs:
                    c, w = time.thread_time_ns(), time.perf_counter_ns()
                    solver.solve(frame)
                    wall[name].append((time.perf_counter_ns() - w) / 1e6)
                    cpu[name].append((time.thread_time_ns() - c) / 1e6)
            c, w = time.thread_time(), time.perf_counter()
            fit_sequence(rig.neutral, rig.deltas, frames, vertex_subset=head, unposed=True)
            offline_cpu += time.thread_time() - c
            offline_wall += time.perf_counter() - w
            total_frames += len(frames)
    off_wall, off_cpu = 1e3 * offline_wall / total_frames, 1e3 * offline_cpu / total_frames
    print(f"{total_frames} frames ({'head crop (4580, 3)' if crop else 'full topology (5023, 3)'} in, "
          f"4580-vertex head fitted, 32 shapes), one BLAS thread; ms per frame")
    print(f"  offline QP (whole sentences)   mean {off_wall:6.3f} wall, {off_cpu:6.3f} cpu")
    for name in chosen:
        p99 = np.percentile(wall[name], 99)
        print(f"  streaming, {name}:\n    wall {_percentiles(wall[name])}\n    cpu  {_percentiles(cpu[name])}\n"
              f"    streaming / offline per frame: mean {np.mean(wall[name]) / off_wall:.2f} wall, "
              f"{np.mean(cpu[name]) / off_cpu:.2f} cpu; p99 {p99 / off_wall:.2f} wall, "
              f"{np.percentile(cpu[name], 99) / off_cpu:.2f} cpu; p99 wall {'under' if p99 < 8.0 else 'OVER'} "
              f"the 8 ms target")
    print(_machine())


def solvers(num_speakers, limit_frames):
    import piqp
    from scipy.linalg import cholesky, solve_triangular
    from scipy.optimize import lsq_linear

    from blendvoca.fit import StreamingSolver, solve_banded_qp
    from blendvoca.fit.box_qp import solve_box_qp
    from blendvoca.runtime.threads import limited_threads

    problems = []
    for _, _, rig, frames in sentences(num_speakers):
        solver = StreamingSolver.from_rig(rig)
        problems.extend((solver.hessian, solver._offsets_of(frame)) for frame in frames)
        if len(problems) >= limit_frames:
            break
    problems = problems[:limit_frames]
    k = problems[0][1].size
    lower, upper = np.zeros(k), np.ones(k)

    def active_set():
        status = None
        for hessian, linear in problems:
            solution = solve_box_qp(hessian, linear, lower, upper, status=status)
            status = solution.status
            yield solution.x

    def piqp_dense():
        dense = piqp.DenseSolver()
        dense.settings.eps_abs = dense.settings.eps_rel = 1e-10
        hessian = problems[0][0]
        dense.setup(np.asfortranarray(hessian), -problems[0][1], x_l=lower, x_u=upper)
        for _, linear in problems:  # one rig: the Hessian stays, the linear term is updated
            dense.update(c=-linear)
            dense.solve()
            yield np.array(dense.result.x)

    def bvls():
        factor = cholesky(problems[0][0], lower=True)
        for _, linear in problems:
            rhs = solve_triangular(factor, linear, lower=True)
            yield lsq_linear(factor.T, rhs, bounds=(0, 1), method="bvls", tol=1e-12).x

    def banded():
        for hessian, linear in problems:
            yield solve_banded_qp(hessian, linear[None], lower=0.0, upper=1.0, rate_bound=None).coeffs[0]

    results = {}
    with limited_threads(1):
        for name, run in (("active set (warm-started)", active_set), ("PIQP dense (linear term updated)", piqp_dense),
                          ("lsq_linear bvls", bvls), ("banded QP, one frame", banded)):
            wall, cpu, answers = [], [], []
            steps = run()
            while True:
                c, w = time.thread_time_ns(), time.perf_counter_ns()
                try:
                    answer = next(steps)
                except StopIteration:
                    break
                wall.append((time.perf_counter_ns() - w) / 1e6)
                cpu.append((time.thread_time_ns() - c) / 1e6)
                answers.append(answer)
            results[name] = wall, cpu, np.array(answers)
    reference = results["active set (warm-started)"][2]
    print(f"per-frame box QP alone (K = {k}, SDK defaults), {len(problems)} frames in stream order, one BLAS "
          f"thread; ms per frame")
    for name, (wall, cpu, answers) in results.items():
        print(f"  {name}:\n    wall {_percentiles(wall)}\n    cpu  {_percentiles(cpu)}\n"
              f"    largest |difference| from the active set {np.abs(answers - reference).max():.1e}")
    print(_machine())


def compare(num_speakers):
    from blendvoca.assets import load_index_list
    from blendvoca.fit import StreamingSolver, fit_sequence
    from blendvoca.runtime.threads import limited_threads

    head = load_index_list("flame-head-idx")
    rows = {"offline QP": []}
    rows.update({name: [] for name in configs()})
    count = 0
    with limited_threads(1):
        for _, _, rig, frames in sentences(num_speakers):
            offline = fit_sequence(rig.neutral, rig.deltas, frames, vertex_subset=head, unposed=True).coeffs
            target = frames[:, head]

            def measures(u):
                error = np.sqrt(((rig.evaluate(u)[:, head] - target) ** 2).sum(-1).mean(-1)).mean() * 1e3
                step = np.abs(np.diff(u, axis=0))
                diff = np.abs(u - offline)
                return [error, np.abs(np.diff(u, 2, axis=0)).mean(), step.mean(), (step > RATE_BOUND + 1e-9).mean(),
                        step.max(), diff.mean(), np.sqrt((diff ** 2).mean()), diff.max()]

            rows["offline QP"].append(measures(offline))
            for name, config in configs().items():
                rows[name].append(measures(StreamingSolver.from_rig(rig, config).solve_sequence(frames)))
            count += 1
    print(f"{count} sentences of the bundled default (4580-vertex head, 32 shapes); mean over sentences "
          f"(largest |difference| and distance: max over sentences)\n")
    print("| fit | RMSE vs meshes (mm) | mean abs 2nd difference | mean step | steps > 0.1 | largest step "
          "| distance to offline: mean | RMS | largest |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, values in rows.items():
        v = np.array(values)
        mean = v.mean(axis=0)
        cells = [f"{mean[0]:.4f}", f"{mean[1]:.5f}", f"{mean[2]:.4f}", f"{100 * mean[3]:.3f} %",
                 f"{v[:, 4].max():.3f}", f"{mean[5]:.4f} (max {v[:, 5].max():.4f})", f"{mean[6]:.4f}",
                 f"{v[:, 7].max():.3f}"]
        print(f"| {name} | " + " | ".join(cells) + " |")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--speakers", type=int, default=None, help="speakers of the bundled default (default all)")
    parser.add_argument("--crop", action="store_true", help="time with frames already cropped to the head")
    parser.add_argument("--solvers", action="store_true", help="the box QP by other solvers")
    parser.add_argument("--solver-frames", type=int, default=1000, help="frames of the --solvers section")
    parser.add_argument("--compare", action="store_true", help="streaming against the offline QP")
    args = parser.parse_args(argv)
    os.environ.setdefault("BLENDVOCA_ASSETS", str(ROOT.parent / "shared" / "assets"))
    if args.solvers:
        solvers(args.speakers, args.solver_frames)
    elif args.compare:
        compare(args.speakers)
    else:
        timing(args.speakers, args.crop)


if __name__ == "__main__":
    main()
