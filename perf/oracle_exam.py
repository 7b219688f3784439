"""The metrics' exam on a synthetic build with oracle tracks.

The corpus knows p(motion | audio, speaker): ``oracle-sample`` draws from it,
``oracle-mean`` is its Monte-Carlo mean, and ``oracle-mean`` plus i.i.d. noise is a
forecast that is spread but cannot see the outcome. A distribution metric (FD, WInD)
or an energy score that does not prefer ``oracle-sample`` to ``oracle-mean`` (and to
the noisy mean, for the energy score), or an LVE that does not prefer ``oracle-mean``,
is broken on the corpus. "Prefer" is strict (means ordered, 95 % intervals apart)
except against the noisy mean, which must only not beat ``oracle-sample``. This
script scores the three rows on one split, in one process, through
``benchmark.evaluation.evaluate_split`` (the runner's scoring), and
prints each metric's value and 95 % interval per row, whether the intervals overlap,
and the probability of improvement over paired bootstrap resamples. It also prints
the share of the split's coefficient variance that ``oracle-mean`` and a linear ridge
on log-mel (+-20 frames) explain::

    python -m blendvoca.synthetic --out SYNTH --speakers 12 --sentences 40 --seed 0 \\
        --layout processed --oracle-samples 8
    python -m blendvoca.build --vocaset SYNTH --out BUILD
    BLENDVOCA_ASSETS=... python perf/oracle_exam.py --data BUILD --samples 8 --out exam.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines.bounds.oracle import OracleMeanMethod, OracleSampleMethod  # noqa: E402
from baselines.regression.ridge import ridge_explained  # noqa: E402
from benchmark.data import open_blendvoca  # noqa: E402
from benchmark.evaluation import EvaluationSettings, evaluate_split  # noqa: E402
from benchmark.methods import Budget, TrainingRequest  # noqa: E402
from benchmark.metrics.bootstrap import probability_of_improvement  # noqa: E402
from benchmark.protocol.generation import generated_tracks  # noqa: E402
from blendvoca.runtime.progress import progress_bars  # noqa: E402

#: What each metric must prefer: (better row, worse row, strict). Strict: the better row's
#: mean is better and the two 95 % intervals do not overlap; not strict: the worse row
#: does not beat the better one (its mean is not better), the test of a forecast that
#: cannot see the outcome (the noisy mean) against the oracle sampler.
EXPECTED = {
    "fd": [("oracle-sample", "oracle-mean", True)],
    "wind": [("oracle-sample", "oracle-mean", True)],
    "energy_rig": [("oracle-sample", "oracle-mean", True), ("oracle-sample", "oracle-mean+noise", False)],
    "energy_mesh": [("oracle-sample", "oracle-mean", True), ("oracle-sample", "oracle-mean+noise", False)],
    "energy_latent": [("oracle-sample", "oracle-mean", True), ("oracle-sample", "oracle-mean+noise", False)],
    "lve_rig": [("oracle-mean", "oracle-sample", True)],
    "lve_mesh": [("oracle-mean", "oracle-sample", True)],
}
#: Reported without an expected order (multimodality is read against the sampler's own value).
REPORTED = ("multimodality", "mve_rig", "apd_rig", "lpd_rig")


def noisy(tracks: dict, *, std: float, samples: int, seed: int) -> dict:
    """Each deterministic track repeated ``samples`` times plus i.i.d. Gaussian noise, clipped to [0, 1]."""
    rng = np.random.default_rng(seed)
    out = {}
    for key in sorted(tracks):
        mean = np.asarray(tracks[key][0], dtype=np.float64)
        out[key] = np.clip(mean[None] + rng.normal(0.0, std, (samples, *mean.shape)), 0.0, 1.0)
    return out


def oracle_rows(dataset, split: str, *, samples: int, noise: float | None, seed: int) -> dict:
    """The exam's rows on ``split``: ``{"oracle-sample": S draws, "oracle-mean": its mean[,
    "oracle-mean+noise": the mean plus i.i.d. noise of std ``noise``, S times]}``, each
    ``{(subject, sentence): (S, T, C)}``."""
    rows = {}
    for method, count in ((OracleSampleMethod(split=split), samples), (OracleMeanMethod(split=split), 1)):
        method.train(dataset, TrainingRequest(seed=seed, budget=Budget()))
        with progress_bars(False):
            rows[method.name], _ = generated_tracks(method, dataset, split=split, samples=count, seed=seed)
    if noise is not None:
        rows["oracle-mean+noise"] = noisy(rows["oracle-mean"], std=noise, samples=samples, seed=seed)
    return rows


def explained(tracks: dict, dataset) -> float:
    """``1 - SS(truth - track) / SS(truth - its mean)`` over the scored sentences (sample 0)."""
    truth = np.concatenate([dataset.coeffs(*key) for key in sorted(tracks)])
    pred = np.concatenate([np.asarray(tracks[key][0]) for key in sorted(tracks)])
    return 1.0 - float(((truth - pred) ** 2).sum()) / float(((truth - truth.mean(axis=0)) ** 2).sum())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="a BlendVOCA build of a synthetic corpus with oracle tracks")
    parser.add_argument("--split", default="test")
    parser.add_argument("--samples", type=int, default=8, help="S for oracle-sample and the noisy mean")
    parser.add_argument("--noise", type=float, default=0.05, help="std of the noise added to oracle-mean")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="write the figures as JSON here")
    args = parser.parse_args(argv)

    dataset = open_blendvoca(args.data)
    if not dataset.has_oracle():
        parser.error(f"{args.data}: the build has no oracle tracks (generate the corpus with --oracle-samples K)")
    rows = oracle_rows(dataset, args.split, samples=args.samples, noise=args.noise, seed=args.seed)

    wanted = tuple(EXPECTED) + REPORTED
    scores, seconds = {}, {}
    for name, tracks in rows.items():
        start = time.perf_counter()
        scores[name] = evaluate_split(tracks, dataset, args.split, EvaluationSettings(seed=args.seed, lipsync=False),
                                      metrics=wanted)
        seconds[name] = time.perf_counter() - start
        print(f"scored {name} ({next(iter(tracks.values())).shape[0]} samples) in {seconds[name]:.1f} s",
              file=sys.stderr, flush=True)

    figures = {"data": str(args.data), "split": args.split, "samples": args.samples, "noise": args.noise,
               "seconds": seconds, "metrics": {}, "checks": []}
    print(f"\n{'metric':<16}" + "".join(f"{name:>34}" for name in rows))
    for metric in wanted:
        entries = {name: s[metric] for name, s in scores.items() if metric in s}
        if not entries:
            continue
        figures["metrics"][metric] = {name: {"mean": e["mean"], "ci95": e["ci95"]} for name, e in entries.items()}
        print(f"{metric:<16}" + "".join(
            f"{e['mean']:>14.4f} [{e['ci95'][0]:.4f}, {e['ci95'][1]:.4f}]" if (e := entries.get(name)) else f"{'-':>34}"
            for name in rows))
    print()
    failed = 0
    for metric, pairs in EXPECTED.items():
        for better, worse, strict in pairs:
            if metric not in scores[better] or metric not in scores[worse]:
                continue
            a, b = scores[better][metric], scores[worse][metric]
            higher = bool(a["higher_is_better"])
            prob = probability_of_improvement(scores[better].replicates[metric], scores[worse].replicates[metric],
                                              higher_is_better=higher)
            ordered = a["mean"] > b["mean"] if higher else a["mean"] < b["mean"]
            apart = a["ci95"][0] > b["ci95"][1] if higher else a["ci95"][1] < b["ci95"][0]
            ok = ordered and (apart or not strict)
            failed += not ok
            figures["checks"].append({"metric": metric, "better": better, "worse": worse, "strict": strict,
                                      "ordered": ordered, "intervals_apart": apart, "ok": ok,
                                      "probability_of_improvement": prob})
            claim = "better than" if strict else "not beaten by"
            print(f"{'ok  ' if ok else 'FAIL'} {metric:<14} {better} {claim} {worse}: "
                  f"{'ordered' if ordered else 'NOT ordered'}, intervals {'apart' if apart else 'overlap'}, "
                  f"P(improvement) = {prob:.3f}")
    share_mean = explained(rows["oracle-mean"], dataset)
    ridge = ridge_explained(dataset, split=args.split)
    figures["explained"] = {"oracle-mean": share_mean, "ridge": ridge["explained"], "ridge_lambda": ridge["lambda"]}
    print(f"\nshare of the {args.split} split's coefficient variance explained: oracle-mean {share_mean:.3f}, "
          f"ridge on log-mel +-20 frames {ridge['explained']:.3f} (lambda {ridge['lambda']:g})")
    if args.out:
        Path(args.out).write_text(json.dumps(figures, indent=2) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
