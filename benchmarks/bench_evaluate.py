"""Time of scoring a test split, by stage, against the sequential uncached evaluation.

    BLENDVOCA_ASSETS=../shared/assets python benchmarks/bench_evaluate.py --data BUILD
        [--method mean|ground-truth-shifted] [--sync-expert E] [--workers 2]

Scores one deterministic method's tracks on ``BUILD``'s test split (the 12 x 40
leaderboard build: 80 sentences) three times in this process with
``benchmark.evaluate.evaluate_split``:

1. reference: one process, no ground-truth WInD cache (every mixture fitted);
2. ``--workers`` processes, cold cache (the first method scored on a split);
3. ``--workers`` processes, warm cache (every later method on that split).

and prints each total, its ratio to the reference, the stage times of run 3 (latent
metrics, vertex metrics, lip sync) and whether the three score sets are identical.
``--method mean`` is the train-split mean track; ``ground-truth-shifted`` the
ground truth delayed by 5 frames (features that move, so the WInD refits work).
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


def stage_times(generated, dataset, extractor, sync_expert, workers: int, cache) -> dict:
    """Seconds of the three evaluation stages (the same calls evaluate_split makes)."""
    from benchmark.evaluate import _lipsync_values, _vertex_values, latent_metrics

    keys = list(generated)
    truth = {k: dataset.coeffs(*k) for k in keys}
    rigs = {s: dataset.rig(s) for s in {k[0] for k in keys}}
    audio = {k: dataset.audio(*k) for k in keys}
    out = {}
    start = time.perf_counter()
    latent_metrics(truth, generated, extractor, wind_workers=workers, wind_cache=cache)
    out["latent (FD, WInD, multimodality, energy)"] = time.perf_counter() - start
    start = time.perf_counter()
    _vertex_values(truth, generated, rigs, dataset.names, workers=workers, mesh_vertices=dataset.vertices)
    out["vertex (LVE, MVE, FDD, energy; mesh and rig)"] = time.perf_counter() - start
    start = time.perf_counter()
    _lipsync_values(generated, rigs, audio, dataset.names, sync_expert=sync_expert, workers=workers,
                    ground_truth=truth)
    out["lip sync (geometric + expert)"] = time.perf_counter() - start
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", required=True, help="BlendVOCA build")
    parser.add_argument("--method", choices=("mean", "ground-truth-shifted"), default="mean")
    parser.add_argument("--sync-expert", default=None, help="learned sync expert (benchmark.lipsync.load_expert)")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()

    from benchmark.data import open_blendvoca
    from benchmark.evaluate import evaluate_split
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
            scores = evaluate_split(generated, dataset, extractor=extractor, sync_expert=expert, workers=workers,
                                    wind_cache=wind_cache)
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
