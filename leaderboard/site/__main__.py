"""Generate the static results browser from stored runs.

``python -m leaderboard.site --results DIR --out SITE [--serve]``.
"""

from __future__ import annotations

import sys

from blendvoca import cli
from blendvoca.errors import UserError

from . import build_site
from .serve import serve_site


def _parser() -> cli.Parser:
    p = cli.parser("leaderboard.site", __doc__)
    p.add_argument("--out", required=True, help="site folder (new, empty, or a site written before)")
    p.add_argument("--samples", type=int, default=3, help="samples per sentence of a stochastic run for playback")
    p.add_argument("--serve", action="store_true", help="serve the site on localhost afterwards")
    p.add_argument("--port", type=int, default=8000, help="port for --serve (0: any free port)")
    cli.add_results_option(p, required=True, help="folder of result JSON files with their stored tracks")
    cli.add_data_option(p, help="BlendVOCA build to use for the runs scored on it (default: the path each run "
                                "recorded)")
    cli.add_quiet_option(p)
    return p


@cli.command
def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.samples < 1:
        raise UserError(f"--samples: expected >= 1, got {args.samples}")
    out = build_site(args.results, args.out, data=args.data, max_samples=args.samples)
    if args.serve:
        print(f"site written to {out}", file=sys.stderr)
        serve_site(out, port=args.port)
    else:
        print(f"site written to {out}; open it through a web server (browsers refuse file:// modules), e.g. "
              f"python -m leaderboard.site --results {args.results} --out {args.out} --serve", file=sys.stderr)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
