"""Throughput of the trained baselines on a device, and the projected time of each paper's protocol.

    BLENDVOCA_ASSETS=../shared/assets python perf/bench_gpu.py [--device cuda] [--methods said faceformer ...]
        [--preset cpu-demo|paper] [--mixed-precision off|bf16|fp16] [--steps 4] [--sample-steps 2 4]
        [--samples 8] [--seconds 4] [--data BUILD] [--threads N] [--config KEY=VALUE ...]

For each method it measures, on ``--device`` (default: a GPU when there is one):

- one training step: the method's own ``train`` timed at ``--steps`` and ``2 x --steps``
  steps, the difference divided by ``--steps`` (set-up and the first steps' warm-up cancel
  out; the in-memory build has no validation split, so no validation is timed; a
  ``--data`` build's validation is, at the tiny budgets' frequent rate);
- one sampling call: ``generate`` of a ``--seconds`` clip with ``--samples`` samples
  (after one warm-up call); for SAiD at two DDIM step counts (``--sample-steps``), the
  difference giving the cost of one denoising step;

and projects the protocol of the method's paper (:data:`PROTOCOLS`, docs/gpu.md) from
them: training steps x step time, plus sentences x (protocol samples / measured samples)
x sampling time (SAiD: x DDIM steps). Sampling time is taken as linear in the samples,
which over-estimates a GPU (a larger batch fills it better) and is about right on a
CPU. The training data is a small in-memory build (:class:`benchmark.testing.FakeBlendVOCA`,
642 vertices) unless ``--data`` names a BlendVOCA build: the vertex methods' step time grows
with the vertex count (VOCASET: 5023), so time them on a real build for real figures.

On a machine without a GPU it runs on the CPU and says so in its first and last lines.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from blendvoca.cli import checked_device  # noqa: E402
from benchmark.methods.base import Budget, progress_bars  # noqa: E402
from benchmark.protocol.training import prepared_method  # noqa: E402
from blendvoca.runtime.threads import limit_threads  # noqa: E402
from blendvoca import cli  # noqa: E402

#: Each paper's protocol on BlendVOCA's 8 x 40 training and 2 x 40 test sentences (VOCASET's
#: splits): training steps, test sentences, samples per sentence and, for SAiD, DDIM steps.
#: SAiD: 50k steps of batch 8, 72 samples with DDIM-1000 per test sentence (the paper's
#: diversity protocol). FaceFormer: 100 epochs of batch 1, one sample per training style (8).
#: CodeTalker: 200 + 100 epochs, 8 styles. CDFace: 200 epochs per part VQ + 50 querying
#: epochs, 5 samples (the board's). Regression (no paper): its default 1200 steps.
PROTOCOLS = {
    "said": {"train_steps": 50_000, "sentences": 80, "samples": 72, "ddim_steps": 1000},
    "faceformer": {"train_steps": 100 * 320, "sentences": 80, "samples": 8},
    "codetalker": {"train_steps": (200 + 100) * 320, "sentences": 80, "samples": 8},
    "cdface": {"train_steps": (2 * 200 + 50) * 320, "sentences": 80, "samples": 5},
    "regression": {"train_steps": 1200, "sentences": 80, "samples": 1},
}

#: Small networks of the ``cpu-demo`` presets for a quick run (``--preset tiny``).
TINY = {
    "regression": {"channels": 16, "hidden": 16, "batch": 8, "window": 40},
    "faceformer": {"feature_dim": 16, "max_seconds": None},
    "codetalker": {"feature_dim": 16, "vq_hidden_size": 16, "vq_zquant_dim": 4, "vq_n_embed": 16, "max_seconds": None},
    "cdface": {"encoder": "logmel", "vq_max_seconds": None, "query_max_seconds": None},
    "said": {"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 4},
}


def method_config(name: str, preset: str, precision: str, extra: dict | None = None) -> dict:
    """The constructor config benchmarked: the preset (regression has none), no time limits,
    then ``extra`` (``--config``; e.g. ``encoder=wav2vec2-tiny`` for a paper network without
    the pretrained encoder's files)."""
    config = dict(TINY[name]) if preset == "tiny" else ({} if name == "regression" else {"preset": preset})
    if name in ("faceformer", "codetalker") and preset != "tiny":
        config["max_seconds"] = None
    if name == "cdface" and preset != "tiny":
        config.update({"vq_max_seconds": None, "query_max_seconds": None})
    if precision != "off":
        config["mixed_precision"] = precision
    return {**config, **(extra or {})}


def _sync(device: str) -> None:
    if device.startswith("cuda"):
        torch.cuda.synchronize()


def train_seconds(name, config, dataset, steps: int, device: str):
    """``(seconds, method)`` of training ``name`` for ``steps`` steps on ``device``."""
    _sync(device)
    start = time.perf_counter()
    with progress_bars(False):
        method, _ = prepared_method(name, config, dataset, seed=0, budget=Budget(max_steps=steps), device=device)
    _sync(device)
    return time.perf_counter() - start, method


def sample_seconds(method, utterance, samples: int, device: str, repeats: int = 2) -> float:
    """Median seconds of one ``generate`` call (after a warm-up call)."""
    def once():
        _sync(device)
        start = time.perf_counter()
        with progress_bars(False):
            method.generate(utterance, samples=samples, seed=0)
        _sync(device)
        return time.perf_counter() - start

    once()
    return float(np.median([once() for _ in range(repeats)]))


def clip(dataset, seconds: float):
    """A ``seconds`` utterance of the dataset's first test speaker (its first sentence's audio, tiled)."""
    from benchmark.methods.contract import Utterance

    subject = dataset.split("test")[0]
    base = dataset.utterance(subject, dataset.sentences(subject)[0], "test")
    audio = np.resize(np.asarray(base.audio, dtype=np.float32), int(seconds * 16000))
    return Utterance(subject=subject, sentence="bench", split="test", audio=audio, num_frames=int(round(seconds * 60)))


def bench_method(name: str, args, dataset, device: str) -> dict:
    """Measured costs and the projected protocol of one method."""
    config = method_config(name, args.preset, args.mixed_precision, cli.parse_config(args.config))
    n = int(args.steps)
    train_seconds(name, config, dataset, 1, device)  # imports, kernels and caches of a first run, untimed
    t1, _ = train_seconds(name, config, dataset, n, device)
    t2, method = train_seconds(name, config, dataset, 2 * n, device)
    step_s = max(t2 - t1, 0.0) / n
    utterance = clip(dataset, args.seconds)
    samples = int(args.samples) if method.stochastic else 1
    protocol = PROTOCOLS[name]
    row = {"method": name, "step_s": step_s, "samples": samples}
    if name == "said":
        k1, k2 = sorted(int(k) for k in args.sample_steps)
        s1 = sample_seconds(method.with_sampling_options(num_steps=k1), utterance, samples, device)
        s2 = sample_seconds(method.with_sampling_options(num_steps=k2), utterance, samples, device)
        per_step = max(s2 - s1, 0.0) / max(k2 - k1, 1)
        fixed = max(s1 - per_step * k1, 0.0)  # the audio encoder and the set-up of a call
        sentence_s = fixed + per_step * protocol["ddim_steps"]
        row["sample_note"] = f"{per_step * 1e3:.1f} ms/DDIM step at S={samples}"
    else:
        sentence_s = sample_seconds(method, utterance, samples, device)
        row["sample_note"] = f"{sentence_s:.2f} s/sentence at S={samples}"
    row["train_h"] = step_s * protocol["train_steps"] / 3600
    row["sample_h"] = sentence_s * protocol["sentences"] * protocol["samples"] / samples / 3600
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="auto", help="auto (a GPU when there is one), cpu, cuda or cuda:N")
    p.add_argument("--methods", nargs="+", default=list(PROTOCOLS), choices=list(PROTOCOLS))
    p.add_argument("--preset", default="cpu-demo", choices=["tiny", "cpu-demo", "paper"])
    p.add_argument("--mixed-precision", default="off", choices=["off", "bf16", "fp16"])
    p.add_argument("--steps", type=int, default=10, help="training steps timed (and twice as many)")
    p.add_argument("--sample-steps", type=int, nargs=2, default=[2, 4], help="SAiD: two DDIM step counts timed")
    p.add_argument("--samples", type=int, default=8, help="samples per generate call of the stochastic methods")
    p.add_argument("--seconds", type=float, default=4.0, help="length of the sampled clip")
    p.add_argument("--data", default=None, help="a BlendVOCA build to train on (default: a small in-memory one)")
    p.add_argument("--threads", type=int, default=None, help="torch CPU threads")
    p.add_argument("--config", action="append", default=[], metavar="KEY=VALUE",
                   help="a method config entry on top of the preset (all methods benchmarked get it)")
    args = p.parse_args(argv)
    device = checked_device(args.device)
    if args.threads:
        limit_threads(args.threads, torch_only=True)
    where = torch.cuda.get_device_name(torch.device(device)) if device.startswith("cuda") else "the CPU"
    note = "" if device.startswith("cuda") else " (no GPU: these are CPU figures, not a GPU's)"
    print(f"device {device}: {where}{note}; preset {args.preset}, mixed precision {args.mixed_precision}, "
          f"torch {torch.__version__}, {torch.get_num_threads()} CPU threads")
    if args.data:
        from benchmark.data import open_blendvoca

        dataset = open_blendvoca(args.data)
    else:
        from benchmark.testing import FakeBlendVOCA

        # no validation split: the timed steps are optimisation steps only (a paper run validates
        # once per epoch or so, a small share of its time)
        dataset = FakeBlendVOCA(0, train=["A", "B"], val=[], test=["D"], sentences=2, frames=(150, 200))
    print(f"{'method':<11} {'train step':>11} {'sampling':>30} {'protocol train':>15} {'protocol sampling':>18}"
          f" {'total':>9}")
    for name in args.methods:
        row = bench_method(name, args, dataset, device)
        protocol = PROTOCOLS[name]
        print(f"{name:<11} {row['step_s'] * 1e3:>8.1f} ms {row['sample_note']:>30} "
              f"{row['train_h']:>8.2f} h/{protocol['train_steps'] // 1000}k {row['sample_h']:>16.2f} h "
              f"{row['train_h'] + row['sample_h']:>7.2f} h", flush=True)
    if not device.startswith("cuda"):
        print("ran on the CPU: no CUDA device here (pass --device cuda on a GPU machine)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
