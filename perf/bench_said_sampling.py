"""Sampling speed of SAiD: sequences per second for a 4 s clip, per sampler and step count.

    BLENDVOCA_ASSETS=../shared/assets python perf/bench_said_sampling.py [--checkpoint said.pt] [--device cpu|cuda]
        [--samples 1] [--steps 10 50 100] [--repeats 3] [--threads 1]

Prints one row per (sampler, steps): seconds per call, sequences per second and the
ratio of that throughput to the reference run (DDIM, 50 steps) measured in the same
process.

    python perf/bench_said_sampling.py --authors [--samples 5] [--steps 50 1000] [--seconds 4] [--repeats 1]
        [--width 192] [--tiny-encoder] [--threads 2] [--device cpu|cuda]

The authors' network (random weights, the published sizes unless ``--width`` /
``--tiny-encoder``): sequences per second of :func:`baselines.said.inference.said_inference`
(all samples of an utterance in one batch, the audio embedding and the cross-attention
keys/values computed once) against the authors' way, a plain diffusers
``DDIMScheduler`` loop with classifier-free guidance run once per sequence, from the
same initial noise (the largest output difference is printed too).

    python perf/bench_said_sampling.py --authors --sentences 6 [--samples 5] [--steps 50] [--seconds 2]

Utterances of different lengths (``--sentences`` clips from 0.75 to 1.25 times
``--seconds``): :meth:`baselines.said.official_pipeline.OfficialSAiD.generate_many`
(all sentences in one zero-padded batch) against the same pipeline one sentence at a
time and against the diffusers loop per sequence, with the largest difference
between the batched and the one-at-a-time tracks.  Without a checkpoint it times an untrained model of the preset (speed does
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
from blendvoca.runtime.threads import limit_threads  # noqa: E402

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


def _authors_network(width: int, tiny_encoder: bool, device: str):
    from baselines.said.official import SAID_UNet1D
    from baselines.wav2vec2 import tiny_config

    torch.manual_seed(0)
    model = SAID_UNet1D(tiny_config() if tiny_encoder else None, model_channels=width)
    with torch.no_grad():  # the zero-initialised output layers get weights, so outputs differ per step
        for name, p in model.denoiser.named_parameters():
            if not p.abs().sum():
                p.normal_(0.0, 0.02)
    return model.eval().to(device)


@torch.no_grad()
def diffusers_cfg_loop(model, waveform: torch.Tensor, frames: int, steps: int, guidance: float, noise: torch.Tensor) -> torch.Tensor:
    """One sequence as the authors' inference makes it: embedding, then a diffusers DDIM loop with CFG."""
    from diffusers import DDIMScheduler

    sched = DDIMScheduler(num_train_timesteps=1000, beta_schedule="squaredcos_cap_v2", prediction_type="epsilon")
    sched.set_timesteps(steps, device=waveform.device)
    emb = model.get_audio_embedding(model.process_audio(waveform), frames)
    ctx = torch.cat([model.null_cond_emb.repeat(1, frames, 1), emb])
    latents = noise.clone()
    for t in sched.timesteps:
        out = model(sched.scale_model_input(torch.cat([latents] * 2), t), t, ctx)
        uncond, cond = out.chunk(2)
        latents = sched.step(cond + guidance * (cond - uncond), t, latents, eta=0.0).prev_sample
    return latents.clamp(0, 1)


def sentence_batch_comparison(args) -> None:
    """Print seq/s of one zero-padded batch of sentences vs one sentence at a time vs the diffusers loop."""
    from baselines.said.official_pipeline import OfficialSAiD, padded_waveform

    if args.threads:
        limit_threads(args.threads, torch_only=True)
    model = _authors_network(args.width, args.tiny_encoder, args.device)
    pipeline = OfficialSAiD(model, {"guidance": args.guidance}).to(args.device)
    full = clip_audio(1.25 * args.seconds * 1.01)
    scales = np.linspace(0.75, 1.25, args.sentences) if args.sentences > 1 else [1.0]
    utterances = [(full[: int(f * args.seconds * 16000)], int(f * args.seconds * 60)) for f in scales]
    seeds = list(range(len(utterances)))
    sequences = args.samples * len(utterances)
    print(f"SAiD authors' network: width {args.width}, encoder {'tiny' if args.tiny_encoder else 'wav2vec2-base'}, "
          f"{len(utterances)} sentences of {utterances[0][1]} to {utterances[-1][1]} frames x {args.samples} sample(s), "
          f"gamma {args.guidance}, device {args.device}, threads {torch.get_num_threads()}")
    print(f"{'steps':>6s} {'diffusers seq/s':>16s} {'one at a time':>14s} {'batched':>8s} {'vs diffusers':>13s} "
          f"{'vs one at a time':>17s} {'max |diff|':>11s}")
    pipeline.generate_many(utterances[:2], samples=1, seeds=[0, 1], num_steps=2)  # warm-up
    for steps in args.steps:
        runs = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            for (audio, frames), seed in zip(utterances, seeds):
                wav, model_frames, _ = padded_waveform(audio, frames)
                noise = torch.randn(args.samples, model_frames, 32, generator=torch.Generator().manual_seed(seed))
                for i in range(args.samples):
                    diffusers_cfg_loop(model, wav.to(args.device), model_frames, steps, args.guidance, noise[i:i + 1])
            t_ref = time.perf_counter() - t0
            t0 = time.perf_counter()
            alone = [pipeline.generate(audio, frames, samples=args.samples, seed=seed, num_steps=steps)
                     for (audio, frames), seed in zip(utterances, seeds)]
            t_alone = time.perf_counter() - t0
            t0 = time.perf_counter()
            batched = pipeline.generate_many(utterances, samples=args.samples, seeds=seeds, num_steps=steps)
            t_batch = time.perf_counter() - t0
            runs.append((t_ref, t_alone, t_batch))
        t_ref, t_alone, t_batch = (float(np.median([r[i] for r in runs])) for i in range(3))
        diff = max(float(np.abs(a - b).max()) for a, b in zip(alone, batched))
        print(f"{steps:6d} {sequences / t_ref:16.3f} {sequences / t_alone:14.3f} {sequences / t_batch:8.3f} "
              f"{t_ref / t_batch:13.2f} {t_alone / t_batch:17.2f} {diff:11.2e}", flush=True)


def authors_comparison(args) -> None:
    """Print seq/s of said_inference vs the per-sequence diffusers CFG loop, for each DDIM step count."""
    from baselines.said.inference import said_inference

    if args.threads:
        limit_threads(args.threads, torch_only=True)
    model = _authors_network(args.width, args.tiny_encoder, args.device)
    audio = clip_audio(args.seconds)
    frames = int(len(audio) * 60 / 16000)
    wav = torch.from_numpy(audio)[None].to(args.device)
    noise = torch.randn(args.samples, frames, 32, generator=torch.Generator().manual_seed(0)).to(args.device)

    def timed(fn):
        if args.device.startswith("cuda"):
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        out = fn()
        if args.device.startswith("cuda"):
            torch.cuda.synchronize()
        return time.perf_counter() - t0, out

    def ours(steps):
        with torch.no_grad():
            emb = model.get_audio_embedding(model.process_audio(wav), frames)
            return said_inference(model, emb, batch=args.samples, num_steps=steps, guidance=args.guidance, noise=noise).result

    def reference(steps):
        return torch.cat([diffusers_cfg_loop(model, wav, frames, steps, args.guidance, noise[i:i + 1]) for i in range(args.samples)])

    print(f"SAiD authors' network: width {args.width}, encoder {'tiny' if args.tiny_encoder else 'wav2vec2-base'}, "
          f"{args.samples} sample(s) of {args.seconds:g} s ({frames} frames), gamma {args.guidance}, device {args.device}, "
          f"threads {torch.get_num_threads()}")
    print(f"{'steps':>6s} {'diffusers seq/s':>16s} {'ours seq/s':>11s} {'ratio':>6s} {'max |diff|':>11s}  (medians of {args.repeats} interleaved runs; ratios per run)")
    ours(2)  # warm-up
    for steps in args.steps:
        runs = []
        for _ in range(args.repeats):
            t_ref, want = timed(lambda: reference(steps))
            t_ours, got = timed(lambda: ours(steps))
            runs.append((t_ref, t_ours))
        t_ref, t_ours = (float(np.median([r[i] for r in runs])) for i in (0, 1))
        ratios = " ".join(f"{r[0] / r[1]:.2f}" for r in runs)
        print(f"{steps:6d} {args.samples / t_ref:16.3f} {args.samples / t_ours:11.3f} "
              f"{float(np.median([r[0] / r[1] for r in runs])):6.2f} {(got - want).abs().max().item():11.2e}  ({ratios})", flush=True)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--checkpoint", default=None)
    p.add_argument("--preset", default="cpu-demo")
    p.add_argument("--device", default="cpu")
    p.add_argument("--samples", type=int, default=1, help="sequences per call (batched)")
    p.add_argument("--steps", type=int, nargs="+", default=[10, 50, 100])
    p.add_argument("--samplers", nargs="+", default=["ddim", "ddpm"])
    p.add_argument("--repeats", type=int, default=None, help="timed calls (default 3; --authors: 1)")
    p.add_argument("--threads", type=int, default=None, help="torch threads (default: the preset's)")
    p.add_argument("--authors", action="store_true", help="the authors' network vs a diffusers CFG loop")
    p.add_argument("--seconds", type=float, default=CLIP_SECONDS, help="clip length (--authors)")
    p.add_argument("--width", type=int, default=192, help="UNet width (--authors; the published 192)")
    p.add_argument("--tiny-encoder", action="store_true", help="tiny wav2vec 2.0 instead of base (--authors)")
    p.add_argument("--guidance", type=float, default=2.0, help="gamma (--authors; the authors' script's 2)")
    p.add_argument("--sentences", type=int, default=None,
                   help="--authors: this many utterances of different lengths, batched across sentences")
    args = p.parse_args(argv)
    if args.repeats is None:
        args.repeats = 1 if args.authors else 3
    if args.authors:
        if args.steps == [10, 50, 100]:
            args.steps = [50, 1000]
        if args.samples == 1 and "--samples" not in (argv or sys.argv):
            args.samples = 5
        if args.sentences:
            sentence_batch_comparison(args)
        else:
            authors_comparison(args)
        return

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
