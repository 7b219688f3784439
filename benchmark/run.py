"""``python -m benchmark.run``: train or load a method, generate on the test split,
score every metric and write one result JSON with its provenance, and beside it a figure
``<result>.png`` (key coefficient tracks of the first test sentences against the ground
truth, and the training loss curve of a trained method: :mod:`benchmark.run_figure`).

Before anything runs, the files of every split (coefficient tracks, audio, rigs) are
checked against the digests of the build's ``manifest.json``, and again after the method
generated: a build modified since it was made, or while the method ran, is refused
(exit status 4) unless ``--no-verify``.

``--seeds 0,1,2`` (instead of ``--seed``) trains, generates and scores one run per
training seed and stores them as one result, whose intervals cover the seeds as well
as the sentences (:mod:`benchmark.protocol.seeds`). A method that trains in steps is
also scored at half its step budget on ``lve_rig`` and ``fd`` (settled or not:
:mod:`benchmark.protocol.convergence`).

``--device cuda`` (default ``cpu``) trains and generates on a GPU: the device is handed
to every ``Method.train`` that takes it, and the trained or loaded method is moved there
before it generates (docs/gpu.md).

The command line over :mod:`benchmark.protocol` (a :class:`~benchmark.protocol.RunSpec`
run by :func:`~benchmark.protocol.run`), on the project's CLI layer :mod:`blendvoca.cli`: a mistake in
what was asked or a build file that is missing is exit status 2, a method that
misbehaved exit status 3, each with one ``error:`` line and nothing written.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from benchmark.methods import Budget, method_listing, method_schema
from benchmark.protocol import DEFAULT_GENERATE_LIMIT, RunSpec, parse_seeds, run
from blendvoca import cli
from blendvoca.errors import DataError, UserError

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = cli.parser("benchmark.run", __doc__)
    p.add_argument("--method", required=False,
                   help="registered or installed method name, or a 'package.module:Class' to import")
    p.add_argument("--vocaset", default=None, metavar="DIR",
                   help="source VOCASET corpus for dataset.vertices (default: the one the build recorded)")
    p.add_argument("--samples", type=int, default=10, help="samples per sentence for stochastic methods")
    seeds = p.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=int, default=None, help="training and sampling seed (default 0)")
    seeds.add_argument("--seeds", default=None, metavar="S1,S2,...",
                       help="train, generate and score once per training seed (distinct integers >= 0, e.g. 0,1,2) "
                            "and store one result over them (methods that train only)")
    p.add_argument("--split", default="test")
    p.add_argument("--checkpoint", default=None, help="load the trained method from here, or train and save here; "
                        "a file: the authors' released weights (faceformer, codetalker, said)")
    p.add_argument("--clip", action="store_true", help="clip out-of-range coefficients instead of failing")
    p.add_argument("--generate-time-limit", type=float, default=None, metavar="SECONDS",
                   help="stop the run (exit 3) when one generate call takes longer than SECONDS; 0: no limit "
                        f"(default: {DEFAULT_GENERATE_LIMIT.describe()}, recorded in the result)")
    p.add_argument("--no-verify", dest="verify", action="store_false",
                   help="score the split's files as they are, without checking them against the build's "
                        "manifest.json digests first (a modified build is otherwise refused, exit 4; "
                        "recorded in the result)")
    p.add_argument("--sentence-batch", type=int, default=1, metavar="N",
                   help="sentences per generation call, batched by methods that can (SAiD); recorded in the result")
    p.add_argument("--lookahead-probes", default=None, metavar="T1,T2,...",
                   help="where the look-ahead probe cuts each probed sentence, seconds from its start (default: "
                        "one cut per sentence after the declared look-ahead; benchmark.protocol.lookahead)")
    p.add_argument("--syncnet-weights", default=None, metavar="PATH",
                   help="SyncNet weights: adds the SyncNet AV offset/confidence (renders every sentence)")
    p.add_argument("--sync-expert", default=None, metavar="PATH",
                   help="learned sync expert (benchmark.lipsync.load_expert): adds av_offset/confidence_expert")
    p.add_argument("--vae", default=None, metavar="PATH",
                   help="the VAE of the latent metrics (fd, wind, energy_latent): a checkpoint in the published "
                        "format; default the published one (asset said-vae). Needed for a dataset whose "
                        "coefficients are not the BlendVOCA 32 (docs/datasets.md)")
    p.add_argument("--checkpoint-fractions", default=None, metavar="F1,F2,...",
                   help="where in the step budget the learning curve scores lve_rig and fd (increasing, each in "
                        "(0, 1]; default 0.25,0.5; docs/methods.md, \"Settled or not\")")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a result of other settings stored under this run's file name (refused otherwise; "
                        "a run that is not plain is named with the digest of its settings, __c<digest>)")
    p.add_argument("--list", action="store_true",
                   help="list the available methods (name, output kind, reference or ranked row, description) and exit")
    p.add_argument("--list-config", action="store_true",
                   help="list the --config options of --method (name, type, default, choices, help) and exit")
    cli.add_data_option(p)
    cli.add_results_option(p)
    cli.add_budget_options(p)
    cli.add_config_options(p)
    # the CPU unless asked: a run's numbers then do not depend on the machine it lands on
    cli.add_device_option(p, default="cpu")
    cli.add_quiet_option(p)
    return p


def _probe_times(text: str) -> tuple:
    """``"0.5,1.2"`` -> ``(0.5, 1.2)`` (``--lookahead-probes``)."""
    try:
        return tuple(float(part) for part in str(text).split(","))
    except ValueError:
        raise cli.UserError(f"--lookahead-probes: expected comma-separated seconds such as 0.5,1.2, "
                             f"got {text!r}") from None


def _print_listing() -> None:
    """One line per method: name, what it outputs, whether the leaderboard ranks it, what it is."""
    rows = [("METHOD", "OUTPUT", "ROW", "DESCRIPTION"), *method_listing()]
    widths = [max(len(row[i]) for row in rows) for i in range(3)]
    for row in rows:
        print("  ".join(cell.ljust(width) for cell, width in zip(row[:3], widths)) + "  " + row[3])


def _print_summary(path) -> None:
    """One line per metric of the result file: arrow (higher or lower is better), mean, interval, unit."""
    result = json.loads(Path(path).read_text())
    for metric, fields in result["metrics"].items():
        arrow = {True: "↑", False: "↓"}.get(fields["higher_is_better"], " ")
        ci = fields.get("ci95")
        ci = "" if not ci else f" [{ci[0]:.4g}, {ci[1]:.4g}]"
        seeds = fields.get("seed_range")
        seeds = "" if not seeds else f" seeds {seeds[0]:.4g}..{seeds[1]:.4g}"
        print(f"  {metric:<28} {arrow} {fields['mean']:.4g}{ci}{seeds} {fields['unit']}".rstrip(), file=sys.stderr)
    still, scored = result["protocol"].get("motionless_sentences"), result["dataset"].get("num_sentences")
    if still and not result["method"].get("reference"):
        print(f"  note: {still} of {scored} sentences do not move at all (every coefficient constant over time): "
              "scored as they are; their lip-sync offsets carry no information", file=sys.stderr)
    convergence = result.get("convergence")
    if convergence:
        moved = ", ".join(f"{name} {m['half_budget']:.4g} -> {m['full_budget']:.4g}"
                          for name, m in convergence["metrics"].items())
        state = "settled" if convergence["settled"] else "NOT settled"
        print(f"  half budget (step {convergence['checked_at_step']}): {moved}: {state}", file=sys.stderr)
    _print_lookahead(result.get("latency") or {})


def _print_lookahead(latency: dict) -> None:
    """The look-ahead the method declares and the one the probe measured (and whether it reads further)."""
    if "measured_lookahead_s" not in latency:
        return
    declared, measured = latency.get("lookahead_s"), latency.get("measured_lookahead_s")
    probe = latency.get("lookahead_probe") or {}
    seen = (probe.get("note") or "not measured") if measured is None else (
        f"measured {measured:.3g} s" + (" (the whole utterance)" if probe.get("whole_utterance") else ""))
    said = "the whole utterance" if declared is None else f"{declared:.3g} s"
    frame = probe.get("frame_s") or 0.0
    beyond = declared is not None and measured is not None and measured > declared + frame + 1e-9
    print(f"  look-ahead: declared {said}, {seen}" + (
        ": READS FURTHER AHEAD THAN IT DECLARES (marked in the tables)" if beyond else ""), file=sys.stderr)


@cli.command
def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.list:
        _print_listing()
        return cli.EXIT_OK
    cli.require_address_space("benchmark.run")
    if not args.method:
        parser.error("--method is required (or --list)")
    for flag, value in (("--data", args.data), ("--vocaset", args.vocaset)):
        if value is not None and not Path(value).expanduser().is_dir():
            parser.error(f"{flag} {value}: no such folder")
    # checked against the method's declaration before any corpus or training work (exit 2)
    schema = method_schema(args.method)
    if args.list_config:
        print(schema.describe() if schema is not None else
              f"{args.method} declares no config options; --config values are passed on as JSON")
        return cli.EXIT_OK
    max_steps, max_seconds = cli.budget_limits(args)
    config = cli.parse_config(args.config, preset=args.preset, schema=schema, method=args.method)
    seeds = None if args.seeds is None else parse_seeds(args.seeds)
    device = cli.checked_device(args.device)  # a GPU that is not there: exit 2 before anything is read
    spec = RunSpec(args.method, config=config, data_root=args.data, split=args.split, samples=args.samples,
                   seed=args.seed, seeds=seeds, budget=Budget(max_steps=max_steps, max_seconds=max_seconds),
                   checkpoint=args.checkpoint, clip=args.clip, generate_time_limit=args.generate_time_limit,
                   sentence_batch=args.sentence_batch, vocaset=args.vocaset, syncnet=args.syncnet_weights,
                   sync_expert=args.sync_expert, results_dir=args.results, verify=args.verify,
                   device=device, vae=args.vae, overwrite=args.overwrite,
                   checkpoint_fractions=args.checkpoint_fractions,
                   lookahead_probes=None if args.lookahead_probes is None else _probe_times(args.lookahead_probes))
    # torch (the training loop) only now: below the address space it needs, the check above said so
    from benchmark.methods.training_loop import loops_finished, loss_histories
    from benchmark.run_figure import write_run_figure

    trained_before = loops_finished()
    path = run(spec)
    histories = loss_histories(trained_before)
    try:
        figure = write_run_figure(path, histories=histories)
        figure = (f"figure: {figure} (key coefficient tracks against the ground truth"
                  f"{', the training loss' if histories else ''})")
    except (DataError, UserError, OSError, KeyError, ValueError) as exc:  # the result stands without it
        figure = f"note: no figure of the run: {exc}"
    if not args.quiet:
        _print_summary(path)
    print(figure, file=sys.stderr)
    print(path)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
