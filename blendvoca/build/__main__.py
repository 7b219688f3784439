"""``python -m blendvoca.build [--vocaset DIR] [--out DIR] [--workers N] [--shapes speech|all]``."""

from __future__ import annotations

import argparse
import sys
import time

from blendvoca.build.pipeline import build_dataset, default_output_dir
from blendvoca.errors import BlendVOCAError, error_line


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m blendvoca.build",
        description="Build BlendVOCA (speaker rigs + fitted coefficient tracks) from VOCASET. "
        "Resumable: rerun the same command after an interruption.",
    )
    parser.add_argument("--vocaset", default=None,
                        help="VOCASET root (official or processed layout); default: the bundled synthetic corpus")
    parser.add_argument("--out", default=None,
                        help="output folder (required with --vocaset; default for the bundled corpus: "
                        "<user cache>/blendvoca-default, where the benchmark looks for it)")
    parser.add_argument("--workers", type=int, default=None, help="processes, >= 1 (default: all cores)")
    parser.add_argument("--shapes", choices=("speech", "all"), default="speech",
                        help="the 32 BlendVOCA shapes or all ARKit shapes")
    parser.add_argument("--delta", type=float, default=0.1, help="rate bound |u[t+1] - u[t]| per 60 fps frame (> 0)")
    parser.add_argument("--no-report", action="store_true", help="skip report/")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    if args.out is None:
        if args.vocaset is not None:
            parser.error("--out is required with --vocaset")
        args.out = default_output_dir()
    start = time.perf_counter()
    try:
        summary = build_dataset(args.out, args.vocaset, workers=args.workers, shapes=args.shapes,
                                delta=args.delta, report=not args.no_report, progress=not args.quiet)
    except KeyboardInterrupt:
        print("interrupted: rerun the same command to continue", file=sys.stderr)
        return 130
    except (BlendVOCAError, ValueError, OSError) as error:  # user input, assets, output folder
        print(error_line(error), file=sys.stderr)
        return 2
    elapsed = time.perf_counter() - start
    print(f"{summary.out}: speakers built {summary.built['speakers']}, up to date {summary.skipped['speakers']}; "
          f"sentences built {summary.built['sentences']}, up to date {summary.skipped['sentences']}; "
          f"{len(summary.failures)} failed; {elapsed:.1f} s")
    for failure in summary.failures:
        print(f"FAILED {failure['subject']} {failure['sentence'] or ''} ({failure['stage']}): {failure['reason']}",
              file=sys.stderr)
    if summary.failures:
        print(f"{len(summary.failures)} item(s) failed (listed above, in report/README.md and in manifest.json "
              "failures); the other outputs are complete", file=sys.stderr)
    return 1 if summary.failures else 0


if __name__ == "__main__":
    sys.exit(main())
