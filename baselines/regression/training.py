"""Least-squares training of :class:`AudioToCoefficients` on random windows."""

from __future__ import annotations

import numpy as np
import torch

from baselines.common.device import MixedPrecision, method_device
from benchmark.methods.base import Budget
from benchmark.methods.training_loop import StepLoop, optimiser_step

from .model import AudioToCoefficients

__all__ = ["feature_statistics", "trained_regressor", "window_batch"]


def feature_statistics(features) -> tuple[np.ndarray, np.ndarray]:
    """Per-band mean and standard deviation over all frames.

    Parameters
    ----------
    features : list of (T_i, D) ndarray

    Returns
    -------
    mean, std : (D,) float32 ndarray
        ``std`` is floored at 1e-5.
    """
    stacked = np.concatenate([np.asarray(f, dtype=np.float64) for f in features], axis=0)
    return stacked.mean(axis=0).astype(np.float32), np.maximum(stacked.std(axis=0), 1e-5).astype(np.float32)


def window_batch(rng: np.random.Generator, features, targets, *, batch: int, window: int):
    """A batch of aligned random windows.

    Parameters
    ----------
    rng : numpy Generator
    features : list of (T_i, D) ndarray
    targets : list of (T_i, K) ndarray
    batch, window : int
        Batch size and window length in frames (shorter sequences are edge-padded).

    Returns
    -------
    x : (batch, window, D) float32 ndarray
    y : (batch, window, K) float32 ndarray
    """
    xs, ys = [], []
    for i in rng.integers(0, len(features), size=batch):
        f, c = features[i], targets[i]
        t = f.shape[0]
        if t <= window:
            pad = window - t
            xs.append(np.pad(f, ((0, pad), (0, 0)), mode="edge"))
            ys.append(np.pad(c, ((0, pad), (0, 0)), mode="edge"))
            continue
        s = int(rng.integers(0, t - window + 1))
        xs.append(f[s:s + window])
        ys.append(c[s:s + window])
    return np.stack(xs).astype(np.float32), np.stack(ys).astype(np.float32)


def _mse(model, features, targets) -> float:
    model.eval()
    device = model.head.weight.device
    with torch.no_grad():
        errors = [float(((model(torch.from_numpy(f[None]).to(device))
                          - torch.from_numpy(c[None].astype(np.float32)).to(device)) ** 2)
                        .mean()) * f.shape[0] for f, c in zip(features, targets)]
    model.train()
    return sum(errors) / sum(f.shape[0] for f in features)


def trained_regressor(features, targets, *, val_features=(), val_targets=(), seed: int = 0,
                      budget: Budget | None = None, default_steps: int = 1500, batch: int = 16, window: int = 120,
                      lr: float = 2e-3, eval_every: int = 250, model_kwargs=None, on_checkpoint=None,
                      fractions=(0.5,), device=None, mixed_precision=None):
    """Train an :class:`AudioToCoefficients` with MSE on random windows.

    Parameters
    ----------
    features : list of (T_i, D) float32 ndarray
        Normalised 60 fps audio features of the training sentences.
    targets : list of (T_i, K) ndarray
        Coefficient tracks of the same sentences.
    val_features, val_targets : lists, optional
        Validation sentences; when given, the weights with the lowest validation
        MSE (checked every ``eval_every`` steps and at the end) are returned.
    seed : int
        Seeds torch and the window sampler: same seed, same weights.
    budget : Budget
        ``max_steps`` replaces ``default_steps``; ``max_seconds`` stops early.
    on_checkpoint : callable, optional
        Called in a run without ``max_seconds`` after each step of the ``fractions`` of the
        steps (:class:`~benchmark.methods.training_loop.StepLoop`), as
        ``on_checkpoint(step, model=model, total_steps=steps)``, ``model`` holding the
        weights this function would return if it stopped there, paused.
    device : str or torch.device, optional
        Where it trains (None: the CPU). The network is initialised and the windows drawn
        on the CPU, so a seed trains on the same batches from the same weights everywhere.
    mixed_precision : {"off", "bf16", "fp16"}, optional
        Autocast of the loss on a GPU (:class:`~baselines.common.device.MixedPrecision`);
        nothing on the CPU.

    Returns
    -------
    model : AudioToCoefficients
        In eval mode.
    history : dict
        ``steps``, ``seconds``, ``train_loss`` (last 50-step mean), ``val_mse``
        (list of ``[step, mse]``), ``best_step``.
    """
    if len(features) != len(targets) or not features:
        raise ValueError(f"trained_regressor: expected equal non-empty lists, got {len(features)} features and "
                         f"{len(targets)} targets")
    for i, (f, c) in enumerate(zip(features, targets)):
        if f.shape[0] != c.shape[0]:
            raise ValueError(f"trained_regressor: sentence {i}: {f.shape[0]} feature frames vs {c.shape[0]} targets")
    budget = budget or Budget()
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    kwargs = dict(n_mels=features[0].shape[1], num_coeffs=targets[0].shape[1], **(model_kwargs or {}))
    model = AudioToCoefficients(**kwargs)
    # start from the mean-coefficient baseline: the sigmoid's bias is the logit of the
    # training mean, so the first steps are not spent pulling every output off 0.5
    mean = np.clip(np.concatenate(targets).mean(axis=0), 1e-3, 1 - 1e-3)
    with torch.no_grad():
        model.head.bias.copy_(torch.from_numpy(np.log(mean / (1 - mean)).astype(np.float32)))
        model.head.weight.mul_(0.1)
    device = method_device(device)
    model.to(device)
    amp = MixedPrecision(mixed_precision, device)
    optimiser = torch.optim.Adam(model.parameters(), lr=lr)
    steps = budget.steps(default_steps)

    def step(loop):
        x, y = window_batch(rng, features, targets, batch=batch, window=window)
        with amp.autocast():
            loss = torch.nn.functional.mse_loss(model(torch.from_numpy(x).to(device)), torch.from_numpy(y).to(device))
        optimiser_step(loss, optimiser, amp=amp)
        return loss.item()

    hook = None
    if on_checkpoint is not None and budget.max_seconds is None:
        def hook(at, total_steps):
            on_checkpoint(at, model=model, total_steps=total_steps)

    validate = (lambda: _mse(model, val_features, val_targets)) if len(val_features) else None
    done = StepLoop(model=model, max_steps=steps, max_seconds=budget.max_seconds, desc="regression: train",
                    validate=validate, validate_every=eval_every, on_checkpoint=hook, fractions=fractions).run(step)
    history = {"steps": done.steps, "seconds": round(done.seconds, 3),
               "train_loss": float(np.mean(done.train_loss[-50:])) if done.train_loss else None, "val_mse": done.val,
               "best_step": done.steps if done.best_step is None else done.best_step}
    return model, history
