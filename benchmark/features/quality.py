"""Whether a trained VAE's latent carries the motion: its reconstruction R^2 on held-out windows.

Every latent metric (FD, WInD, multimodality, the latent energy score) reads the
encoder's mean. A VAE whose KL term won (posterior collapse, Bowman et al. 2016) has
an encoder mean that hardly depends on its input, and a decoder that returns the
average window whatever it is given: the latent distances between a row and the
ground truth are then numbers of nothing (on the FACEGOOD build, 3000 steps at
``beta = 1`` gave a static face a smaller FD than the mean face's, both below 0.005).
The latent's scale is arbitrary (FD scales with it), so the test is scale-free: the
fraction of the held-out windows' variance that decoding their encoder means gives
back, ``R^2 = 1 - sum (x - decode(encode(x)))^2 / sum (x - mean_x)^2`` over frames and
coefficients, each coefficient divided by the spread the VAE was trained with.
:data:`MIN_RECONSTRUCTION_R2` is the floor below which the trainer warns.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from benchmark.metrics.windows import WINDOW

__all__ = ["MIN_RECONSTRUCTION_R2", "held_out_windows", "reconstruction_r2"]

#: Below this held-out reconstruction R^2 the VAE's latent carries too little of the
#: motion for distances in it to rank rows: the trainer warns and the card records it. A
#: decoder that ignores its latent returns one window whatever it is given, R^2 <= 0
#: (FACEGOOD from random weights: -0.17, its ReLU output head dead); the published VAE
#: fine-tuned on FACEGOOD's training takes gives back 0.28 of a held-out take's variance.
MIN_RECONSTRUCTION_R2 = 0.1


def held_out_windows(tracks: Sequence[np.ndarray], *, hop: int = WINDOW // 4, window: int = WINDOW) -> np.ndarray:
    """Every ``window``-frame window of ``tracks`` starting every ``hop`` frames, (N, window, C)."""
    out = [t[s:s + window] for t in tracks for s in range(0, len(t) - window + 1, hop)]
    if not out:
        return np.zeros((0, window, tracks[0].shape[1] if len(tracks) else 0), dtype=np.float32)
    return np.asarray(out, dtype=np.float32)


def reconstruction_r2(model, windows: np.ndarray, coeffs_std) -> float | None:
    """The share of ``windows``' variance (each coefficient over ``coeffs_std``) that
    ``model.decode(model.encode(windows))`` gives back; None for fewer than two windows."""
    if len(windows) < 2:
        return None
    std = np.asarray(coeffs_std, dtype=np.float64).reshape(1, 1, -1)
    with torch.no_grad():
        recon = model.decode(model.encode(torch.as_tensor(windows))).double().numpy()
    x = windows.astype(np.float64) / std
    residual = ((x - recon / std) ** 2).sum()
    total = ((x - x.mean(axis=(0, 1), keepdims=True)) ** 2).sum()
    return float(1.0 - residual / total) if total > 0 else None
