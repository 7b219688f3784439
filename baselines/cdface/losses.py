"""CDFace training objectives (Gu et al., Diverse Code Query Learning, TVCG 2025).

Predictions of one facial part are stacked as ``(N, B, T, D)``: ``N`` samples
queried per timestep, a batch of ``B`` sequences of ``T`` frames, ``D = 3 V_part``
motion values per frame. Every norm is the plain L2 norm of a frame's ``D``
values, summed over frames as in the paper and averaged over the batch.
"""

from __future__ import annotations

import torch

__all__ = [
    "best_of_n_reconstruction",
    "code_regularizer",
    "diversity_loss",
    "lip_losses",
    "lip_reconstruction",
    "upper_face_losses",
]


def _check(preds: torch.Tensor, where: str, min_samples: int = 1) -> None:
    if preds.ndim != 4 or preds.shape[0] < min_samples:
        raise ValueError(f"{where}: expected predictions (N >= {min_samples}, B, T, D), got {tuple(preds.shape)}")


def _frame_mask(mask, preds: torch.Tensor, where: str) -> torch.Tensor:
    mask = torch.as_tensor(mask, dtype=preds.dtype, device=preds.device)
    if mask.shape != preds.shape[1:3]:
        raise ValueError(f"{where}: expected a frame mask (B, T) = {tuple(preds.shape[1:3])}, got {tuple(mask.shape)}")
    return mask


def diversity_loss(preds: torch.Tensor, mask=None) -> torch.Tensor:
    """Diversity-promoting loss, Eq. 4 (Eq. 11 with ``mask``).

    ``L_d = - sum_t min_{i != j} || x_t^(i) m_t - x_t^(j) m_t ||``: the smallest
    distance between two of the N samples at each frame, summed over frames,
    negated; minimising it pushes the closest pair apart.

    Parameters
    ----------
    preds : (N, B, T, D) Tensor, N >= 2
    mask : (B, T) array_like of {0, 1}, optional
        Closure-aware mask ``m_t`` (1 where the lips may diversify).

    Returns
    -------
    () Tensor, mean over the batch.
    """
    _check(preds, "diversity_loss", 2)
    if mask is not None:
        preds = preds * _frame_mask(mask, preds, "diversity_loss")[None, :, :, None]
    n = preds.shape[0]
    i, j = torch.triu_indices(n, n, 1, device=preds.device)
    diff = preds[i] - preds[j]  # (P, B, T, D)
    # the norm's gradient is undefined at 0: a tiny floor keeps identical samples trainable
    dist = torch.sqrt((diff * diff).sum(-1) + 1e-12)
    return -dist.min(dim=0).values.sum(-1).mean()


def best_of_n_reconstruction(preds: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Best-of-N reconstruction, Eq. 5: ``sum_t min_i || x_t - x_t^(i) ||``.

    Only the sample closest to the ground truth at each frame is supervised.

    Parameters
    ----------
    preds : (N, B, T, D) Tensor
    target : (B, T, D) Tensor

    Returns
    -------
    () Tensor, mean over the batch.
    """
    _check(preds, "best_of_n_reconstruction")
    if target.shape != preds.shape[1:]:
        raise ValueError(f"best_of_n_reconstruction: expected target {tuple(preds.shape[1:])}, got {tuple(target.shape)}")
    dist = torch.linalg.vector_norm(preds - target[None], dim=-1)  # (N, B, T)
    return dist.min(dim=0).values.sum(-1).mean()


def lip_reconstruction(preds: torch.Tensor, target: torch.Tensor, mask) -> torch.Tensor:
    """Lip reconstruction, Eq. 12: best-of-N plus every sample on closure frames.

    ``L_rc^l = L_rc + 1/N sum_i sum_t || (x_t - x_t^(i)) (1 - m_t) ||``: on frames
    that need lip closure (``m_t = 0``) all N samples follow the ground truth.

    Parameters
    ----------
    preds : (N, B, T, D) Tensor
    target : (B, T, D) Tensor
    mask : (B, T) array_like of {0, 1}

    Returns
    -------
    () Tensor, mean over the batch.
    """
    mask = _frame_mask(mask, preds, "lip_reconstruction")
    closed = torch.linalg.vector_norm((preds - target[None]) * (1.0 - mask)[None, :, :, None], dim=-1)
    return best_of_n_reconstruction(preds, target) + closed.sum(-1).mean(-1).sum() / preds.shape[0]


def code_regularizer(codes: torch.Tensor, quantized: torch.Tensor) -> torch.Tensor:
    """Feature regulariser, Eq. 13/14: ``sum_samples sum_t || z_t - sg(q_t) ||``.

    Parameters
    ----------
    codes : (N, B, T, C) Tensor
        Predicted (continuous) codes ``z``; for the upper face ``N = N^l N^u``.
    quantized : same shape
        Their nearest codebook entries ``q`` (no gradient flows into them).

    Returns
    -------
    () Tensor, summed over samples and frames, mean over the batch.
    """
    if codes.shape != quantized.shape or codes.ndim != 4:
        raise ValueError(f"code_regularizer: expected codes and quantized (N, B, T, C) of one shape, "
                         f"got {tuple(codes.shape)} and {tuple(quantized.shape)}")
    return torch.linalg.vector_norm(codes - quantized.detach(), dim=-1).sum(-1).mean(-1).sum()


def lip_losses(preds, target, mask, codes, quantized, *, lambda_d: float, lambda_rc: float, lambda_rg: float) -> dict:
    """Eq. 15: ``L^l = lambda_d^l L_d^l + lambda_rc^l L_rc^l + lambda_rg L_rg^l``.

    Parameters
    ----------
    preds : (N^l, B, T, D_l) Tensor; target : (B, T, D_l); mask : (B, T)
    codes, quantized : (N^l, B, T, C)

    Returns
    -------
    dict with ``total`` and the unweighted ``diversity``, ``reconstruction``, ``regularizer``.
    """
    parts = {
        "diversity": diversity_loss(preds, mask) if preds.shape[0] > 1 else preds.new_zeros(()),
        "reconstruction": lip_reconstruction(preds, target, mask),
        "regularizer": code_regularizer(codes, quantized),
    }
    parts["total"] = lambda_d * parts["diversity"] + lambda_rc * parts["reconstruction"] + lambda_rg * parts["regularizer"]
    return parts


def upper_face_losses(preds, target, codes, quantized, *, lambda_d: float, lambda_rc: float, lambda_rg: float,
                      repeats: int = 1) -> dict:
    """Eq. 16 with Eq. 9/10: diversity and best-of-N reconstruction over the N^u
    upper-face samples of each lip sample, summed over the N^l lip samples.

    Parameters
    ----------
    preds : (G, N^u, B, T, D_u) Tensor; target : (B, T, D_u)
        ``G`` groups of N^u samples, one per lip sample.
    codes, quantized : (G, N^u, B, T, C)
    repeats : int
        How many lip samples each group stands for (``N^l`` when all lip samples
        share one upper-face group, as under teacher forcing of the lip context).

    Returns
    -------
    dict with ``total``, ``diversity``, ``reconstruction``, ``regularizer``.
    """
    if preds.ndim != 5:
        raise ValueError(f"upper_face_losses: expected predictions (N^l, N^u, B, T, D), got {tuple(preds.shape)}")
    zero = preds.new_zeros(())
    diversity = sum((diversity_loss(group) for group in preds), zero) if preds.shape[1] > 1 else zero
    reconstruction = sum((best_of_n_reconstruction(group, target) for group in preds), zero)
    regularizer = code_regularizer(codes.flatten(0, 1), quantized.flatten(0, 1))
    diversity, reconstruction, regularizer = diversity * repeats, reconstruction * repeats, regularizer * repeats
    total = lambda_d * diversity + lambda_rc * reconstruction + lambda_rg * regularizer
    return {"total": total, "diversity": diversity, "reconstruction": reconstruction, "regularizer": regularizer}
