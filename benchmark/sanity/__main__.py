"""``python -m benchmark.sanity --data BUILD --out DIR [--levels small|full] [--vae PATH] [--quiet]``:
check that every metric reacts to what it claims to measure.

The ground-truth coefficient tracks of the build's test split are disturbed at five or
more levels per kind (time shift and advance, temporal smoothing, i.i.d. noise,
damping toward the neutral, mouth-only damping, sentence swaps, noisy samples,
constant offsets), each disturbed set is scored through the normal evaluation
(``benchmark.evaluation.evaluate_split``), and each metric's response is judged
against its declaration (``benchmark/sanity/expectations.py``: rises, falls, must not
react, equals the level, or no claim, each with its reason). Writes
``DIR/sanity.json`` (``{metric: {disturbance: {levels, values, rho, expected, ok,
...}}}``), ``DIR/sanity.png`` (the metric x disturbance grid) and
``DIR/sanity_meta.json`` (how it was run). The reference rows (a static face, the ground
truth, and a one-to-many build's oracle samples and their mean) are judged against
their claims (``REFERENCE_CLAIMS``: the dynamics closeness is 0 for a static face, 1 for
the ground truth, ...) into ``DIR/sanity_references.json``. ``--vae PATH`` scores the latent
metrics with a corpus's own VAE (its card checked against the build), the check a VAE
trained for a board should pass before the board is scored with it. Exit status 4 when a metric breaks its
declaration (after writing the files), 2 for a build without a test split or a bad flag.
"""

from __future__ import annotations

import sys
from pathlib import Path

from benchmark.protocol import check_results_dir, default_data_root, open_data
from benchmark.sanity.disturbances import DISTURBANCES
from benchmark.sanity.report import SANITY_SETTINGS, ground_truth, run_sanity, status_counts
from blendvoca import cli
from blendvoca.errors import CheckFailed, UserError

__all__ = ["main"]


@cli.command
def main(argv=None) -> int:
    p = cli.parser("benchmark.sanity", __doc__)
    p.add_argument("--out", required=True, metavar="DIR",
                   help="folder for sanity.json, sanity.png and sanity_meta.json")
    p.add_argument("--levels", choices=("small", "full"), default="small",
                   help="small: 5 levels per disturbance (CI); full: 8 (default small)")
    p.add_argument("--disturbances", default=None, metavar="KIND,...",
                   help="only these disturbances (comma-separated; default all: "
                        "time_shift, time_advance, smoothing, noise, damping, mouth_damping, sentence_swap, "
                        "noisy_samples, constant_offset)")
    p.add_argument("--split", default="test", help="split whose ground truth is disturbed (default test)")
    p.add_argument("--sync-expert", default=None, metavar="PATH",
                   help="also judge the learned sync expert's AV offset and confidence (benchmark.lipsync)")
    p.add_argument("--vae", default=None, metavar="PATH",
                   help="score the latent metrics with this VAE (python -m benchmark.features.train) instead of the "
                        "published one: does a corpus's own VAE rank what it claims to?")
    cli.add_data_option(p)
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    cli.require_address_space("benchmark.sanity")
    kinds = None
    if args.disturbances is not None:
        kinds = [k.strip() for k in args.disturbances.split(",") if k.strip()]
        unknown = [k for k in kinds if k not in DISTURBANCES]
        if unknown or not kinds:
            raise UserError(f"--disturbances: unknown {unknown or args.disturbances!r}; expected some of "
                            f"{', '.join(DISTURBANCES)}")
    data = default_data_root() if args.data is None else Path(args.data).expanduser()
    dataset = open_data(data)
    ground_truth(dataset, args.split)  # a build without that split: one error line, nothing written
    settings = SANITY_SETTINGS
    if args.sync_expert is not None:
        if not Path(args.sync_expert).expanduser().is_file():
            raise UserError(f"--sync-expert {args.sync_expert}: no such file")
        settings = settings.replace(sync_expert=str(Path(args.sync_expert).expanduser()))
    if args.vae is not None:
        from benchmark.features.card import check_vae_fits  # torch: loaded only for a given VAE

        vae = Path(args.vae).expanduser()
        check_vae_fits(vae, dataset.names, data=data)  # a missing file or another shape set: one error line
        settings = settings.replace(extractor=str(vae.resolve()))
    out = check_results_dir(Path(args.out).expanduser())
    table, failed = run_sanity(dataset, out, levels=args.levels, split=args.split, kinds=kinds, settings=settings)
    counts = status_counts(table)
    print(f"sanity: {counts['held']} declarations held, {counts['failed']} failed, "
          f"{counts['no claim']} pairs without a claim, {counts['not scored']} declared but not scored")
    for metric, kind, entry in failed:
        if "values" in entry:
            print(f"FAILED {metric} under {kind}: declared {entry['expected']}; {entry['why']}; "
                  f"values {[round(v, 4) for v in entry['values']]} at levels {entry['levels']}")
        else:  # a reference row's claim
            print(f"FAILED {metric} on the {kind}: declared {entry['expected']} {entry['target']:g}; {entry['why']}")
    print(out / "sanity.json")
    print(out / "sanity_references.json")
    print(out / "sanity.png")
    if failed:
        raise CheckFailed(f"{len(failed)} metric declaration(s) broken: "
                          + ", ".join(f"{m} under {d}" for m, d, _e in failed))
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
