"""Dynamics beside the latent FD and a coefficient-space FD, on the disturbed ground truth.

Scores the ground truth of a build's test split, disturbed at four levels per kind
(``benchmark.sanity.disturbances``) and a static face, with the latent FD (through
``benchmark.evaluation.evaluate_split``, the sanity suite's settings), two
coefficient-space FDs (per frame: the 32 coefficients; the coefficients and their
velocities) and the dynamics ratios, and prints a Markdown table and the Spearman
correlation of each coefficient FD with the latent FD over the sets. With a build
that has oracle samples, ``--references`` also prints the sanity suite's reference
rows (``benchmark.sanity.report.reference_table``)::

    BLENDVOCA_ASSETS=... python perf/dynamics_fd.py --data BUILD [--references]

It answers issue 54's question, whether a coefficient-space FD beside the latent FD
tells a reader something the latent one does not (docs/results/dynamics-measurements.md).
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

LEVELS = {"damping": (0.2, 0.4, 0.6, 0.8), "noise": (0.01, 0.02, 0.05, 0.1), "smoothing": (1, 2, 4, 8),
          "time_shift": (1, 2, 4, 8), "mouth_damping": (0.2, 0.4, 0.6, 0.8), "sentence_swap": (0.25, 0.5, 0.75, 1.0),
          "constant_offset": (0.002, 0.005, 0.01, 0.02)}


def _with_velocity(tracks) -> np.ndarray:
    return np.concatenate([np.hstack([v[1:], np.diff(v, axis=0)]) for v in tracks])


def disturbed_table(dataset) -> list:
    """``[(kind, level, latent FD, coefficient FD, coefficient + velocity FD, ratio lips, jaw, upper)]``."""
    from benchmark.evaluation import evaluate_split
    from benchmark.metrics.frechet import frechet_distance
    from benchmark.sanity.disturbances import disturb
    from benchmark.sanity.report import SANITY_SETTINGS, ground_truth
    from blendvoca.runtime.progress import progress_bars

    truth = ground_truth(dataset)
    real, real_v = np.concatenate(list(truth.values())), _with_velocity(truth.values())
    sets = [("static", None)] + [(k, lv) for k, levels in LEVELS.items() for lv in levels]
    rows = []
    for kind, level in sets:
        generated = ({k: np.zeros((1, *v.shape)) for k, v in truth.items()} if kind == "static"
                     else disturb(kind, truth, level, dataset.names))
        with progress_bars(False), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scores = evaluate_split(generated, dataset, "test", SANITY_SETTINGS,
                                    metrics=["fd", "motion_ratio_lips", "motion_ratio_jaw", "motion_ratio_upper"])
        fake = [v[0] for v in generated.values()]
        rows.append((kind, level, scores["fd"]["mean"], frechet_distance(np.concatenate(fake), real),
                     frechet_distance(_with_velocity(fake), real_v), scores["motion_ratio_lips"]["mean"],
                     scores["motion_ratio_jaw"]["mean"], scores["motion_ratio_upper"]["mean"]))
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="perf/dynamics_fd.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, metavar="BUILD", help="a BlendVOCA build with a test split")
    p.add_argument("--references", action="store_true",
                   help="also the reference rows (static, ground truth, oracle sample and mean where the build "
                        "has them)")
    args = p.parse_args(argv)
    from scipy.stats import spearmanr

    from benchmark.data import open_blendvoca

    dataset = open_blendvoca(args.data)
    rows = disturbed_table(dataset)
    print("| set | level | latent FD | coef. FD (frames) | coef. FD (frames + velocity) | ratio lips | ratio jaw | "
          "ratio upper |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for kind, level, *v in rows:
        print(f"| {kind} | {'' if level is None else level} | {v[0]:.3f} | {v[1]:.4f} | {v[2]:.4f} | {v[3]:.3f} | "
              f"{v[4]:.3f} | {v[5]:.3f} |")
    values = np.array([r[2:] for r in rows])
    print(f"Spearman, latent FD against the coefficient FD: frames {spearmanr(values[:, 0], values[:, 1])[0]:.3f}, "
          f"frames + velocity {spearmanr(values[:, 0], values[:, 2])[0]:.3f} ({len(rows)} sets)")
    if args.references:
        from benchmark.sanity.report import reference_table

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            table = reference_table(dataset)
        print("\n| metric | row | mean | 95 % interval | claim | status |\n|---|---|---:|---|---|---|")
        for metric, by_row in table.items():
            for row, e in by_row.items():
                ci = "" if e["ci95"] is None else f"[{e['ci95'][0]:.3f}, {e['ci95'][1]:.3f}]"
                mean = "" if e["mean"] is None else f"{e['mean']:.3f}"
                print(f"| `{metric}` | {row} | {mean} | {ci} | {e['expected']} {e['target']:g} | {e['status']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
