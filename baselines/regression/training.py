"""Least-squares training of :class:`AudioToCoefficients` on random windows."""

from __future__ import annotations

import copy
import sys
import time

import numpy as np
import torch

from baselines.common.device import MixedPrecision, method_device
from baselines.common.training import kept_state, paused_training
from benchmark.methods.base import Budget, checkpoint_step

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
                      lr: float = 2e-3, eval_every: int = 250, model_kwargs=None, progress: bool = True,
                      on_checkpoint=None, device=None, mixed_precision=None):
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
        Called once, in a run without ``max_seconds``, after half the steps, as
        ``on_checkpoint(step, model=model, total_steps=steps)``, ``model`` holding the
        weights this function would return if it stopped there (the best on validation,
        a validation at that step included, not recorded), in eval mode without
        gradients; afterwards training goes on exactly as without the call.
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
    started = time.perf_counter()
    losses, val_history = [], []
    best = (float("inf"), None, 0)
    try:
        from tqdm import tqdm
        bar = tqdm(total=steps, desc="regression: train", unit="step", disable=not progress, file=sys.stderr)
    except ImportError:
        bar = None
    half = checkpoint_step(steps) if on_checkpoint is not None and budget.max_seconds is None else None
    step = 0
    while not budget.exhausted(step, started) and step < steps:
        x, y = window_batch(rng, features, targets, batch=batch, window=window)
        with amp.autocast():
            loss = torch.nn.functional.mse_loss(model(torch.from_numpy(x).to(device)), torch.from_numpy(y).to(device))
        optimiser.zero_grad()
        amp.backward(loss)
        amp.step(optimiser)
        losses.append(loss.item())
        step += 1
        if bar is not None:
            bar.update(1)
            if step % 50 == 0:
                bar.set_postfix(loss=f"{np.mean(losses[-50:]):.5f}")
        if len(val_features) and (step % eval_every == 0):
            mse = _mse(model, val_features, val_targets)
            val_history.append([step, mse])
            if mse < best[0]:
                best = (mse, copy.deepcopy(model.state_dict()), step)
        if step == half:
            if val_history and val_history[-1][0] == step:
                state = best[1]
            elif len(val_features):
                with paused_training(model):
                    state = kept_state(best[0], best[1], _mse(model, val_features, val_targets))
            else:
                state = None
            with paused_training(model, state):
                on_checkpoint(step, model=model, total_steps=steps)
    if bar is not None:
        bar.close()
    if len(val_features) and (not val_history or val_history[-1][0] != step):
        mse = _mse(model, val_features, val_targets)
        val_history.append([step, mse])
        if mse < best[0]:
            best = (mse, copy.deepcopy(model.state_dict()), step)
    if best[1] is not None:
        model.load_state_dict(best[1])
    model.eval()
    history = {"steps": step, "seconds": round(time.perf_counter() - started, 3),
               "train_loss": float(np.mean(losses[-50:])) if losses else None, "val_mse": val_history,
               "best_step": best[2] if best[1] is not None else step}
    return model, history
