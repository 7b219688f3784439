"""Command line of the results browser: ``python -m leaderboard.site --results DIR --out SITE [--serve]``."""

from __future__ import annotations

import argparse
import sys

from . import build_site
from .serve import serve_site


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m leaderboard.site",
                                description="Generate the static results browser from stored runs.")
    p.add_argument("--results", required=True, help="folder of result JSON files with their stored tracks")
    p.add_argument("--out", required=True, help="site folder (new, empty, or a site written before)")
    p.add_argument("--data", default=None,
                   help="BlendVOCA build to use for the runs scored on it (default: the path each run recorded)")
    p.add_argument("--samples", type=int, default=3, help="samples per sentence of a stochastic run for playback")
    p.add_argument("--serve", action="store_true", help="serve the site on localhost afterwards")
    p.add_argument("--port", type=int, default=8000, help="port for --serve (0: any free port)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.samples < 1:
        print(f"error: --samples: expected >= 1, got {args.samples}", file=sys.stderr)
        return 2
    try:
        out = build_site(args.results, args.out, data=args.data, max_samples=args.samples, progress=not args.quiet)
    except (FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"site written to {out}; open it through a web server (browsers refuse file:// modules), e.g. "
          f"python -m leaderboard.site --results {args.results} --out {args.out} --serve", file=sys.stderr)
    if args.serve:
        serve_site(out, port=args.port)
    return 0


if __name__ == "__main__":
    sys.exit(main())
