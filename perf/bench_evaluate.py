"""Time of scoring a test split, by stage, against the sequential uncached evaluation.

    BLENDVOCA_ASSETS=../shared/assets python perf/bench_evaluate.py --data BUILD
        [--method mean|ground-truth-shifted] [--sync-expert E] [--workers 2]

Scores one deterministic method's tracks on ``BUILD``'s test split (the 12 x 40
leaderboard build: 80 sentences) three times in this process with
``benchmark.evaluation.evaluate_split``:

1. reference: one process, no ground-truth WInD cache (every mixture fitted);
2. ``--workers`` processes, cold cache (the first method scored on a split);
3. ``--workers`` processes, warm cache (every later method on that split).

and prints each total, its ratio to the reference, the stage times of run 3 (latent
metrics, vertex metrics, lip sync) and whether the three score sets are identical.
``--method mean`` is the train-split mean track; ``ground-truth-shifted`` the
ground truth delayed by 5 frames (features that move, so the WInD refits work).

    python perf/bench_evaluate.py --samples 10 [--data BUILD] [--repeats 3]

instead times a stochastic row against the ground-truth row of the same split, in
this process, with a warm ground-truth WInD cache and one process each (``workers=1``):
the ground-truth row scores the split's own tracks (one sample), the stochastic row
``--samples`` seeded tracks per sentence (the ground truth delayed by 1-5 frames plus
Gaussian noise of 0.02). The two are timed alternately ``--repeats`` times and the
minimum of each is kept (the machine may be shared), and the ratio is printed with
the per-stage times of the stochastic row. ``--data`` defaults to the bundled default.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def tracks(dataset, method: str) -> dict:
    keys = [(s, n) for s in dataset.split("test") for n in dataset.sentences(s)]
    if method == "mean":
        train = [dataset.coeffs(s, n) for s in dataset.split("train") for n in dataset.sentences(s)]
        mean = np.concatenate(train).mean(axis=0)
        return {k: np.repeat(mean[None], len(dataset.coeffs(*k)), axis=0)[None] for k in keys}
    out = {}
    for k in keys:
        gt = dataset.coeffs(*k)
        out[k] = np.concatenate([np.repeat(gt[:1], 5, axis=0), gt[:-5]])[None]
    return out


def sampled_tracks(dataset, samples: int, seed: int = 0) -> dict:
    """``samples`` seeded tracks per test sentence: the ground truth delayed by 1-5
    frames plus Gaussian noise (sd 0.02), clipped to [0, 1]."""
    rng = np.random.default_rng(seed)
    out = {}
    for s in dataset.split("test"):
        for n in dataset.sentences(s):
            gt = dataset.coeffs(s, n)
            rows = []
            for _ in range(samples):
                lag = int(rng.integers(1, 6))
                shifted = np.concatenate([np.repeat(gt[:1], lag, axis=0), gt[:-lag]])
                rows.append(np.clip(shifted + rng.normal(0.0, 0.02, gt.shape), 0.0, 1.0))
            out[(s, n)] = np.stack(rows)
    return out


def stochastic_ratio(args) -> None:
    """Time the ``--samples`` row against the ground-truth row, alternately, in this process."""
    from benchmark.evaluation import EvaluationSettings, evaluate_split
    from benchmark.features import load_published_vae

    if args.data is None:
        from benchmark.protocol.spec import default_data_root

        args.data = default_data_root()
    from benchmark.data import open_blendvoca

    dataset = open_blendvoca(args.data)
    extractor = load_published_vae()
    sampled = sampled_tracks(dataset, args.samples)
    rows = {"ground truth (1 sample)": {key: dataset.coeffs(*key)[None] for key in sampled},
            f"{args.samples} samples": sampled}
    frames = sum(v.shape[1] for v in rows["ground truth (1 sample)"].values())
    print(f"{args.data}: {len(rows['ground truth (1 sample)'])} test sentences, {frames} frames; "
          f"workers=1, warm cache, min of {args.repeats} alternating runs")
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp) / "wind-gmm"
        for tracks_ in rows.values():  # warm: the ground-truth fits, imports, the VAE
            evaluate_split(tracks_, dataset, "test",
                           EvaluationSettings(extractor=extractor, workers=1, wind_cache=cache))
        best = {label: float("inf") for label in rows}
        for _ in range(args.repeats):
            for label, tracks_ in rows.items():
                start = time.perf_counter()
                evaluate_split(tracks_, dataset, "test",
                               EvaluationSettings(extractor=extractor, workers=1, wind_cache=cache))
                best[label] = min(best[label], time.perf_counter() - start)
        for label, seconds in best.items():
            print(f"  {label:28s} {seconds:7.2f} s")
        label = f"{args.samples} samples"
        print(f"  ratio {label} / ground truth: {best[label] / best['ground truth (1 sample)']:.2f}x")
        print(f"  stages of the {label} row (warm cache, 1 process):")
        for stage, seconds in stage_times(rows[label], dataset, extractor, None, 1, cache).items():
            print(f"    {stage:44s} {seconds:7.2f} s")


def stage_times(generated, dataset, extractor, sync_expert, workers: int, cache) -> dict:
    """Seconds of the three evaluation stages (the same calls evaluate_split makes)."""
    from benchmark.evaluation import EvaluationSettings, latent_metrics, lipsync_values, vertex_values

    keys = list(generated)
    truth = {k: dataset.coeffs(*k) for k in keys}
    rigs = {s: dataset.rig(s) for s in {k[0] for k in keys}}
    audio = {k: dataset.audio(*k) for k in keys}
    out = {}
    start = time.perf_counter()
    latent_metrics(truth, generated, extractor, EvaluationSettings(workers=workers, wind_cache=cache))
    out["latent (FD, WInD, multimodality, energy)"] = time.perf_counter() - start
    start = time.perf_counter()
    vertex_values(truth, generated, rigs, dataset.names, workers=workers, mesh_vertices=dataset.vertices)
    out["vertex (LVE, MVE, FDD, energy; mesh and rig)"] = time.perf_counter() - start
    start = time.perf_counter()
    lipsync_values(generated, rigs, audio, dataset.names, sync_expert=sync_expert, workers=workers,
                   ground_truth=truth)
    out["lip sync (geometric + expert)"] = time.perf_counter() - start
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=None, help="BlendVOCA build (required without --samples)")
    parser.add_argument("--samples", type=int, default=None,
                        help="time a row of this many seeded samples against the ground-truth row")
    parser.add_argument("--repeats", type=int, default=3, help="alternating timed runs with --samples")
    parser.add_argument("--method", choices=("mean", "ground-truth-shifted"), default="mean")
    parser.add_argument("--sync-expert", default=None, help="learned sync expert (benchmark.lipsync.load_expert)")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    if args.samples is not None:
        stochastic_ratio(args)
        return
    if args.data is None:
        parser.error("--data is required without --samples")

    from benchmark.data import open_blendvoca
    from benchmark.evaluation import EvaluationSettings, evaluate_split
    from benchmark.features import load_published_vae
    from benchmark.lipsync.expert import load_expert

    dataset = open_blendvoca(args.data)
    generated = tracks(dataset, args.method)
    extractor = load_published_vae()
    expert = load_expert(args.sync_expert) if args.sync_expert else None
    print(f"{args.method} on {args.data}: {len(generated)} test sentences, "
          f"{sum(v.shape[1] for v in generated.values())} frames")
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp) / "wind-gmm"
        runs = {}
        for label, workers, wind_cache in (("reference: 1 process, no cache", 1, None),
                                           (f"{args.workers} processes, cold cache", args.workers, cache),
                                           (f"{args.workers} processes, warm cache", args.workers, cache)):
            start = time.perf_counter()
            scores = evaluate_split(generated, dataset, "test", EvaluationSettings(
                extractor=extractor, sync_expert=expert, workers=workers, wind_cache=wind_cache))
            runs[label] = (time.perf_counter() - start, scores)
        reference = next(iter(runs.values()))
        for label, (seconds, _) in runs.items():
            print(f"  {label:34s} {seconds:7.1f} s   {reference[0] / seconds:5.2f}x")
        same = all(dict(s) == dict(reference[1]) and s.per_sentence == reference[1].per_sentence
                   for _, s in runs.values())
        print(f"  scores identical in all three: {same}")
        print("  stages (warm cache):")
        for stage, seconds in stage_times(generated, dataset, extractor, expert, args.workers, cache).items():
            print(f"    {stage:34s} {seconds:7.1f} s")


if __name__ == "__main__":
    main()
