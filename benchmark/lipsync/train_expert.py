"""``python -m benchmark.lipsync.train_expert --data D --out PATH [--max-steps N | --max-seconds S]``.

Trains the learned lip-sync expert (:mod:`benchmark.lipsync.expert`) on the
training split of a BlendVOCA build and writes the checkpoint atomically;
``benchmark.lipsync.load_expert(PATH)`` reads it. Ctrl-C stops training and
saves the model trained so far. An existing ``--out`` is not replaced unless
``--overwrite``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmark.lipsync.train_expert",
                                     description="Train the learned lip-sync expert on a BlendVOCA build's training split.")
    parser.add_argument("--data", required=True, help="BlendVOCA build (blendvoca.build output)")
    parser.add_argument("--out", required=True, help="checkpoint to write (.pt)")
    budget = parser.add_mutually_exclusive_group()
    budget.add_argument("--max-steps", type=int, default=None, help="training steps")
    budget.add_argument("--max-seconds", type=float, default=None, help="training time (default 240 s)")
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--lr", type=float, default=2e-3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.max_steps is None and args.max_seconds is None:
        args.max_seconds = 240.0
    if (args.max_steps is not None and args.max_steps < 1) or (args.max_seconds is not None and args.max_seconds <= 0):
        print("error: --max-steps must be >= 1 and --max-seconds > 0", file=sys.stderr)
        return 2
    out = Path(args.out).expanduser()
    if out.exists() and not args.overwrite:
        print(f"error: {out} exists; pass --overwrite to replace it", file=sys.stderr)
        return 2
    from benchmark.data import open_blendvoca
    from benchmark.lipsync.expert import save_expert
    from benchmark.lipsync.expert_train import dataset_items, train_expert

    try:
        dataset = open_blendvoca(args.data)
        items = dataset_items(dataset, "train")
        if not items:
            raise ValueError(f"{args.data}: the training split has no sentences")
    except (ValueError, FileNotFoundError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    expert = train_expert(items, max_steps=args.max_steps, max_seconds=args.max_seconds,
                          batch_size=args.batch_size, lr=args.lr, seed=args.seed, progress=not args.quiet,
                          trained_on={"data": str(Path(args.data).expanduser().resolve()), "split": "train",
                                      "subjects": dataset.split("train"),
                                      "manifest_hash": dataset.manifest_hash})
    save_expert(expert, out)
    info = expert.trained_on
    print(f"saved {out} (trained on {info['sentences']} sentences of {args.data} train split, "
          f"{info['steps']} steps, {info['seconds']} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
