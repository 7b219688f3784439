"""Time of the WInD mixture fits, sequential against parallel, in one process.

    python perf/bench_wind.py [--windows 1500] [--dim 64] [--workers 2]

The evaluation's WInD work for one method: ``repeats`` (10) pairs of seeded GMM
fits (generated and ground-truth features) plus ``resamples`` (20) bootstrap
refits of the generated side, on fabricated VAE-like features (a 5-cluster
mixture). Runs it with ``benchmark.metrics.gmm_components_many`` on 1 process
and on ``--workers`` forked processes, checks the mixtures are bit-identical
and prints both times and their ratio.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--windows", type=int, default=1500, help="feature vectors per side")
    parser.add_argument("--dim", type=int, default=64)
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--resamples", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)

    from benchmark.metrics import gmm_components_many

    rng = np.random.default_rng(0)
    centres = rng.normal(size=(5, args.dim)) * 3

    def features(n):
        return centres[rng.integers(0, 5, n)] + rng.normal(size=(n, args.dim))

    fake, real = features(args.windows), features(args.windows)
    jobs = [(data, 5, r) for r in range(args.repeats) for data in (fake, real)]
    jobs += [(fake[rng.integers(0, len(fake), len(fake))], 5, 0) for _ in range(args.resamples)]
    gmm_components_many(jobs[:2], 1)  # warm-up: imports
    times, results = {}, {}
    for workers in (1, args.workers):
        start = time.perf_counter()
        results[workers] = gmm_components_many(jobs, workers)
        times[workers] = time.perf_counter() - start
    identical = all(np.array_equal(a, b) for x, y in zip(results[1], results[args.workers])
                    for a, b in zip(x, y))
    print(f"{len(jobs)} GMM fits ({args.windows} x {args.dim} features, K = 5): sequential {times[1]:.2f} s, "
          f"{args.workers} processes {times[args.workers]:.2f} s, ratio {times[1] / times[args.workers]:.2f}x; "
          f"bit-identical: {identical}")


if __name__ == "__main__":
    main()
