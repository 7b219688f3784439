"""``python -m blendvoca.build [--vocaset DIR] [--out DIR] [--workers N] [--shapes speech|all]``.

Build BlendVOCA (speaker rigs + fitted coefficient tracks) from VOCASET. Resumable:
rerun the same command after an interruption.

Exit status (:mod:`blendvoca.cli`): 0 everything built, 5 the build ran to its end
but some items failed (each printed as ``FAILED subject sentence (stage): reason``,
and in ``report/README.md`` and the manifest's ``failures``; the other outputs are
complete), 2 a usage, input or output-folder error (nothing built), 130 interrupted
(rerun to continue), 1 an internal bug.
"""

from __future__ import annotations

import sys
import time

from blendvoca import cli
from blendvoca.builder.pipeline import build_dataset, default_output_dir
from blendvoca.format.layout import MANIFEST_FILE, REPORT_DIR


@cli.command
def main(argv: list[str] | None = None) -> int:
    p = cli.parser("blendvoca.build", "Build BlendVOCA (speaker rigs + fitted coefficient tracks) from VOCASET. "
                                      "Resumable: rerun the same command after an interruption.")
    p.add_argument("--vocaset", default=None,
                   help="VOCASET root (official or processed layout); default: the bundled synthetic corpus")
    p.add_argument("--out", default=None,
                   help="output folder (required with --vocaset; default for the bundled corpus: "
                        "<user cache>/blendvoca-default, where the benchmark looks for it)")
    p.add_argument("--workers", type=int, default=None, help="processes, >= 1 (default: all cores)")
    p.add_argument("--shapes", choices=("speech", "all"), default="speech",
                   help="the 32 BlendVOCA shapes or all ARKit shapes")
    p.add_argument("--delta", type=float, default=0.1, help="rate bound |u[t+1] - u[t]| per 60 fps frame (> 0)")
    p.add_argument("--no-report", action="store_true", help=f"skip {REPORT_DIR}/")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    if args.out is None:
        if args.vocaset is not None:
            p.error("--out is required with --vocaset")
        args.out = default_output_dir()
    start = time.perf_counter()
    summary = build_dataset(args.out, args.vocaset, workers=args.workers, shapes=args.shapes,
                            delta=args.delta, report=not args.no_report, progress=not args.quiet)
    elapsed = time.perf_counter() - start
    print(f"{summary.out}: speakers built {summary.built['speakers']}, up to date {summary.skipped['speakers']}; "
          f"sentences built {summary.built['sentences']}, up to date {summary.skipped['sentences']}; "
          + (f"oracle samples of {summary.built['oracle']} sentences built, up to date "
             f"{summary.skipped['oracle']}; " if "oracle" in summary.built else "")
          + f"{len(summary.failures)} failed; {elapsed:.1f} s")
    for warning in summary.warnings:
        print(f"warning: {warning['subject']} {warning['sentence'] or ''}: {warning['message']}", file=sys.stderr)
    for failure in summary.failures:
        print(f"FAILED {failure['subject']} {failure['sentence'] or ''} ({failure['stage']}): {failure['reason']}",
              file=sys.stderr)
    if summary.failures:
        print(f"{len(summary.failures)} item(s) failed (listed above, in {REPORT_DIR}/README.md and in "
              f"{MANIFEST_FILE} failures); the other outputs are complete", file=sys.stderr)
        return cli.EXIT_PARTIAL
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
