"""Sampling speed of SAiD: sequences per second for a 4 s clip, per sampler and step count.

    BLENDVOCA_ASSETS=../shared/assets python benchmarks/bench_said_sampling.py [--checkpoint said.pt] [--device cpu|cuda]
        [--samples 1] [--steps 10 50 100] [--repeats 3] [--threads 1]

Prints one row per (sampler, steps): seconds per call, sequences per second and the
ratio of that throughput to the reference run (DDIM, 50 steps) measured in the same
process.  Without a checkpoint it times an untrained model of the preset (speed does
not depend on the weights).  Audio: the first 4 s of the ``speech-voca`` asset, or
noise when the asset is unavailable.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from baselines.said.pipeline import SAiD  # noqa: E402

CLIP_SECONDS = 4.0


def clip_audio(seconds: float = CLIP_SECONDS) -> np.ndarray:
    """Return ``seconds`` of 16 kHz speech (the VOCA test sentence) or of noise without assets."""
    n = int(seconds * 16000)
    try:
        from blendvoca.assets import resolve
        from blendvoca.io.audio import load_audio

        audio = load_audio(resolve("speech-voca"))
        return np.resize(audio, n).astype(np.float32)
    except Exception as exc:  # noqa: BLE001 - speed does not depend on the words
        print(f"(speech asset unavailable: {exc}; timing on noise)")
        return (0.1 * np.random.default_rng(0).standard_normal(n)).astype(np.float32)


def time_generation(said: SAiD, audio: np.ndarray, *, sampler: str, steps: int, samples: int, repeats: int, device: str) -> float:
    """Return the median wall seconds of one ``said.generate`` call (after one warm-up call)."""
    def once():
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        said.generate(audio, samples=samples, sampler=sampler, num_steps=steps, seed=0)
        if device.startswith("cuda"):
            torch.cuda.synchronize()
        return time.perf_counter() - t0

    once()
    return float(np.median([once() for _ in range(repeats)]))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--checkpoint", default=None)
    p.add_argument("--preset", default="cpu-demo")
    p.add_argument("--device", default="cpu")
    p.add_argument("--samples", type=int, default=1, help="sequences per call (batched)")
    p.add_argument("--steps", type=int, nargs="+", default=[10, 50, 100])
    p.add_argument("--samplers", nargs="+", default=["ddim", "ddpm"])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--threads", type=int, default=None, help="torch threads (default: the preset's)")
    args = p.parse_args(argv)

    from blendvoca.names import BLENDVOCA_NAMES

    said = SAiD.load(args.checkpoint) if args.checkpoint else SAiD.from_preset(BLENDVOCA_NAMES, args.preset)
    if args.threads is not None:
        said.config["training"]["num_threads"] = args.threads
    said.to(args.device)
    audio = clip_audio()
    params = sum(p.numel() for p in said.model.trainable_parameters())
    print(f"SAiD {said.config['preset']}: {params} trainable parameters, encoder {said.config['model']['encoder']['kind']}, "
          f"device {args.device}, threads {said.config['training'].get('num_threads') or torch.get_num_threads()}, "
          f"{args.samples} sequence(s) of {CLIP_SECONDS:g} s per call, guidance {said.config['sampling']['guidance']}")
    ref = time_generation(said, audio, sampler="ddim", steps=50, samples=args.samples, repeats=args.repeats, device=args.device)
    print(f"{'sampler':8s} {'steps':>6s} {'s/call':>9s} {'seq/s':>9s} {'vs ddim-50':>10s}")
    print(f"{'ddim':8s} {50:6d} {ref:9.3f} {args.samples / ref:9.3f} {1.0:10.2f}  (reference)")
    for sampler in args.samplers:
        for steps in args.steps:
            if sampler == "ddim" and steps == 50:
                continue
            sec = time_generation(said, audio, sampler=sampler, steps=steps, samples=args.samples, repeats=args.repeats, device=args.device)
            print(f"{sampler:8s} {steps:6d} {sec:9.3f} {args.samples / sec:9.3f} {ref / sec:10.2f}")


if __name__ == "__main__":
    main()
