"""Latency of the chunked methods on the bundled default, as the runner measures it.

Each method is trained for a few steps (latency hardly depends on the weights) and
timed by :func:`benchmark.protocol.generation.measure_latency` on the first test
sentences: the look-ahead it declares, the time to its first frame, CPU seconds and
wall seconds (the real-time factor) per second of audio; then the look-ahead it was
seen to use (the causality probe, :mod:`benchmark.protocol.lookahead`), whether that
was the whole utterance, and the probe's cost. ``benchmark.run`` stores the same
record in every result (``latency``) after scoring.

    BLENDVOCA_CACHE=... python perf/bench_latency.py                       # said faceformer codetalker cdface
    python perf/bench_latency.py --methods said --max-steps 50 --sentences 3
    python perf/bench_latency.py --methods regression said --chunk-frames 120 --chunk-overlap 30
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

METHODS = ("said", "faceformer", "codetalker", "cdface")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--max-steps", type=int, default=20, help="training steps per method (default 20)")
    parser.add_argument("--sentences", type=int, default=3, help="test sentences timed (default 3)")
    parser.add_argument("--chunk-frames", type=int, default=None,
                        help="chunk length of the chunked methods, " + ", ".join(METHODS)
                             + " (config chunk_frames; default theirs)")
    parser.add_argument("--chunk-overlap", type=int, default=None, help="their chunk_overlap (default theirs)")
    args = parser.parse_args(argv)

    import torch  # noqa: F401 - loaded first: limit_threads reaches the libraries loaded now

    from benchmark.methods import Budget, TrainingRequest, get_method
    from benchmark.protocol.generation import measure_latency
    from benchmark.protocol.spec import default_data_root, open_data
    from blendvoca.runtime.progress import progress_bars
    from blendvoca.runtime.threads import limit_threads

    limit_threads(1, torch_only=True)
    with progress_bars(False):
        dataset = open_data(default_data_root())
    print(f"{'method':>11} {'lookahead (s)':>14} {'first frame (s)':>16} {'CPU s / audio s':>16} {'RTF':>7} "
          f"{'measured (s)':>13} {'whole':>6} {'probe calls':>12} {'probe (s)':>10}")
    for name in args.methods:
        cls = get_method(name)
        chunked = {key: value for key, value in (("chunk_frames", args.chunk_frames),
                                                 ("chunk_overlap", args.chunk_overlap))
                   if value is not None and name in METHODS}
        method = cls(**chunked)
        method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=args.max_steps)))
        lat = measure_latency(method, dataset, split="test", seed=0, name=name, sentences=args.sentences)
        look = "whole" if lat["lookahead_s"] is None else f"{lat['lookahead_s']:.2f}"
        probe = lat["lookahead_probe"]
        measured = "-" if lat["measured_lookahead_s"] is None else f"{lat['measured_lookahead_s']:.3f}"
        print(f"{name:>11} {look:>14} {lat['first_frame_s']:>16.3f} {lat['compute_per_audio_s']:>16.3f} "
              f"{lat['rtf']:>7.3f} {measured:>13} {str(probe['whole_utterance']).lower():>6} "
              f"{probe['generate_calls']:>12} {probe['wall_s']:>10.2f}", flush=True)
        for cut in probe["probes"]:
            print(f"{'':>11}   {cut['subject']}/{cut['sentence']} ({cut['duration_s']:.2f} s): cut at "
                  f"{cut['cut_s']:.3f} s, first change at {cut['changed_from_s']} s -> {cut['lookahead_s']:.3f} s",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
