"""Cost of checking a build before scoring it, as a fraction of the scoring itself.

    BLENDVOCA_ASSETS=../shared/assets python perf/bench_verify.py [--data BUILD] [--split test]

``benchmark.run`` checks the files of the split it scores (coefficient tracks, audio,
rigs) against the digests of the build's ``manifest.json`` before anything runs
(``BlendVOCADataset.verify``). This script times that check and the evaluation of
the train-split mean track on the same split (``benchmark.evaluation.evaluate_split``,
as a run scores it) and prints both and their ratio. Without ``--data`` it uses the
bundled-default build (built once if missing); the figure quoted in the docs is on
the 12 x 40 build::

    python -m blendvoca.synthetic --out C12 --speakers 12 --sentences 40 --seed 0 --layout processed
    python -m blendvoca.build --vocaset C12 --out B12

The check runs first, on files the operating system may not have cached yet; the
evaluation then reads them again.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def mean_tracks(dataset, split: str) -> dict:
    """The train-split mean track for every sentence of ``split``, ``(1, T, K)`` each."""
    train = [dataset.coeffs(s, n) for s in dataset.split("train") for n in dataset.sentences(s)]
    mean = np.concatenate(train).mean(axis=0)
    keys = [(s, n) for s in dataset.split(split) for n in dataset.sentences(s)]
    return {k: np.repeat(mean[None], len(dataset.coeffs(*k)), axis=0)[None] for k in keys}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=None, help="BlendVOCA build (default: the bundled default)")
    parser.add_argument("--split", default="test")
    parser.add_argument("--repeat", type=int, default=3, help="times the check is repeated (the best is kept)")
    args = parser.parse_args(argv)

    from benchmark.data import open_blendvoca
    from benchmark.evaluation import evaluate_split
    from blendvoca.runtime.progress import progress_bars
    from benchmark.protocol import default_data_root

    with progress_bars(False):
        root = Path(args.data) if args.data else default_data_root()
    dataset = open_blendvoca(root)
    subjects = dataset.split(args.split)
    files = dataset.scored_files(subjects)
    size = sum((root / rel).stat().st_size for rel in files)
    checks = []
    for _ in range(max(1, args.repeat)):
        start = time.perf_counter()
        dataset.verify(subjects)
        checks.append(time.perf_counter() - start)
    generated = mean_tracks(dataset, args.split)
    start = time.perf_counter()
    with progress_bars(False):
        evaluate_split(generated, dataset, args.split)
    evaluation = time.perf_counter() - start
    print(f"build {root}: split {args.split!r}, {len(subjects)} speakers, {len(generated)} sentences")
    print(f"verify: {len(files)} files, {size / 2**20:.1f} MiB, first {checks[0]:.3f} s, best {min(checks):.3f} s")
    print(f"evaluate (mean track): {evaluation:.2f} s")
    print(f"verify / evaluate: first {100 * checks[0] / evaluation:.2f} %, best {100 * min(checks) / evaluation:.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
