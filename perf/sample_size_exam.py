"""The oracle exam at several test-split sizes: per distribution metric, the smallest split that orders the oracle rows.

``perf/oracle_exam.py`` scores ``oracle-sample`` (the corpus's conditional draws) and
``oracle-mean`` (their mean) on one split; on a one-to-many corpus every distribution
metric must prefer the sampler. How often it does depends on the split's size: FD's
plug-in estimate is biased upwards by about ``k / N`` (Chong and Forsyth, CVPR 2020),
more for the spread sampler than for the mean, so a small split can order the rows the
wrong way. This script scores both rows once on a corpus's test split (the latent
features of every 120-frame window, the per-sentence energy scores and LVE), then draws
``--subsets`` random test splits of ``n`` sentences for each ``--sizes`` ``n``
(without replacement from the test split; the same splits for both rows) and reports,
per metric, the probability that ``oracle-sample`` comes out better than
``oracle-mean`` (for LVE: worse, the mean is its optimum) and the smallest ``n`` from
which it stays >= 0.95 (:mod:`benchmark.evaluation.sample_size`). Metrics:
FD, ``FD_inf`` (FD extrapolated to infinite sample size,
:func:`benchmark.metrics.frechet.frechet_extrapolation`, over whole sentences of the
split), WInD (one seeded fit per side on the first ``--wind-subsets`` splits of each
size, the generated side thinned to 20,000 windows as the evaluation's refits: its
mixture fits are most of the cost), the energy scores, LVE (rig). The features and per-sentence
values are cached in ``--cache`` (a second run only redraws)::

    python -m blendvoca.synthetic --out SYNTH --speakers 12 --sentences 40 --seed 0 \\
        --layout processed --oracle-samples 8 --audio-determined 0.7
    python -m blendvoca.build --vocaset SYNTH --out BUILD
    BLENDVOCA_ASSETS=... python perf/sample_size_exam.py --data BUILD --cache CACHE \\
        --sizes 4,8,16,24,32,40,80 --out exam.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(1, str(Path(__file__).resolve().parent))

from benchmark.data import open_blendvoca  # noqa: E402
from benchmark.evaluation import EvaluationSettings, evaluate_split  # noqa: E402
from benchmark.evaluation.latent import WIND_RESAMPLE_WINDOWS, _encoded, _latent_energy, resolve_extractor  # noqa: E402
from benchmark.evaluation.sample_size import LEVEL, ordering_probability, smallest_reliable_size  # noqa: E402
from benchmark.metrics.frechet import (  # noqa: E402
    EXTRAPOLATION_DRAWS,
    GroupMoments,
    frechet_distance_from_stats,
    frechet_extrapolation,
)
from benchmark.metrics.windows import cut_windows  # noqa: E402
from benchmark.metrics.wind import gmm_components, wind_from_gmms  # noqa: E402
from blendvoca.runtime.progress import progress_bars  # noqa: E402

ROWS = ("oracle-sample", "oracle-mean")
#: Mixture components of WInD (the protocol's ``wind_components``), one fit per side and split.
WIND_COMPONENTS = 5
#: Per-sentence metrics read from the evaluation (those the split's dataset gives).
SENTENCE_METRICS = ("energy_rig", "energy_mesh", "lve_rig")
#: metric -> (higher is better, the row expected to be better).
EXPECTED = {"fd": (False, "oracle-sample"), "fd_inf": (False, "oracle-sample"), "wind": (False, "oracle-sample"),
            "energy_latent": (False, "oracle-sample"), "energy_rig": (False, "oracle-sample"),
            "energy_mesh": (False, "oracle-sample"), "lve_rig": (False, "oracle-mean")}


def _sizes(text: str) -> list[int]:
    try:
        sizes = sorted({int(part) for part in text.split(",") if part.strip()})
    except ValueError:
        sizes = []
    if not sizes or sizes[0] < 2:
        raise argparse.ArgumentTypeError(f"expected comma-separated sizes >= 2 (4,8,16), got {text!r}")
    return sizes


def scored_split(data: str, split: str, samples: int, seed: int, cache: Path | None) -> dict:
    """The split's latent features and per-sentence values of both oracle rows:
    ``{"keys", "real", "real_owner", "fake": {row: (N, D)}, "fake_owner": {row: (N,)},
    "sentence": {row: {metric: (sentences,)}}}``, read from ``cache`` when it holds them."""
    from oracle_exam import oracle_rows  # the exam's rows: one implementation (perf/ is on sys.path)

    stored = None if cache is None else cache / f"sample-size-{split}-s{samples}-seed{seed}.npz"
    if stored is not None and stored.is_file():
        with np.load(stored, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            return {"keys": [tuple(k) for k in meta["keys"]], "real": z["real"], "real_owner": z["real_owner"],
                    "fake": {r: z[f"fake_{r}"] for r in ROWS}, "fake_owner": {r: z[f"owner_{r}"] for r in ROWS},
                    "sentence": {r: {m: np.asarray(v) for m, v in meta["sentence"][r].items()} for r in ROWS},
                    "seconds": meta["seconds"]}
    start = time.perf_counter()
    dataset = open_blendvoca(data)
    if not dataset.has_oracle():
        raise SystemExit(f"error: {data}: expected a build with oracle tracks (a corpus generated with "
                         "--oracle-samples K), got none")
    rows = oracle_rows(dataset, split, samples=samples, noise=None, seed=seed)
    keys = sorted(rows["oracle-sample"])
    index = {key: i for i, key in enumerate(keys)}
    ground_truth = {key: dataset.coeffs(*key) for key in keys}
    extractor = resolve_extractor(None)
    out = {"keys": keys, "fake": {}, "fake_owner": {}, "sentence": {}}
    with progress_bars(False):
        for row in ROWS:
            windows = cut_windows(ground_truth, rows[row])
            if "real" not in out:
                out["real"] = _encoded(extractor, windows.real, "encode ground truth")
                out["real_owner"] = np.array([index[key] for key, _ in windows.real_keys])
            fake = _encoded(extractor, windows.fake, f"encode {row}")
            out["fake"][row] = fake
            out["fake_owner"][row] = np.array([index[key] for key, _, _ in windows.fake_keys])
            energy = _latent_energy(out["real"], windows.real_keys, fake, windows.fake_keys)
            values = {"energy_latent": np.array([float(energy[key].mean()) for key in keys])}
            scores = evaluate_split(rows[row], dataset, split, EvaluationSettings(seed=seed, lipsync=False,
                                                                                  resamples=10),
                                    metrics=SENTENCE_METRICS)
            per_key = {(r["subject"], r["sentence"]): r for r in scores.per_sentence}
            for metric in SENTENCE_METRICS:
                if all(metric in per_key.get(key, {}) for key in keys):
                    values[metric] = np.array([float(per_key[key][metric]) for key in keys])
            out["sentence"][row] = values
    out["seconds"] = time.perf_counter() - start
    if stored is not None:
        stored.parent.mkdir(parents=True, exist_ok=True)
        meta = {"keys": [list(k) for k in keys], "seconds": out["seconds"],
                "sentence": {r: {m: v.tolist() for m, v in out["sentence"][r].items()} for r in ROWS}}
        partial = stored.with_suffix(".partial.npz")
        np.savez(partial, meta=json.dumps(meta), real=out["real"], real_owner=out["real_owner"],
                 **{f"fake_{r}": out["fake"][r] for r in ROWS}, **{f"owner_{r}": out["fake_owner"][r] for r in ROWS})
        partial.replace(stored)
    return out


def split_draws(total: int, sizes, subsets: int, seed: int) -> dict:
    """``{n: [sentence indices of each random split of n]}``; one split (all) where n >= total."""
    rng = np.random.default_rng(seed)
    return {n: [np.arange(total)] if n >= total else [np.sort(rng.choice(total, n, replace=False))
                                                      for _ in range(subsets)]
            for n in sizes}


def exam(scored: dict, sizes, *, subsets: int, wind_subsets: int, seed: int,
         fd_inf_draws: int = EXTRAPOLATION_DRAWS, metrics=None) -> dict:
    """Per size and metric: each row's values on the random splits, the ordering
    probability and the mean values; per metric the smallest reliable size (``metrics``:
    only these; default all)."""
    total = len(scored["keys"])
    real = GroupMoments(scored["real"], scored["real_owner"])
    fake = {row: GroupMoments(scored["fake"][row], scored["fake_owner"][row]) for row in ROWS}
    draws = split_draws(total, sizes, subsets, seed)
    sentence_metrics = [m for m in scored["sentence"]["oracle-sample"] if m in scored["sentence"]["oracle-mean"]]
    results = {"sizes": {}, "smallest": {}}
    for n, splits in draws.items():
        values = {m: {row: [] for row in ROWS} for m in ("fd", "fd_inf", "wind", *sentence_metrics)
                  if metrics is None or m in metrics}
        started = time.perf_counter()
        for d, chosen in enumerate(splits):
            for row in ROWS:
                if "fd" in values:
                    values["fd"][row].append(frechet_distance_from_stats(*fake[row].statistics(chosen),
                                                                         *real.statistics(chosen)))
                if "fd_inf" in values:
                    values["fd_inf"][row].append(frechet_extrapolation(
                        fake[row].subset(chosen), real.subset(chosen), draws=fd_inf_draws, seed=seed + d).value)
                for m in sentence_metrics:
                    if m in values:
                        values[m][row].append(float(scored["sentence"][row][m][chosen].mean()))
                if "wind" in values and d < wind_subsets:
                    if row == ROWS[0]:
                        y = scored["real"][np.isin(scored["real_owner"], chosen)]
                        real_gmm = gmm_components(y, min(WIND_COMPONENTS, len(y)), seed=seed)
                    x = scored["fake"][row][np.isin(scored["fake_owner"][row], chosen)]
                    if len(x) > WIND_RESAMPLE_WINDOWS:  # as the evaluation's refits: a seeded subsample
                        x = x[np.random.default_rng(seed + d).choice(len(x), WIND_RESAMPLE_WINDOWS, replace=False)]
                    gmm = gmm_components(x, min(WIND_COMPONENTS, len(x)), seed=seed)
                    values["wind"][row].append(float(wind_from_gmms(gmm, real_gmm)))
        entry = {"splits": len(splits), "seconds": time.perf_counter() - started, "metrics": {}}
        for metric, per_row in values.items():
            higher, better = EXPECTED[metric]
            worse = next(r for r in ROWS if r != better)
            entry["metrics"][metric] = {
                "probability": ordering_probability(per_row[better], per_row[worse], higher),
                "draws": len(per_row[better]),
                "mean": {row: float(np.mean(per_row[row])) for row in ROWS},
                "values": {row: [float(f"{v:.6g}") for v in per_row[row]] for row in ROWS}}
        results["sizes"][n] = entry
        print(f"size {n}: {len(splits)} splits in {entry['seconds']:.1f} s", file=sys.stderr, flush=True)
    # a probability needs several splits: the whole test split (one draw) is reported, not decided on
    drawn = [n for n in sizes if results["sizes"][n]["splits"] > 1]
    for metric in values:
        probabilities = {n: results["sizes"][n]["metrics"][metric]["probability"] for n in drawn}
        results["smallest"][metric] = smallest_reliable_size(probabilities, LEVEL) if drawn else None
    return results


def markdown(results: dict, sizes, total: int) -> str:
    """The exam's table: per metric the ordering probability at each size and the smallest reliable size."""
    metrics = list(results["smallest"])
    lines = ["| metric | " + " | ".join(f"n = {n}" for n in sizes) + f" | smallest n (P >= {LEVEL}) |",
             "|---|" + "---:|" * (len(sizes) + 1)]
    for metric in metrics:
        cells = []
        for n in sizes:
            m = results["sizes"][n]["metrics"][metric]
            cells.append(f"{m['probability']:.2f} ({m['draws']})" if m["draws"] > 1 else
                         ("right" if m["probability"] == 1 else "wrong") + " (whole split)")
        smallest = results["smallest"][metric]
        largest = max((n for n in sizes if results["sizes"][n]["splits"] > 1), default=None)
        lines.append(f"| {metric} | " + " | ".join(cells) + " | "
                     + (str(smallest) if smallest is not None else f"> {largest} (not reached)") + " |")
    lines += ["", "| metric | row | " + " | ".join(f"n = {n}" for n in sizes) + " |",
              "|---|---|" + "---:|" * len(sizes)]
    for metric in metrics:
        for row in ROWS:
            lines.append(f"| {metric} | {row} | " + " | ".join(
                f"{results['sizes'][n]['metrics'][metric]['mean'][row]:.4g}" for n in sizes) + " |")
    return "\n".join(lines) + f"\n\n(test split of {total} sentences; cells: P(right order) (splits drawn), " \
                              "the whole split's order where it is one split; second table: mean value over the " \
                              "splits)\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="a BlendVOCA build of a synthetic corpus with oracle tracks")
    parser.add_argument("--split", default="test")
    parser.add_argument("--samples", type=int, default=8, help="S of oracle-sample")
    parser.add_argument("--sizes", type=_sizes, default=_sizes("4,8,16,24,32,40,80"),
                        help="test-split sizes n in sentences, comma-separated (default 4,8,16,24,32,40,80)")
    parser.add_argument("--subsets", type=int, default=200, help="random splits per size")
    parser.add_argument("--wind-subsets", type=int, default=20, help="of which scored with WInD")
    parser.add_argument("--fd-inf-draws", type=int, default=EXTRAPOLATION_DRAWS,
                        help=f"subsets per size of each FD_inf extrapolation (default {EXTRAPOLATION_DRAWS})")
    parser.add_argument("--metrics", help=f"only these, comma-separated (default all: {', '.join(EXPECTED)})")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, help="keep the features and per-sentence values here")
    parser.add_argument("--out", type=Path, help="write the figures as JSON here")
    args = parser.parse_args(argv)
    if args.subsets < 1 or args.wind_subsets < 0 or args.fd_inf_draws < 1:
        parser.error(f"--subsets and --fd-inf-draws must be >= 1 and --wind-subsets >= 0, got {args.subsets}, "
                     f"{args.fd_inf_draws} and {args.wind_subsets}")
    metrics = None if args.metrics is None else [m.strip() for m in args.metrics.split(",") if m.strip()]
    if metrics is not None and (not metrics or set(metrics) - set(EXPECTED)):
        parser.error(f"--metrics: expected names among {', '.join(EXPECTED)}, got {args.metrics!r}")
    scored = scored_split(args.data, args.split, args.samples, args.seed, args.cache)
    total = len(scored["keys"])
    sizes = sorted({min(n, total) for n in args.sizes})
    results = exam(scored, sizes, subsets=args.subsets, wind_subsets=args.wind_subsets, seed=args.seed,
                   fd_inf_draws=args.fd_inf_draws, metrics=metrics)
    table = markdown(results, sizes, total)
    print(table)
    if args.out:
        figures = {"data": str(args.data), "split": args.split, "samples": args.samples, "sentences": total,
                   "subsets": args.subsets, "wind_subsets": args.wind_subsets, "fd_inf_draws": args.fd_inf_draws,
                   "seed": args.seed,
                   "scoring_seconds": scored["seconds"], "level": LEVEL, **results, "table": table}
        args.out.write_text(json.dumps(figures, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
