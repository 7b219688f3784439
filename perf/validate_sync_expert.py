"""Validation of the learned lip-sync expert against known truths.

Trains the expert on the training split of a BlendVOCA build (default: the
bundled default, built if needed) for ``--max-seconds`` (or loads ``--expert``),
then on every validation and test sentence checks:

- the ground truth's offset is its true lag (synthetic sidecar; 0 otherwise) within 1 frame;
- the ground truth delayed / advanced by ``--shift`` frames is found at lag +- shift within 2 frames;
- a loudness follower (the example plug-in's rule: jawOpen = gain x speech RMS,
  the other shapes at the training mean) gets a lower confidence than the ground truth;

and prints the geometric (weight-free) score of the same tracks beside it.

    python perf/validate_sync_expert.py --max-seconds 240 [--data DIR] [--out expert.pt]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "examples" / "blendvoca-example-method" / "src"))


def shifted(coeffs: np.ndarray, shift: int) -> np.ndarray:
    """``out[t] = coeffs[t - shift]`` (edge frames repeated): motion ``shift`` frames later."""
    T = len(coeffs)
    idx = np.clip(np.arange(T) - shift, 0, T - 1)
    return coeffs[idx]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=None, help="BlendVOCA build (default: the bundled default)")
    parser.add_argument("--expert", default=None, help="use this checkpoint instead of training")
    parser.add_argument("--max-seconds", type=float, default=240.0)
    parser.add_argument("--max-steps", type=int, default=None)
    parser.add_argument("--shift", type=int, default=8)
    parser.add_argument("--out", default=None, help="save the trained expert here")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--regression-seconds", type=float, default=120.0,
                        help="also train the regression baseline (a model that follows the phones) this long; 0: skip")
    args = parser.parse_args(argv)

    from scipy.ndimage import gaussian_filter1d

    from benchmark.data import open_blendvoca
    from benchmark.lipsync import geometric_sync, load_expert, mouth_activity
    from benchmark.lipsync.expert import save_expert
    from benchmark.lipsync.expert_training import dataset_items, train_expert
    from benchmark.metrics import vertex
    from blendvoca import rig_regions as regions
    from blendvoca_example_method import energy_envelope

    if args.data is None:
        from blendvoca.builder.pipeline import build_dataset, default_output_dir
        from blendvoca.format import manifest_path

        data = default_output_dir()
        if not manifest_path(data).is_file():
            build_dataset(data, None)
    else:
        data = Path(args.data)
    dataset = open_blendvoca(data)
    train = dataset_items(dataset, "train")
    start = time.perf_counter()
    if args.expert:
        expert = load_expert(args.expert)
    else:
        expert = train_expert(train, max_seconds=args.max_seconds, max_steps=args.max_steps, seed=args.seed,
                              trained_on={"data": str(data), "split": "train"})
        if args.out:
            save_expert(expert, args.out)
    print(f"expert: {expert.trained_on} ({time.perf_counter() - start:.0f} s)")

    regression = None
    if args.regression_seconds > 0:
        from baselines.regression.plugin import RegressionMethod
        from benchmark.methods.base import Budget, TrainingRequest

        regression = RegressionMethod()
        regression.train(dataset, TrainingRequest(seed=args.seed, budget=Budget(max_seconds=args.regression_seconds)))

    # Loudness follower fitted on the training split, as the example plug-in does.
    jaw = list(dataset.names).index("jawOpen")
    x = np.concatenate([energy_envelope(it.audio, len(it.coeffs)) for it in train])
    y = np.concatenate([it.coeffs[:, jaw] for it in train])
    gain = float(x @ y / max(x @ x, 1e-12))
    mean = np.concatenate([it.coeffs for it in train]).mean(axis=0)

    rows = []
    for split in ("val", "test"):
        for it in dataset_items(dataset, split):
            subject = it.name.split("/")[0]
            loud = np.tile(mean, (len(it.coeffs), 1))
            loud[:, jaw] = np.clip(gain * energy_envelope(it.audio, len(it.coeffs)), 0, 1)
            gt = expert.sync(it.coeffs, it.audio)
            late = expert.sync(shifted(it.coeffs, args.shift), it.audio)
            early = expert.sync(shifted(it.coeffs, -args.shift), it.audio)
            lo = expert.sync(loud, it.audio)
            # A model that follows the phones imperfectly: the truth plus smooth noise
            # of 30 % of each shape's spread in the sentence.
            noise = gaussian_filter1d(np.random.default_rng(0).normal(size=it.coeffs.shape), 3.0, axis=0)
            noise *= 0.3 * it.coeffs.std(axis=0) / noise.std(axis=0)
            ph = expert.sync(np.clip(it.coeffs + noise, 0, 1), it.audio)
            reg = None
            if regression is not None:
                utt = dataset.utterance(subject, it.name.split("/")[1])
                reg_track = np.asarray(regression.generate(utt, samples=1, seed=0))[0]
                reg = expert.sync(reg_track, it.audio)
            rig = dataset.rig(subject)
            neutral, deltas = np.asarray(rig.neutral), np.asarray(rig.deltas)
            lip = regions.lip_vertices(deltas, dataset.names)

            def geo(track):
                return geometric_sync(mouth_activity(vertex.rig_vertices(neutral, deltas, track), neutral, lip),
                                      it.audio, 16000, 60.0, 15)

            rows.append(dict(name=it.name, lag=it.lag, gt=gt, late=late, early=early, loud=lo, noisy=ph, reg=reg,
                             geo_reg=None if reg is None else geo(reg_track),
                             geo_gt=geo(it.coeffs), geo_loud=geo(loud)))

    print(f"\n{'sentence':28s} lag | expert: gt  +{args.shift}  -{args.shift}  conf gt  conf loud | "
          "geometric: off gt  off loud  conf gt  conf loud")
    for r in rows:
        print(f"{r['name']:28s} {r['lag']:+3d} | {r['gt'].offset:+9d} {r['late'].offset:+4d} {r['early'].offset:+4d} "
              f"{r['gt'].confidence:8.3f} {r['loud'].confidence:10.3f} | {r['geo_gt'].offset:+13d} "
              f"{r['geo_loud'].offset:+9d} {r['geo_gt'].confidence:8.3f} {r['geo_loud'].confidence:10.3f}")
    n = len(rows)
    ok_gt = np.mean([abs(r["gt"].offset - r["lag"]) <= 1 for r in rows])
    ok_shift = np.mean([abs(r["late"].offset - (r["lag"] + args.shift)) <= 2 for r in rows])
    ok_early = np.mean([abs(r["early"].offset - (r["lag"] - args.shift)) <= 2 for r in rows])
    ok_loud = np.mean([r["loud"].confidence < r["gt"].confidence for r in rows])
    conf_gt = np.mean([r["gt"].confidence for r in rows])
    conf_loud = np.mean([r["loud"].confidence for r in rows])
    conf_noisy = np.mean([r["noisy"].confidence for r in rows])
    ok_noisy = np.mean([r["loud"].confidence < r["noisy"].confidence for r in rows])
    if regression is not None:
        conf_reg = np.mean([r["reg"].confidence for r in rows])
        geo_reg = np.mean([r["geo_reg"].confidence for r in rows])
        off_reg = np.mean([abs(r["reg"].offset - r["lag"]) for r in rows])
        ok_reg = np.mean([r["loud"].confidence < r["reg"].confidence for r in rows])
        print(f"regression baseline: mean expert confidence {conf_reg:.3f}, mean |offset - lag| {off_reg:.2f}; "
              f"loudness follower below it in {ok_reg:.0%}; geometric confidence {geo_reg:.3f}")
    geo_gt = np.mean([r["geo_gt"].confidence for r in rows])
    geo_loud = np.mean([r["geo_loud"].confidence for r in rows])
    print(f"\n{n} validation + test sentences")
    print(f"ground truth at its true lag within 1 frame:     {ok_gt:.0%}")
    print(f"+{args.shift}-frame shift recovered within 2 frames:       {ok_shift:.0%}")
    print(f"-{args.shift}-frame shift recovered within 2 frames:       {ok_early:.0%}")
    print(f"loudness follower's confidence below the truth's: {ok_loud:.0%} "
          f"(mean expert confidence: truth {conf_gt:.3f}, loudness {conf_loud:.3f})")
    print(f"noisy truth (follows the phones): mean confidence {conf_noisy:.3f}; "
          f"loudness follower below it in {ok_noisy:.0%}")
    print(f"geometric score, mean confidence: truth {geo_gt:.3f}, loudness {geo_loud:.3f}")
    passed = ok_gt >= 0.75 and ok_shift >= 0.75 and conf_loud < conf_gt
    print("acceptance (>= 75 % on offsets, loudness below truth):", "PASS" if passed else "FAIL")
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())
