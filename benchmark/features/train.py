"""Train a BlendVOCA VAE feature extractor (the paper's recipe).

Loss per batch (B windows of T frames x C coefficients, coefficients divided by
their per-coefficient std ``coeffs_std.csv``):
``0.5 * sum (x - x_hat)^2 / B + beta * KL + w_vel * 0.5 * sum (dx - dx_hat)^2 / B``
where ``dx`` are frame differences and ``KL = 0.5 * mean_b sum_z (mu^2 + e^logvar - logvar - 1)``;
beta follows a cyclical linear annealing schedule (10 cycles, ramp on the first half
of each cycle); AdamW, constant learning rate after a linear warm-up over the first
10 % of the steps, gradient clipping at 1, and an exponential moving average of
the weights (decay 0.99, ramped up as ``(1 + step) / (10 + step)`` early on) that
is what gets saved.

``python -m benchmark.features.train --data DIR --out vae.pth [--max-steps N] [--init published] [--beta B]``
(``--max-seconds S`` stops earlier, keeping the schedules of the step count; ``--init
published`` starts from the published VAE, what a small corpus needs) trains on
the build's training split and writes beside ``vae.pth`` its card ``vae.pth.json``
(:mod:`benchmark.features.card`: the coefficient names it was trained on), which
``benchmark.run --vae`` checks against the build it scores.
"""

from __future__ import annotations

import copy
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from benchmark.features.quality import MIN_RECONSTRUCTION_R2, held_out_windows, reconstruction_r2
from benchmark.features.vae import CoeffsVAE, load_published_vae, load_vae_state
from benchmark.methods.training_loop import StepLoop, ema_decay_at, optimiser_step
from benchmark.metrics.windows import WINDOW
from blendvoca import cli
from blendvoca.errors import DataError, UserError
from blendvoca.io.torch_file import write_torch_file

#: Training steps when no budget is given (the learning-rate warm-up and the KL
#: cycles are laid out over them).
DEFAULT_STEPS = 300


def cyclical_beta(step: int, total_steps: int, n_cycles: int = 10, ratio: float = 0.5, stop: float = 1.0) -> float:
    """KL weight of a step under cyclical linear annealing (Fu et al. 2019).

    Each of ``n_cycles`` equal cycles ramps beta linearly from 0 to ``stop`` over
    its first ``ratio`` fraction and holds ``stop`` for the rest.
    """
    if total_steps < 1 or n_cycles < 1 or not 0 < ratio <= 1:
        raise ValueError(
            f"cyclical_beta: expected total_steps >= 1, n_cycles >= 1, 0 < ratio <= 1, "
            f"got {total_steps}, {n_cycles}, {ratio}"
        )
    period = total_steps / n_cycles
    phase = (step % period) / period
    return float(stop * min(1.0, phase / ratio))


def warmup_lr_factor(step: int, warmup_steps: int) -> float:
    """Learning-rate multiplier: linear warm-up then constant."""
    if warmup_steps <= 0:
        return 1.0
    return float(min(1.0, step / warmup_steps))


def vae_losses(model: CoeffsVAE, coeffs: torch.Tensor, std: torch.Tensor, sample: bool = True):
    """Reconstruction, KL and velocity losses of a batch.

    Parameters
    ----------
    model : CoeffsVAE
    coeffs : (B, T, C) tensor
    std : (C,) tensor
        Per-coefficient standard deviation (weights of the reconstruction).
    sample : bool
        Reparametrised sampling of the latent (training) or its mean.

    Returns
    -------
    reconst, kl, velocity : scalar tensors
    """
    mean, log_var, _, recon = model(coeffs, sample=sample)
    batch = coeffs.shape[0]
    target = coeffs / std.view(1, 1, -1)
    pred = recon / std.view(1, 1, -1)
    reconst = 0.5 * ((target - pred) ** 2).sum() / batch
    kl = 0.5 * (mean**2 + log_var.exp() - log_var - 1).sum(dim=1).mean()
    velocity = 0.5 * ((torch.diff(target, dim=1) - torch.diff(pred, dim=1)) ** 2).sum() / batch
    return reconst, kl, velocity


def random_windows(tracks: Sequence[np.ndarray], count: int, rng: np.random.Generator, window: int = WINDOW) -> np.ndarray:
    """``count`` windows at uniformly random (track, start), (count, window, C)."""
    usable = [t for t in tracks if len(t) >= window]
    if not usable:
        raise DataError(f"random_windows: no track has >= {window} frames; the training split's sentences are "
                        "too short for the VAE's windows")
    which = rng.integers(len(usable), size=count)
    out = []
    for i in which:
        start = rng.integers(len(usable[i]) - window + 1)
        out.append(usable[i][start : start + window])
    return np.stack(out).astype(np.float32)


def train_vae(
    tracks: Sequence[np.ndarray],
    coeffs_std: np.ndarray,
    *,
    steps: int = DEFAULT_STEPS,
    max_seconds: float | None = None,
    batch_size: int = 8,
    lr: float = 1e-4,
    beta: float = 1.0,
    weight_vel: float = 1.0,
    ema_decay: float = 0.99,
    warmup_fraction: float = 0.1,
    n_cycles: int = 10,
    seed: int = 0,
    init: CoeffsVAE | None = None,
) -> CoeffsVAE:
    """Train a VAE on random windows of coefficient tracks.

    Parameters
    ----------
    tracks : sequence of (T_i, C) ndarrays
        Training tracks (60 fps, columns in BlendVOCA order).
    coeffs_std : (C,) ndarray
    steps : int
        Training steps; the warm-up and the KL annealing cycles are laid out over them.
    max_seconds : float, optional
        Stop after this much training time even before ``steps`` (the EMA so far is returned).
    batch_size, lr, beta, weight_vel, ema_decay, warmup_fraction, n_cycles, seed
        See the module docstring.
    init : CoeffsVAE, optional
        Start from these weights (copied; e.g. the published VAE, :func:`initial_vae`).

    Returns
    -------
    CoeffsVAE
        The EMA weights, in eval mode.
    """
    coeffs_std = np.asarray(coeffs_std, dtype=np.float32).ravel()
    channels = {t.shape[1] for t in tracks}
    if channels != {len(coeffs_std)}:
        raise DataError(f"train_vae: tracks have {channels} channels, coeffs_std has {len(coeffs_std)}")
    if np.any(coeffs_std <= 0):
        raise DataError("train_vae: coeffs_std must be positive")
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    model = CoeffsVAE(channels=len(coeffs_std)) if init is None else copy.deepcopy(init)
    if model.channels != len(coeffs_std):
        raise DataError(f"train_vae: the initial VAE reads {model.channels} coefficients, the tracks have "
                        f"{len(coeffs_std)}")
    ema = copy.deepcopy(model)
    optimizer = torch.optim.AdamW(model.parameters(), lr=lr)
    warmup = int(warmup_fraction * steps)
    scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, lambda s: warmup_lr_factor(s, warmup))
    std = torch.as_tensor(coeffs_std)

    def step(loop):
        at = loop.step
        batch = torch.as_tensor(random_windows(tracks, batch_size, rng))
        reconst, kl, velocity = vae_losses(model, batch, std)
        loss = reconst + cyclical_beta(at, steps, n_cycles, stop=beta) * kl + weight_vel * velocity
        optimiser_step(loss, optimizer, grad_clip=1.0, params=model.parameters(), scheduler=scheduler)
        with torch.no_grad():
            decay = ema_decay_at(at, ema_decay)
            for p_ema, p in zip(ema.parameters(), model.parameters()):
                p_ema.mul_(decay).add_(p.detach(), alpha=1 - decay)
            for b_ema, b_cur in zip(ema.buffers(), model.buffers()):
                b_ema.copy_(b_cur)
        return loss.item()

    model.train()
    StepLoop(max_steps=steps, max_seconds=max_seconds, desc="VAE").run(step)
    return ema.eval()


#: ``init`` naming the published VAE (asset ``said-vae``) as the starting weights.
INIT_PUBLISHED = "published"


def initial_vae(init: str, channels: int) -> CoeffsVAE:
    """The starting weights ``init`` names: :data:`INIT_PUBLISHED` or a VAE state dict's path;
    UserError for a file that is not there or reads another number of coefficients."""
    if init == INIT_PUBLISHED:
        model = load_published_vae()
    else:
        path = Path(init).expanduser()
        if not path.is_file():
            raise UserError(f"--init {init}: expected 'published' or a VAE state dict (.pth), no such file")
        model = load_vae_state(torch.load(path, map_location="cpu", weights_only=True))
    if model.channels != channels:
        raise UserError(f"--init {init}: a VAE of {model.channels} coefficients, the build has {channels}")
    return model.train()


def train_vae_on_build(data, out, *, steps: int = DEFAULT_STEPS, max_seconds: float | None = None, coeffs_std=None,
                       batch_size: int = 8, lr: float = 1e-4, beta: float = 1.0, init: str | None = None,
                       seed: int = 0):
    """Train a VAE on the training split of the build ``data`` and save it to ``out``
    (atomically), with its card ``out.json`` (:mod:`benchmark.features.card`: the
    build's coefficient names, recipe, the training's steps, KL weight, start and seed,
    and its reconstruction R^2 on the validation split, :mod:`benchmark.features.quality`),
    which ``benchmark.run --vae`` checks against the build it scores. A VAE whose R^2 is
    below :data:`~benchmark.features.quality.MIN_RECONSTRUCTION_R2` is saved with a
    warning: its latent carries too little of the motion for the latent metrics.

    Parameters
    ----------
    data, out : path-like
    steps, max_seconds, batch_size, lr, beta, seed
        As :func:`train_vae`.
    init : str, optional
        ``"published"``: fine-tune the published VAE (asset ``said-vae``) instead of
        training from random weights, :data:`INIT_PUBLISHED`; or the path of a VAE state dict.
    coeffs_std : path-like, optional
        ``coeffs_std.csv`` weighting the reconstruction; default BlendVOCA's (asset ``coeffs-std``).

    Returns
    -------
    CoeffsVAE
    """
    from benchmark.data import open_blendvoca
    from benchmark.features.card import write_vae_card
    from blendvoca.io.coeffs import read_coeffs_csv

    dataset = open_blendvoca(data)
    tracks = [dataset.coeffs(s, n) for s in dataset.split("train") for n in dataset.sentences(s)]
    if coeffs_std is None:
        from blendvoca.assets import resolve

        coeffs_std = resolve("coeffs-std")
    std, _ = read_coeffs_csv(coeffs_std, names=dataset.names)
    start = None if init is None else initial_vae(init, len(dataset.names))
    model = train_vae(tracks, std[0], steps=steps, max_seconds=max_seconds, batch_size=batch_size, lr=lr, beta=beta,
                      seed=seed, init=start)
    try:  # the held-out check reads the validation split; a build without one gets none
        held_out = [dataset.coeffs(s, n) for s in dataset.split("val") for n in dataset.sentences(s)]
    except ValueError:
        held_out = []
    r2 = reconstruction_r2(model, held_out_windows(held_out), std[0]) if held_out else None
    if r2 is not None and r2 < MIN_RECONSTRUCTION_R2:
        warnings.warn(f"train_vae_on_build: the VAE for {data} gives back {r2:.2f} of the validation split's variance "
                      f"(below {MIN_RECONSTRUCTION_R2}): its latent carries little of the motion, and latent distances "
                      "in it may rank nothing (from random weights on a small corpus the decoder's ReLU output head "
                      "can die: start from the published VAE, --init published)", stacklevel=2)
    # the card first: a VAE file is only ever found beside the card of its own training
    recipe = getattr(dataset, "recipe_id", None) or getattr(dataset, "manifest_hash", None) or ""
    write_vae_card(out, dataset.names, recipe_id=recipe,
                   dataset=getattr(dataset, "dataset_name", "vocaset"), steps=steps, seed=seed, beta=beta,
                   init=init, reconstruction_r2=r2)
    write_torch_file(out, model.state_dict())  # atomic: an interrupted save leaves no partial file
    return model


@cli.command
def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.parser("benchmark.features.train", __doc__)
    parser.add_argument("--out", required=True, help="output state_dict (.pth)")
    parser.add_argument("--batch-size", type=int, default=8)
    parser.add_argument("--lr", type=float, default=1e-4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--beta", type=float, default=1.0,
                        help="the KL term's weight at the top of each annealing cycle (default 1, the paper's)")
    parser.add_argument("--init", default=None, metavar="published|PATH",
                        help="start from these weights instead of random ones: 'published' fine-tunes the published "
                             "VAE (what a small corpus needs: docs/datasets.md), or a VAE state dict")
    parser.add_argument("--coeffs-std", default=None, help="coeffs_std.csv (default: the asset coeffs-std)")
    cli.add_data_option(parser, required=True, help="BlendVOCA build (or SAiD-layout folder)")
    cli.add_budget_options(parser, default_steps=DEFAULT_STEPS)
    args = parser.parse_args(argv)
    steps, seconds = cli.budget_limits(args)
    steps = DEFAULT_STEPS if steps is None else steps
    if args.batch_size < 1:
        raise UserError(f"--batch-size: expected >= 1, got {args.batch_size}")
    if not args.beta > 0:
        raise UserError(f"--beta: expected a KL weight > 0, got {args.beta}")

    train_vae_on_build(args.data, args.out, steps=steps, max_seconds=seconds, coeffs_std=args.coeffs_std,
                       batch_size=args.batch_size, lr=args.lr, beta=args.beta, init=args.init, seed=args.seed)
    print(f"saved {args.out}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
