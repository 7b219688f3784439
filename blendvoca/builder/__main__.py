"""``python -m blendvoca.build [--dataset NAME --root DIR | --vocaset DIR] [--out DIR] [--shapes speech|all]``.

Build BlendVOCA (speaker rigs + fitted coefficient tracks) from VOCASET, or the same
layout from another corpus (``--dataset``: the adapters of :mod:`blendvoca.datasets`,
``docs/datasets.md``). ``--vocaset DIR`` is ``--dataset vocaset --root DIR``. The
VOCASET build is resumable: rerun the same command after an interruption.

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
from blendvoca.builder.pipeline import default_output_dir
from blendvoca.datasets import adapter, dataset_names
from blendvoca.format.layout import MANIFEST_FILE, REPORT_DIR


@cli.command
def main(argv: list[str] | None = None) -> int:
    p = cli.parser("blendvoca.build", "Build BlendVOCA (speaker rigs + fitted coefficient tracks) from VOCASET, or "
                                      "the same layout from another corpus (--dataset). Resumable: rerun the same "
                                      "command after an interruption.")
    p.add_argument("--dataset", default=None, metavar="NAME",
                   help=f"the corpus at --root: {', '.join(dataset_names())} (docs/datasets.md); default vocaset")
    p.add_argument("--root", default=None, metavar="DIR", help="the corpus, in the layout of --dataset (facegood: default, its files through the "
                        "asset resolver, data_manifest.yaml)")
    p.add_argument("--vocaset", default=None, metavar="DIR",
                   help="VOCASET root (official or processed layout): the same as --dataset vocaset --root DIR; "
                        "default: the bundled synthetic corpus")
    p.add_argument("--out", default=None,
                   help="output folder (required with a corpus; default for the bundled corpus: "
                        "<user cache>/blendvoca-default, where the benchmark looks for it)")
    p.add_argument("--workers", type=int, default=None, help="processes, >= 1 (default: all cores)")
    p.add_argument("--shapes", choices=("speech", "all"), default="speech",
                   help="the 32 BlendVOCA shapes or all ARKit shapes")
    p.add_argument("--delta", type=float, default=0.1, help="rate bound |u[t+1] - u[t]| per 60 fps frame (> 0)")
    p.add_argument("--no-report", action="store_true", help=f"skip {REPORT_DIR}/")
    p.add_argument("--pose-fit", choices=("joint", "remove"), default=None,
                   help="posed corpora (biwi, multiface): joint = alternate the rigid alignment and the fit "
                        "(default), remove = remove the pose first, then fit (docs/pose.md)")
    p.add_argument("--cuts", default=None, metavar="FILE",
                   help="coefficient corpora: where to cut long takes into utterances, a JSON object of take name "
                        "-> cut times in seconds (docs/datasets.md); default: at the pauses found")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    if args.vocaset is not None and (args.dataset is not None or args.root is not None):
        p.error("--vocaset DIR is the short form of --dataset vocaset --root DIR: give one form, not both")
    dataset = args.dataset or "vocaset"
    root = args.vocaset if args.vocaset is not None else args.root
    if args.dataset is None and args.root is not None:
        p.error(f"--root needs --dataset NAME ({', '.join(dataset_names())})")
    build = adapter(dataset)  # an unknown name is refused before anything else
    if root is None and dataset != "vocaset" and build.default_root is None:
        p.error(f"--dataset {dataset} needs --root DIR, the corpus (docs/datasets.md)")
    if args.out is None:
        if root is not None or dataset != "vocaset":
            given = "--vocaset" if args.vocaset is not None else "--root" if root is not None else f"--dataset {dataset}"
            p.error(f"--out is required with {given}")
        args.out = default_output_dir()
    extra = {}
    if args.pose_fit is not None:
        if not build.takes("pose_fit"):
            p.error(f"--pose-fit: the {dataset} corpus is not posed (it applies to posed corpora: "
                    f"{', '.join(n for n in dataset_names() if adapter(n).takes('pose_fit'))})")
        extra["pose_fit"] = args.pose_fit
    if args.cuts is not None:
        if not build.takes("cuts"):
            p.error(f"--cuts: the {dataset} corpus is not cut into utterances (it applies to the coefficient "
                    f"corpora: {', '.join(n for n in dataset_names() if adapter(n).takes('cuts'))})")
        extra["cuts"] = args.cuts
    start = time.perf_counter()
    summary = build(root, args.out, workers=args.workers, shapes=args.shapes, delta=args.delta,
                    report=not args.no_report, **extra)
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
