"""Write a coefficient track as Live Link Face CSV, ARKit JSON, Audio2Face JSON, GLB, USD or FBX.

``python -m blendvoca.export --coeffs CSV --format FMT --out FILE [--rig RIG] [--fps F] [--audio WAV
[--copy-audio]] [--clip] [--convention NAME]``.

``fbx`` is written by Blender (a Python with ``bpy``: ``$BLENDVOCA_BPY_PYTHON``). The USD,
FBX and Audio2Face files reference the audio by its path relative to ``--out`` (they
can be moved with it); ``--copy-audio`` copies it beside ``--out`` first.

``--convention`` (``csv`` only) writes the columns of a naming convention of
``blendvoca.names`` (``python -m blendvoca.names list``) in its order and spelling.

Weights outside [0, 1] are refused (the first frame and column named), as the
benchmark refuses them, unless ``--clip`` clips them and says how many moved.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import UserError
from blendvoca.export import FORMATS, NEEDS_RIG, export_track, load_rig
from blendvoca.export.align import check_track, unit_range_track
from blendvoca.io.coeffs import read_coeffs_csv
from blendvoca.names import convention_names


@cli.command
def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.parser("blendvoca.export", __doc__)
    parser.add_argument("--coeffs", required=True, help="coefficient CSV (BlendVOCA/SAiD layout or Live Link Face)")
    parser.add_argument("--format", required=True, choices=FORMATS, dest="fmt")
    parser.add_argument("--out", required=True, help="output file (.usda text or .usdc/.usd binary for usd)")
    parser.add_argument("--rig", help="rig .npz or SAiD folder (needed by glb, usd and fbx)")
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate of the track (default 60)")
    parser.add_argument("--audio", help="WAV of the speech (a2f-json trackPath, usd sound prim; referenced by its "
                                        "path relative to --out)")
    parser.add_argument("--copy-audio", action="store_true",
                        help="copy --audio beside --out and reference the copy (the two then move together)")
    parser.add_argument("--clip", action="store_true",
                        help="clip weights outside [0, 1] into it (and say how many moved) instead of refusing "
                             "the track")
    parser.add_argument("--convention", default=None, metavar="NAME",
                        help="csv only: the columns of this naming convention (python -m blendvoca.names list), "
                             "in its order and spelling")
    args = parser.parse_args(argv)
    if args.convention is not None:
        if args.fmt != "csv":
            raise UserError(f"--convention applies to --format csv only; {args.fmt} has its own columns")
        convention_names(args.convention)  # an unknown name, or one without a fixed order, is refused now
    if args.fmt in NEEDS_RIG and not args.rig:
        raise UserError(f"--format {args.fmt} needs --rig (a rig .npz or SAiD folder)")
    if not args.fps > 0:
        raise UserError(f"--fps must be positive, got {args.fps}")
    if args.audio and not Path(args.audio).is_file():
        raise UserError(f"audio file not found: {args.audio}")
    rig = load_rig(args.rig) if args.rig else None
    coeffs, names = read_coeffs_csv(args.coeffs)
    # checked here too so that a bad value is reported against the file the user gave
    coeffs, _ = check_track(coeffs, names, where=args.coeffs)
    coeffs, clipped = unit_range_track(coeffs, names, where=args.coeffs, clip=args.clip)
    if args.copy_audio and not args.audio:
        raise UserError("--copy-audio needs --audio")
    aligned = export_track(args.out, coeffs, names, args.fmt, rig=rig, fps=args.fps, audio=args.audio,
                           convention=args.convention, copy_audio=args.copy_audio)
    aligned = dataclasses.replace(aligned, clipped=clipped)
    for note in aligned.notes():
        print(note, file=sys.stderr)
    print(f"wrote {args.out} ({args.fmt}, {len(aligned.coeffs)} frames at {args.fps:g} fps, {len(aligned.names)} shapes)")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
