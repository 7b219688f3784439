"""Training SAiD: random augmented windows, L1 + velocity noise loss, AdamW, warm-up, EMA,
model selection on the validation loss.

Command line (needs a built BlendVOCA directory)::

    python -m baselines.said.train --data DIR --out said.pt [--preset cpu-demo] [--max-seconds S]
        [--max-steps N | --budget 500 | --budget 5m] [--config KEY=VALUE ...] [--device cpu] [--quiet]
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np
import torch

from baselines.common.device import MixedPrecision, torch_device
from baselines.said.augment import training_batch, validation_windows
from baselines.said.dataset import dataset_pairs, mirror_for
from baselines.said.ema import EMA
from baselines.said.losses import said_loss
from baselines.said.normalization import coefficient_normalization
from baselines.said.parametrization import noise_from_output
from baselines.said.pipeline import SAiD
from baselines.said.schedule import add_noise, alphas_of
from benchmark.data import open_blendvoca
from benchmark.methods.training_loop import StepLoop, optimiser_step
from blendvoca import cli
from blendvoca.errors import DataError, UserError


def _check_pairs(pairs, k: int, where: str):
    out = []
    for i, pair in enumerate(pairs):
        if not isinstance(pair, (tuple, list)) or len(pair) != 2:
            raise TypeError(f"{where}: expected (coeffs, audio) pairs, got {type(pair).__name__} at index {i}")
        coeffs, audio = np.asarray(pair[0], dtype=np.float32), np.asarray(pair[1], dtype=np.float32)
        if coeffs.ndim != 2 or coeffs.shape[1] != k or coeffs.shape[0] < 2:
            raise ValueError(f"{where}: expected coeffs of shape (T>=2, {k}) at index {i}, got {coeffs.shape}")
        if audio.ndim != 1:
            raise ValueError(f"{where}: expected (N,) mono audio at index {i}, got {audio.shape}")
        out.append((coeffs, audio))
    return out


def diffusion_loss(said: SAiD, coeffs: torch.Tensor, audio: torch.Tensor, *, generator: torch.Generator | None = None, cond_drop_prob: float = 0.0, velocity_weight: float = 1.0, model=None) -> torch.Tensor:
    """Return SAiD's loss on one batch: noise at random timesteps, predict it, L1 + velocity.

    Parameters
    ----------
    said : SAiD
    coeffs : (B, W, K) Tensor
        Coefficients in [0, 1].
    audio : (B, N) Tensor
        The matching 16 kHz audio windows.
    generator : torch.Generator, optional
        Source of timesteps, noise and condition dropping.
    cond_drop_prob : float, default 0.0
        Probability of replacing a window's audio condition by the null condition.
    velocity_weight : float, default 1.0
    model : SAiDModel, optional
        Defaults to ``said.model`` (pass the EMA model to evaluate it).

    Returns
    -------
    loss : () Tensor
    """
    model = said.model if model is None else model
    b, w, _ = coeffs.shape
    x0 = said.to_diffusion(coeffs)
    # random draws on the CPU generator, so that a seed means the same on every device
    device = coeffs.device
    t = torch.randint(0, said.alphas_cumprod.shape[0], (b,), generator=generator).to(device)
    noise = torch.randn(x0.shape, generator=generator).to(device)
    x_t = add_noise(x0, noise, t, said.alphas_cumprod)
    drop = (torch.rand(b, generator=generator) < cond_drop_prob).to(device) if cond_drop_prob > 0 else None
    cond = model.condition(model.audio_features(audio, w), drop)
    prediction = said.config["diffusion"].get("prediction", "epsilon")
    output = model(x_t, t, cond)
    if said.config["training"].get("loss_space", "noise") == "v":
        # L1 + velocity loss on the v target: the noise loss weighted by 1 / sqrt(alpha_bar),
        # so that the nearly pure-noise steps, whose x0 prediction the first sampling
        # steps use, are trained too (the plain noise loss gives them no gradient).
        if prediction != "v":
            raise UserError(f"diffusion_loss: loss_space 'v' needs prediction 'v', got {prediction!r}")
        a = alphas_of(t, said.alphas_cumprod).to(x0.dtype)[:, None, None]
        return said_loss(a.sqrt() * noise - (1.0 - a).sqrt() * x0, output, velocity_weight=velocity_weight)
    eps = noise_from_output(output, x_t, alphas_of(t, said.alphas_cumprod), prediction)
    return said_loss(noise, eps, velocity_weight=velocity_weight)


LR_DECAYS = ("constant", "linear", "cosine")


def budget_decay(kind: str, done: float) -> float:
    """The learning-rate factor after the fraction ``done`` of the training budget (steps or seconds).

    ``constant``: 1; ``linear``: ``1 - done``; ``cosine``: ``(1 + cos(pi done)) / 2``
    (both reach 0 at the end of the budget, whichever of its step or time limit is met first).
    """
    done = min(max(float(done), 0.0), 1.0)
    if kind == "constant":
        return 1.0
    if kind == "linear":
        return 1.0 - done
    if kind == "cosine":
        return 0.5 * (1.0 + math.cos(math.pi * done))
    raise UserError(f"SAiD training: expected lr_decay in {LR_DECAYS}, got {kind!r}")


def train_said(
    said: SAiD,
    train_pairs,
    val_pairs=None,
    *,
    seed: int = 0,
    max_steps: int | None = None,
    max_seconds: float | None = None,
    mirror: np.ndarray | None = None,
    on_checkpoint=None,
    fractions=(0.5,),
    mixed_precision=None,
) -> dict:
    """Train ``said`` in place; at the end it holds the EMA weights with the best validation loss.

    Parameters
    ----------
    said : SAiD
    train_pairs : list of (coeffs (T_i, K) in [0, 1], audio (N_i,) float32 at 16 kHz)
    val_pairs : list of pairs, optional
        Model selection on the validation loss of the EMA weights (fixed windows,
        timesteps and noise); without it the last EMA weights are kept.
    seed : int, default 0
    max_steps, max_seconds : optional
        Stop at whichever comes first; default the config's training values (with
        ``max_steps`` alone, the config's time limit does not apply: a step budget is
        deterministic).
    mirror : (K,) int ndarray, optional
        Mirror permutation of the columns for the swap augmentation; None disables it.
    on_checkpoint : callable, optional
        The runner's checkpoint call (``TrainingRequest.on_checkpoint``): in a run without a
        time limit, called after the ``fractions`` of ``max_steps`` as ``on_checkpoint(step,
        total_steps=max_steps)`` with ``said`` holding the weights this function would leave
        if it stopped there (the EMA weights best on validation; the EMA weights without
        validation), paused (:class:`~benchmark.methods.training_loop.StepLoop`).
    mixed_precision : {"off", "bf16", "fp16"}, optional
        Autocast of the training loss when ``said`` is on a GPU
        (:class:`~baselines.common.device.MixedPrecision`); nothing on the CPU. The
        validation loss is computed in full precision. Timesteps, noise and windows are
        drawn on CPU generators whatever the device: a seed trains on the same batches.

    Returns
    -------
    history : dict
        ``train_loss`` and ``lr`` (per step), ``val`` (``[step, loss]`` pairs), ``best_step``,
        ``best_val_loss``, ``steps``, ``seconds``.  Also stored as ``said.history``.
    """
    cfg = said.config["training"]
    k = len(said.names)
    train_pairs = _check_pairs(train_pairs, k, "train_said train_pairs")
    if not train_pairs:
        raise DataError("train_said: expected at least one training pair, got none")
    val_pairs = _check_pairs(val_pairs or [], k, "train_said val_pairs")
    if max_seconds is None and max_steps is None:
        max_seconds = cfg["max_seconds"]  # a step budget alone stays deterministic: no time cap then
    max_steps = cfg["max_steps"] if max_steps is None else max_steps
    if max_steps is None and max_seconds is None:
        raise UserError("train_said: expected max_steps or max_seconds, got neither")
    max_steps = math.inf if max_steps is None else int(max_steps)
    max_seconds = math.inf if max_seconds is None else float(max_seconds)

    mean, scale = coefficient_normalization([c for c, _ in train_pairs], said.config["diffusion"].get("normalization", "unit-interval"))
    with torch.no_grad():
        said.model.coeff_mean.copy_(torch.from_numpy(mean))
        said.model.coeff_scale.copy_(torch.from_numpy(scale))
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed)
    model = said.model
    params = model.trainable_parameters()
    # fused: one kernel over all parameters instead of several small ops per parameter
    fused = all(p.device.type in ("cpu", "cuda") for p in params) or None
    opt = torch.optim.AdamW(params, lr=cfg["lr"], betas=tuple(cfg["betas"]), weight_decay=cfg["weight_decay"], fused=fused)
    ema = EMA(model, cfg["ema_decay"])
    amp = MixedPrecision(mixed_precision, said.device)

    val_batches = None
    if val_pairs:
        vc, va = validation_windows(val_pairs, cfg["window"])
        vgen = torch.Generator().manual_seed(seed + 1)
        val_batches = []
        for i in range(0, len(vc), cfg["batch_size"]):
            c = torch.from_numpy(vc[i : i + cfg["batch_size"]]).to(said.device)
            a = torch.from_numpy(va[i : i + cfg["batch_size"]]).to(said.device)
            val_batches.append((c, a, vgen.initial_seed() + i))

    def val_loss() -> float:
        ema.model.eval()
        total, count = 0.0, 0
        with torch.no_grad():
            for c, a, s in val_batches:
                g = torch.Generator().manual_seed(s)
                total += float(diffusion_loss(said, c, a, generator=g, velocity_weight=cfg["velocity_weight"], model=ema.model)) * len(c)
                count += len(c)
        return total / count

    warmup = max(1, int(cfg["warmup_steps"]))
    decay = cfg.get("lr_decay", "constant")
    loop = StepLoop(model=model, max_steps=max_steps, max_seconds=max_seconds, desc="SAiD training",
                    threads=cfg.get("num_threads"), validate=val_loss if val_batches else None,
                    validate_every=cfg["val_every"], kept_from=ema.model,
                    on_checkpoint=on_checkpoint if math.isinf(max_seconds) else None, fractions=fractions)

    def lr_factor(step: int) -> float:
        done = max(step / max_steps if max_steps > 0 else 1.0,
                   loop.elapsed() / max_seconds if max_seconds > 0 else 1.0)
        return min(1.0, (step + 1) / warmup) * budget_decay(decay, done)

    sched = torch.optim.lr_scheduler.LambdaLR(opt, lr_factor)
    rates = []

    def step(loop):
        model.train()
        c, a = training_batch(
            train_pairs, cfg["batch_size"], cfg["window"], rng,
            mirror=mirror, mirror_prob=cfg["mirror_prob"], shift_prob=cfg["audio_shift_prob"],
        )
        with amp.autocast():
            loss = diffusion_loss(
                said, torch.from_numpy(c).to(said.device), torch.from_numpy(a).to(said.device), generator=gen,
                cond_drop_prob=cfg["cond_drop_prob"], velocity_weight=cfg["velocity_weight"],
            )
        rates.append(opt.param_groups[0]["lr"])
        optimiser_step(loss, opt, amp=amp, grad_clip=cfg.get("grad_clip"), params=params, clip_foreach=True,
                       scheduler=sched)
        ema.update(model)
        return loss.item()

    done = loop.run(step)
    history = {"train_loss": done.train_loss, "lr": rates, "val": done.val, "best_step": done.best_step,
               "best_val_loss": done.best_loss, "steps": done.steps, "seconds": done.seconds}
    said.history = history
    return history


def train_file(data: str | os.PathLike, out: str | os.PathLike, *, preset: str = "cpu-demo", config: dict | None = None,
               seed: int = 0, max_steps: int | None = None, max_seconds: float | None = None,
               device: str = "cpu") -> dict:
    """Train SAiD on the BlendVOCA build ``data`` and write the checkpoint ``out``.

    Parameters
    ----------
    data : str or os.PathLike
        A built BlendVOCA directory (train and val splits).
    out : str or os.PathLike
        The checkpoint file to write (``.pt``).
    preset : {"cpu-demo", "paper"}
    config : dict, optional
        Flat overrides of the preset (:func:`baselines.said.presets.resolve_config`).
    seed : int
        Fixes the initial weights, the batches and the noise.
    max_steps, max_seconds : optional
        As :func:`train_said`.
    device : str
        ``auto``, ``cpu``, ``cuda`` or ``cuda:N``.

    Returns
    -------
    history : dict
        From :func:`train_said`.

    Raises
    ------
    UserError
        ``data`` is not a directory; a bad preset, config key or device.
    DataError
        ``data`` is not a BlendVOCA build (``benchmark.data.open_blendvoca``).
    """
    dataset = open_blendvoca(Path(os.fspath(data)))
    device = torch_device(device)
    torch.manual_seed(seed)  # the initial weights follow the seed too
    said = SAiD.from_preset(tuple(dataset.names), preset, **(config or {})).to(device)
    history = train_said(
        said, dataset_pairs(dataset, "train"), dataset_pairs(dataset, "val"),
        seed=seed, max_steps=max_steps, max_seconds=max_seconds, mirror=mirror_for(dataset.names),
    )
    said.save(out)
    return history


@cli.command
def main(argv=None) -> int:
    """Command line: train SAiD on a built BlendVOCA directory and write a checkpoint."""
    p = cli.parser("baselines.said.train", __doc__)
    p.add_argument("--out", required=True, help="checkpoint file to write (.pt)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--wav2vec2-path", default=None, help="local wav2vec2 directory (paper preset)")
    cli.add_data_option(p, required=True, help="BlendVOCA directory (python -m blendvoca.build --out DIR)")
    cli.add_budget_options(p)
    cli.add_config_options(p, preset_default="cpu-demo", preset_help="cpu-demo (default) or paper")
    cli.add_device_option(p, default="cpu")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    max_steps, max_seconds = cli.budget_limits(args)
    config = cli.parse_config(args.config)
    if args.wav2vec2_path:
        config["wav2vec2_path"] = args.wav2vec2_path
    history = train_file(args.data, args.out, preset=args.preset, config=config, seed=args.seed,
                         max_steps=max_steps, max_seconds=max_seconds, device=args.device)
    print(f"wrote {args.out}: {history['steps']} steps in {history['seconds']:.0f} s, "
          f"best validation loss {history['best_val_loss']}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
