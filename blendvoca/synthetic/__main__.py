"""Generate a synthetic VOCASET corpus with ground truth.

``python -m blendvoca.synthetic --out DIR --speakers N --sentences M --seed S
[--audio-determined F] [--oracle-samples K] [--head-motion DEG] [--layout processed|official]``.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import UserError
from blendvoca.io.json_file import read_json
from blendvoca.synthetic.corpus import DEFAULT_AUDIO_DETERMINED, DEFAULT_CORPUS, generate_corpus


def check_arguments(args) -> None:
    """Refuse bad arguments before anything is written: one :class:`UserError` naming them all."""
    problems = []
    if args.speakers < 3:
        problems.append(f"--speakers: expected >= 3 (train/val/test), got {args.speakers}")
    if not 1 <= args.sentences <= 99:
        problems.append(f"--sentences: expected 1 to 99, got {args.sentences}")
    if args.seed < 0:
        problems.append(f"--seed: expected >= 0, got {args.seed}")
    low, high = args.min_duration, args.max_duration
    if not (math.isfinite(low) and math.isfinite(high) and 0 < low <= high):
        problems.append(f"--min-duration/--max-duration: expected 0 < min <= max seconds, got {low} and {high}")
    if not (math.isfinite(args.head_motion) and 0 <= args.head_motion <= 45):
        problems.append(f"--head-motion: expected 0 to 45 degrees, got {args.head_motion}")
    if not (math.isfinite(args.audio_determined) and 0 < args.audio_determined <= 1):
        problems.append(f"--audio-determined: expected 0 < F <= 1, got {args.audio_determined}")
    if not 0 <= args.oracle_samples <= 1000:
        problems.append(f"--oracle-samples: expected 0 to 1000, got {args.oracle_samples}")
    out = Path(args.out).expanduser()
    if out.exists() and not out.is_dir():
        problems.append(f"--out {out} is a file; expected a new or empty folder")
    elif args.overwrite and out.is_dir() and any(out.iterdir()) and not (out / "synthetic.json").is_file():
        problems.append(f"--overwrite: {out} is not a synthetic corpus (no synthetic.json); "
                        "refusing to replace a folder this tool did not write")
    if problems:
        raise UserError("; ".join(problems))


@cli.command
def main(argv: list[str] | None = None) -> int:
    parser = cli.parser("blendvoca.synthetic", __doc__)
    parser.add_argument("--out", required=True, help="output folder (must not exist or be empty)")
    parser.add_argument("--speakers", type=int, default=DEFAULT_CORPUS["speakers"], help="number of speakers (>= 3)")
    parser.add_argument("--sentences", type=int, default=DEFAULT_CORPUS["sentences"], help="sentences per speaker (1-99)")
    parser.add_argument("--seed", type=int, default=DEFAULT_CORPUS["seed"], help=">= 0")
    parser.add_argument("--layout", choices=("official", "processed"), default="official")
    parser.add_argument("--min-duration", type=float, default=DEFAULT_CORPUS["duration"][0], help="seconds (> 0)")
    parser.add_argument("--max-duration", type=float, default=DEFAULT_CORPUS["duration"][1], help="seconds (>= min)")
    parser.add_argument("--frame-faces", action="store_true", help="store triangles in every frame PLY")
    parser.add_argument("--head-motion", nargs="?", type=float, const=3.0, default=0.0, metavar="DEG",
                        help="also write posed frames (registereddata/) with a smooth head motion of up to DEG "
                             "degrees per axis (default 3), recorded in the ground truth")
    parser.add_argument("--audio-determined", type=float, default=DEFAULT_AUDIO_DETERMINED, metavar="F",
                        help="share of the speech shapes' motion variance that the audio and the speaker id "
                             f"determine, 0 < F <= 1 (default {DEFAULT_AUDIO_DETERMINED}; 1: no undetermined "
                             "components, generator version 1's corpus)")
    parser.add_argument("--oracle-samples", type=int, default=0, metavar="K",
                        help="also write K conditional samples of every sentence's motion (oracle/), which the "
                             "build fits for the oracle-sample and oracle-mean reference rows (default 0)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing synthetic corpus in --out")
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    check_arguments(args)
    # FileExistsError, a read-only folder or a full disk are OSErrors: the command layer reports them (exit 2).
    out = generate_corpus(args.out, speakers=args.speakers, sentences=args.sentences, seed=args.seed,
                          layout=args.layout, duration=(args.min_duration, args.max_duration),
                          frame_faces=args.frame_faces, head_motion=args.head_motion or False,
                          overwrite=args.overwrite,
                          audio_determined=args.audio_determined, oracle_samples=args.oracle_samples)
    print(f"wrote {out} ({args.layout} layout, {args.speakers} x {args.sentences}) in {time.perf_counter() - start:.1f} s")
    print(share_summary(out))
    return cli.EXIT_OK


def share_summary(out) -> str:
    """One line on the corpus's audio-determined share: declared, and measured when it has oracle samples."""
    meta = read_json(Path(out) / "synthetic.json", what="the synthetic-corpus sidecar")
    declared = meta.get("audio_determined", {}).get("declared", 1.0)
    oracle = meta.get("oracle_samples") or {}
    measured = oracle.get("measured_signal_share")
    if measured is None:
        return (f"audio-determined share: declared F = {declared:g} (measured on the fitted coefficients by the "
                "build of a corpus generated with --oracle-samples K)")
    return (f"audio-determined share: declared F = {declared:g}; measured on the speech driving signals over the "
            f"ground truth and {oracle['count']} oracle samples: {measured:.3f} (the build reports it on the "
            "fitted coefficients)")


if __name__ == "__main__":
    sys.exit(main())
