"""Training FaceFormer on vertex sequences: teacher forcing, MSE, Adam (the authors' recipe)."""

from __future__ import annotations

import torch

from baselines.common.training import epochs_to_steps, fit_sequences, style_items

__all__ = ["train_faceformer"]


def train_faceformer(model, train, val, subjects, *, training: dict, seed: int, max_steps: float, max_seconds: float,
                     on_checkpoint=None, fractions=(0.5,), mixed_precision=None) -> dict:
    """Train ``model`` (a :class:`~baselines.faceformer.model.Faceformer`) in place.

    One sentence per step (batch 1, as the authors), teacher-forced MSE on the
    vertices, Adam; keeps the weights with the lowest validation MSE (teacher-forced,
    averaged over two styles since validation speakers are unseen) when ``val`` is given.
    ``on_checkpoint``, ``fractions``: the runner's checkpoint calls (:func:`~baselines.common.training.fit_sequences`).
    The sentences move once to the device ``model`` is on; ``mixed_precision``
    (``"off"``, ``"bf16"``, ``"fp16"``) applies there when it is a GPU.
    """
    scale = float(training["motion_scale"])
    n_sub = len(subjects)
    items, val_items, eye = style_items(model, train, val, subjects, scale)

    def step_loss(item):
        (audio, template, verts), k = item
        return torch.mean((model(audio, template, verts, eye[k : k + 1]) - verts) ** 2)

    def val_loss():
        losses = [torch.mean((model(a, t, v, eye[k : k + 1]) - v) ** 2)
                  for a, t, v in val_items for k in range(min(n_sub, 2))]
        return float(sum(losses) / len(losses))

    return fit_sequences(model, step_loss, items, val_loss if val_items else None, lr=training["lr"], seed=seed,
                         max_steps=epochs_to_steps(training, len(items), max_steps, max_seconds),
                         max_seconds=max_seconds, num_threads=training.get("num_threads"),
                         grad_clip=training.get("grad_clip"), desc="FaceFormer training",
                         loss_scale=scale**2, on_checkpoint=on_checkpoint, fractions=fractions,
                         mixed_precision=mixed_precision)
