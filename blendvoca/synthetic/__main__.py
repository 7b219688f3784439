"""``python -m blendvoca.synthetic --out DIR --speakers N --sentences M --seed S``."""

from __future__ import annotations

import argparse
import sys
import time

from blendvoca.synthetic.corpus import DEFAULT_CORPUS, generate_corpus


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m blendvoca.synthetic",
                                     description="Generate a synthetic VOCASET corpus with ground truth.")
    parser.add_argument("--out", required=True, help="output folder (must not exist or be empty)")
    parser.add_argument("--speakers", type=int, default=DEFAULT_CORPUS["speakers"], help="number of speakers (>= 3)")
    parser.add_argument("--sentences", type=int, default=DEFAULT_CORPUS["sentences"], help="sentences per speaker")
    parser.add_argument("--seed", type=int, default=DEFAULT_CORPUS["seed"])
    parser.add_argument("--layout", choices=("official", "processed"), default="official")
    parser.add_argument("--min-duration", type=float, default=DEFAULT_CORPUS["duration"][0], help="seconds")
    parser.add_argument("--max-duration", type=float, default=DEFAULT_CORPUS["duration"][1], help="seconds")
    parser.add_argument("--frame-faces", action="store_true", help="store triangles in every frame PLY")
    parser.add_argument("--head-motion", nargs="?", type=float, const=3.0, default=0.0, metavar="DEG",
                        help="also write posed frames (registereddata/) with a smooth head motion of up to DEG "
                             "degrees per axis (default 3), recorded in the ground truth")
    parser.add_argument("--overwrite", action="store_true")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    try:
        out = generate_corpus(args.out, speakers=args.speakers, sentences=args.sentences, seed=args.seed,
                              layout=args.layout, duration=(args.min_duration, args.max_duration),
                              frame_faces=args.frame_faces, head_motion=args.head_motion or False,
                              overwrite=args.overwrite, progress=not args.quiet)
    except (ValueError, FileExistsError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"wrote {out} ({args.layout} layout, {args.speakers} x {args.sentences}) in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
