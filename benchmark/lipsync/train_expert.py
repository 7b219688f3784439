"""Train the learned lip-sync expert on a BlendVOCA build's training split.

``python -m benchmark.lipsync.train_expert --data D --out PATH [--max-steps N] [--max-seconds S]``
trains :mod:`benchmark.lipsync.expert` with :func:`benchmark.lipsync.expert_training.train_expert`
and writes the checkpoint atomically; ``benchmark.lipsync.load_expert(PATH)`` reads it.
``--also-data D2`` adds another build's training split (repeatable);
``--motion-norm utterance --channel-gain 0.3 --channel-drop 0.1`` is the real-speech
expert's recipe (docs/metrics.md, "The real-speech expert"; the defaults are the
original one). Training stops at whichever budget ends first (240 s when none is given). Ctrl-C
stops training and saves the model trained so far. An existing ``--out`` is not
replaced unless ``--overwrite``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import DataError, UserError

#: Training time when no budget is given.
DEFAULT_SECONDS = 240.0


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("benchmark.lipsync.train_expert", __doc__)
    parser.add_argument("--out", required=True, help="checkpoint to write (.pt)")
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--lr", type=float, default=2e-3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    parser.add_argument("--motion-norm", choices=("training", "utterance"), default="training",
                        help="motion input: standardised by the training statistics (default) or normalised per "
                             "utterance (the real-speech expert's recipe: docs/metrics.md)")
    parser.add_argument("--channel-gain", type=float, default=0.0, metavar="SIGMA",
                        help="augmentation: each shape of a crop scaled by exp(N(0, SIGMA)) (default 0: none)")
    parser.add_argument("--channel-drop", type=float, default=0.0, metavar="P",
                        help="augmentation: each shape of a crop zeroed with probability P (default 0)")
    parser.add_argument("--also-data", action="append", default=[], metavar="DIR",
                        help="another build whose training split is trained on too (repeatable)")
    cli.add_data_option(parser, required=True, help="BlendVOCA build (blendvoca.build output)")
    cli.add_budget_options(parser)
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    max_steps, max_seconds = cli.budget_limits(args)
    if max_steps is None and max_seconds is None:
        max_seconds = DEFAULT_SECONDS
    out = Path(args.out).expanduser()
    if out.exists() and not args.overwrite:
        raise UserError(f"{out} exists; pass --overwrite to replace it")

    from benchmark.data import open_blendvoca
    from benchmark.lipsync.expert import save_expert
    from benchmark.lipsync.expert_training import dataset_items, train_expert

    if not 0.0 <= args.channel_drop < 1.0 or args.channel_gain < 0:
        raise UserError(f"--channel-drop: expected 0 <= P < 1 and --channel-gain >= 0, got {args.channel_drop}, "
                        f"{args.channel_gain}")
    items, trained_on = [], {}
    for k, data in enumerate([args.data, *args.also_data]):
        dataset = open_blendvoca(data)
        found = dataset_items(dataset, "train")
        if not found:
            raise DataError(f"{data}: the training split has no sentences")
        items += found
        record = {"data": str(Path(data).expanduser().resolve()), "split": "train", "subjects": dataset.split("train"),
                  "manifest_hash": dataset.manifest_hash, "recipe_id": dataset.recipe_id}
        if k == 0:
            trained_on.update(record)
        else:
            trained_on.setdefault("also", []).append(record)
    config = {"motion_norm": args.motion_norm}
    expert = train_expert(items, max_steps=max_steps, max_seconds=max_seconds,
                          batch_size=args.batch_size, lr=args.lr, seed=args.seed, config=config,
                          channel_gain=args.channel_gain, channel_drop=args.channel_drop, trained_on=trained_on)
    save_expert(expert, out)
    info = expert.trained_on
    print(f"saved {out} (trained on {info['sentences']} sentences of {args.data} train split, "
          f"{info['steps']} steps, {info['seconds']} s)")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
