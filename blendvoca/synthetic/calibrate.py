"""Measure the audio-determined share against the components' scale: the table behind ``--audio-determined``.

``python -m blendvoca.synthetic.calibrate --out DIR [--scales 0,0.5,1,...] [--speakers N] [--sentences M]
[--oracle-samples K] [--seed S]`` generates one corpus per scale with K oracle samples,
builds each (the rigs are shared: the speakers do not depend on the scale) and
prints, per scale, the share of the speech shapes' coefficient variance that the
conditional mean explains (:func:`blendvoca.builder.report.measured_share`), as
the ``CALIBRATION`` rows of :mod:`blendvoca.synthetic.variation`.
"""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

from blendvoca import cli
from blendvoca.builder import build_dataset
from blendvoca.builder.report import measured_share
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.runtime.progress import progress_bars
from blendvoca.synthetic.corpus import generate_corpus
from blendvoca.vocaset import open_vocaset


def measure(out: Path, *, scale: float, speakers: int, sentences: int, oracle_samples: int, seed: int,
            duration=(3.0, 5.0), workers: int | None = None) -> dict:
    """Generate and build one corpus at ``scale``; return :func:`measured_share`'s dict plus timings."""
    corpus = out / f"corpus-{scale:g}"
    build = out / "build"
    start = time.perf_counter()
    with progress_bars(False):
        generate_corpus(corpus, speakers=speakers, sentences=sentences, seed=seed, duration=duration,
                        audio_determined=0.5, oracle_samples=oracle_samples, overwrite=True, _scale=scale)
        generated = time.perf_counter() - start
        summary = build_dataset(build, corpus, workers=workers, report=False)
    built = time.perf_counter() - start - generated
    opened = open_vocaset(corpus)
    items = [(s, q) for s in opened.subjects for q in opened.sentences(s)]
    share = measured_share(build, opened.splits, items, BLENDVOCA_NAMES, count=oracle_samples,
                           declared={"declared": None, "oracle_samples": oracle_samples})
    shutil.rmtree(corpus)
    return {**share, "scale": scale, "generate_s": generated, "build_s": built, "failures": len(summary.failures)}


@cli.command
def main(argv=None) -> int:
    p = cli.parser("blendvoca.synthetic.calibrate", __doc__)
    p.add_argument("--out", required=True, help="working folder (corpora and one build)")
    p.add_argument("--scales", default="0,0.5,1,1.5,2,3")
    p.add_argument("--speakers", type=int, default=6)
    p.add_argument("--sentences", type=int, default=4)
    p.add_argument("--oracle-samples", type=int, default=6)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--workers", type=int, default=None, help="build processes (default: all cores)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print("scale  measured  test    oracle-mean(test)  generate_s  build_s")
    for scale in (float(x) for x in args.scales.split(",")):
        r = measure(out, scale=scale, speakers=args.speakers, sentences=args.sentences,
                    oracle_samples=args.oracle_samples, seed=args.seed, workers=args.workers)
        print(f"{scale:<6g} {r['measured']:.3f}     {r['measured_test']:.3f}   {r['oracle_mean_test']:.3f}"
              f"              {r['generate_s']:.1f}        {r['build_s']:.1f}  failures {r['failures']}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
