"""Wall time of a whole build and where it goes (rigs, sentence fits, summary).

    python perf/bench_build.py --speakers 12 --sentences 40 --workers 2 --work /tmp/bv12x40
    python perf/bench_build.py --default --workers 2 --work /tmp/bvdefault

Generates the synthetic corpus (processed layout for the VOCASET-size run, to
keep disk use sane) unless present, builds, then reruns the finished build
(which must do nothing) and prints both timings. Also times one sentence's
stages in-process (read frames, fit, write) against the fit alone.

    python perf/bench_build.py --rig-reuse --speakers 12 --sentences 1 --work /tmp/bv12x1

``--rig-reuse`` times the rig stage's computation in this process (one BLAS
thread, every speaker in turn): one correspondence per speaker (the previous
build) against one correspondence shared by all speakers (the build now), and
checks that the reference speaker's rig is identical either way.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", required=True, help="folder for the corpus and the build")
    parser.add_argument("--speakers", type=int, default=12)
    parser.add_argument("--sentences", type=int, default=40)
    parser.add_argument("--default", action="store_true", help="the bundled default corpus instead")
    parser.add_argument("--layout", default="processed", choices=("official", "processed"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rig-reuse", action="store_true",
                        help="only the rig stage, with and without the shared correspondence")
    args = parser.parse_args(argv)

    from blendvoca.builder import build_dataset
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
    if args.rig_reuse:
        rig_reuse(corpus)
        return
    out = work / "BlendVOCA"
    for label in ("build", "rerun (nothing to do)"):
        start = time.perf_counter()
        summary = build_dataset(out, corpus, workers=args.workers)
        total = time.perf_counter() - start
        stages = ", ".join(f"{k} {v:.1f} s" for k, v in summary.seconds.items())
        print(f"{label}: {total:.1f} s wall on {args.workers} workers ({stages}); built {summary.built}, "
              f"up to date {summary.skipped}, failures {len(summary.failures)}")


def rig_reuse(corpus_root):
    """Print the rig stage's compute time without and with the shared correspondence, and the ratio."""
    import numpy as np

    from blendvoca.assets import load_index_list
    from blendvoca.builder.speaker import speaker_rig
    from blendvoca.retarget import correspondence_for_target
    from blendvoca.rig import load_arkit_reference
    from blendvoca.runtime.threads import limited_threads
    from blendvoca.vocaset import open_vocaset

    corpus = open_vocaset(corpus_root)
    reference = load_arkit_reference("speech")
    ref_lm, flame_lm = load_index_list("arkit-landmarks"), load_index_list("flame-landmarks")
    head = load_index_list("flame-head-idx")
    templates = {s: corpus.template(s) for s in corpus.subjects}
    faces = corpus.faces
    with limited_threads(1):
        start = time.perf_counter()
        own = {s: speaker_rig(reference, t, faces, ref_lm, flame_lm, head) for s, t in templates.items()}
        separate = time.perf_counter() - start
        start = time.perf_counter()
        first = corpus.subjects[0]
        shared = correspondence_for_target(reference.neutral, reference.faces, templates[first], faces,
                                           ref_lm, flame_lm, crop=head)
        reused = {s: speaker_rig(reference, t, faces, ref_lm, flame_lm, head, correspondence=shared)
                  for s, t in templates.items()}
        together = time.perf_counter() - start
    same = np.array_equal(own[first].deltas, reused[first].deltas)
    spread = max(float(np.abs(own[s].deltas - reused[s].deltas).max()) for s in templates)
    print(f"rig stage, {len(templates)} speakers, 1 process: one correspondence per speaker {separate:.1f} s, "
          f"one shared {together:.1f} s, ratio {separate / together:.2f}x; reference speaker's rig identical: "
          f"{same}; largest delta difference over speakers {spread * 1000:.3f} mm")


if __name__ == "__main__":
    try:
        main()
    except ValueError as exc:  # bad arguments (e.g. --speakers 2): the message, not a traceback
        sys.exit(f"bench_build: {exc}")
