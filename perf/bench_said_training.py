"""Training speed of SAiD's cpu-demo networks: milliseconds per training step, by part.

    python perf/bench_said_training.py [--steps 40] [--rounds 3] [--threads 1] [--batch 16] [--window 60]

Times the steps that ``train_said`` makes: one batch of ``--batch`` random windows of
``--window`` frames with their audio, the diffusion loss (log-mel features included),
the backward pass, gradient clipping, the AdamW step and the EMA update. Reference:
the authors' network at cpu-demo width (the preset's default). It is timed against the
compact UNet (``architecture=compact``) in the same process, in interleaved rounds.
Prints ms per step for each part and the ratio of the compact UNet's step time to the
authors'. The two are directly comparable because both see the same batches.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from baselines.said.ema import EMA  # noqa: E402
from baselines.said.pipeline import SAiD  # noqa: E402
from baselines.said.train import diffusion_loss  # noqa: E402
from blendvoca.names import BLENDVOCA_NAMES  # noqa: E402
from blendvoca.runtime.threads import limit_threads  # noqa: E402

ARCHITECTURES = ("authors", "compact")


class Trainer:
    """One cpu-demo SAiD with its optimizer and EMA, stepping on a fixed batch."""

    def __init__(self, architecture: str, batch: int, window: int):
        torch.manual_seed(0)
        self.said = SAiD.from_preset(BLENDVOCA_NAMES, "cpu-demo", architecture=architecture)
        self.params = self.said.model.trainable_parameters()
        self.opt = torch.optim.AdamW(self.params, lr=1e-3, fused=True)
        self.ema = EMA(self.said.model, 0.999)
        self.gen = torch.Generator().manual_seed(0)
        data = torch.Generator().manual_seed(1)
        self.coeffs = torch.rand(batch, window, len(BLENDVOCA_NAMES), generator=data)
        self.audio = 0.1 * torch.randn(batch, window * 16000 // 60, generator=data)
        self.seconds = {"encoder": 0.0, "forward": 0.0, "backward": 0.0, "update": 0.0}
        self.steps = 0

    def step(self, timed: bool) -> None:
        model = self.said.model
        model.train()
        t0 = time.perf_counter()
        model.audio_features(self.audio, self.coeffs.shape[1])  # the encoder alone, for its share
        t1 = time.perf_counter()
        loss = diffusion_loss(self.said, self.coeffs, self.audio, generator=self.gen, cond_drop_prob=0.1)
        t2 = time.perf_counter()
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        t3 = time.perf_counter()
        torch.nn.utils.clip_grad_norm_(self.params, 1.0, foreach=True)
        self.opt.step()
        self.ema.update(model)
        t4 = time.perf_counter()
        if timed:
            self.seconds["encoder"] += t1 - t0
            self.seconds["forward"] += (t2 - t1) - (t1 - t0)  # the loss's forward less its encoder call
            self.seconds["backward"] += t3 - t2
            self.seconds["update"] += t4 - t3
            self.steps += 1

    def ms_per_step(self) -> dict:
        parts = {k: 1000 * v / self.steps for k, v in self.seconds.items()}
        return {**parts, "step": sum(parts.values())}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=40, help="timed steps per network and round")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds")
    p.add_argument("--threads", type=int, default=1, help="torch threads (the cpu-demo preset trains on 1)")
    p.add_argument("--batch", type=int, default=16)
    p.add_argument("--window", type=int, default=60)
    args = p.parse_args(argv)
    limit_threads(args.threads, torch_only=True)
    trainers = {name: Trainer(name, args.batch, args.window) for name in ARCHITECTURES}
    for trainer in trainers.values():
        for _ in range(5):
            trainer.step(timed=False)
    for _ in range(args.rounds):
        for trainer in trainers.values():
            for _ in range(args.steps):
                trainer.step(timed=True)
    print(f"cpu-demo training step, batch {args.batch} x {args.window} frames, {args.threads} thread(s), "
          f"{args.rounds} x {args.steps} steps each")
    print(f"{'network':<10} {'params':>8} {'encoder':>8} {'forward':>8} {'backward':>9} {'update':>7} {'step':>7} (ms)")
    for name, trainer in trainers.items():
        ms = trainer.ms_per_step()
        params = sum(p.numel() for p in trainer.params)
        print(f"{name:<10} {params:>8} {ms['encoder']:>8.2f} {ms['forward']:>8.2f} {ms['backward']:>9.2f} "
              f"{ms['update']:>7.2f} {ms['step']:>7.2f}")
    ratio = trainers["compact"].ms_per_step()["step"] / trainers["authors"].ms_per_step()["step"]
    print(f"compact / authors step time: {ratio:.2f}")


if __name__ == "__main__":
    main()
