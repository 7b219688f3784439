"""``python -m blendvoca.export``: write a coefficient track as Live Link Face CSV, ARKit
JSON, Audio2Face JSON, GLB or USD."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path


def main(argv: Sequence[str] | None = None) -> int:
    from blendvoca.export import FORMATS, NEEDS_RIG, export_track, load_rig

    parser = argparse.ArgumentParser(prog="python -m blendvoca.export", description=__doc__)
    parser.add_argument("--coeffs", required=True, help="coefficient CSV (BlendVOCA/SAiD layout or Live Link Face)")
    parser.add_argument("--format", required=True, choices=FORMATS, dest="fmt")
    parser.add_argument("--out", required=True, help="output file (.usda text or .usdc/.usd binary for usd)")
    parser.add_argument("--rig", help="rig .npz or SAiD folder (needed by glb and usd)")
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate of the track (default 60)")
    parser.add_argument("--audio", help="WAV of the speech (a2f-json trackPath, usd sound prim)")
    args = parser.parse_args(argv)

    from blendvoca.io.coeffs import read_coeffs_csv

    try:
        if args.fmt in NEEDS_RIG and not args.rig:
            raise ValueError(f"--format {args.fmt} needs --rig (a rig .npz or SAiD folder)")
        if args.fps <= 0:
            raise ValueError(f"--fps must be positive, got {args.fps}")
        if args.audio and not Path(args.audio).is_file():
            raise FileNotFoundError(f"audio file not found: {args.audio}")
        rig = load_rig(args.rig) if args.rig else None
        coeffs, names = read_coeffs_csv(args.coeffs)
        aligned = export_track(args.out, coeffs, names, args.fmt, rig=rig, fps=args.fps, audio=args.audio)
    except (ValueError, FileNotFoundError, ImportError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    for note in aligned.notes():
        print(note, file=sys.stderr)
    print(f"wrote {args.out} ({args.fmt}, {len(aligned.coeffs)} frames at {args.fps:g} fps, {len(aligned.names)} shapes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
