"""CodeTalker's two-stage training on vertex sequences.

Stage 1 learns the motion codebook: the VQ-VAE reconstructs each sentence (L1) with
the codebook + commitment loss (weight ``quant_loss_weight``), AdamW (``paper``: the
rate halved every 20 epochs). Stage 2 freezes
it and learns the speech-conditioned code query with teacher forcing: MSE of the
decoded motion plus MSE between the predicted and the ground truth's quantized
features, Adam.

Two switchable departures (off in ``paper``, the authors' recipe; on in ``cpu-demo``):
``own_input_prob`` > 0 feeds back, for each frame with that probability (ramped up from
0 over the first half of a step-limited stage 2), the model's own quantized-and-decoded
prediction of a first, gradient-free teacher-forced pass instead of the ground truth
(two-pass scheduled sampling), so the decoder learns from inputs like those it sees
when it runs on its own output; ``val_free_running`` selects the kept stage-2 weights
by the MSE of the autoregressive ``predict`` on the validation sentences instead of the
teacher-forced loss.
"""

from __future__ import annotations

import math

import torch

from baselines.common.device import module_device
from baselines.common.sequences import sequence_tensors
from baselines.common.training import epochs_to_steps, fit_sequences, style_items

__all__ = ["split_budget", "train_stage1", "train_stage2"]


def split_budget(max_steps: float, max_seconds: float, fraction) -> tuple[tuple, tuple]:
    """``((steps1, seconds1), (steps2, seconds2))``: ``fraction`` of each limit for stage 1 (None: no split)."""
    if fraction is None:
        return (max_steps, max_seconds), (max_steps, max_seconds)
    f = float(fraction)
    s1 = max_steps if math.isinf(max_steps) else max(1, int(round(max_steps * f)))
    t1 = max_seconds if math.isinf(max_seconds) else max_seconds * f
    s2 = max_steps if math.isinf(max_steps) else max(1, int(max_steps) - s1)
    t2 = max_seconds if math.isinf(max_seconds) else max_seconds - t1
    return (s1, t1), (s2, t2)


def train_stage1(vq, train, val, *, training: dict, seed: int, max_steps: float, max_seconds: float,
                 mixed_precision=None) -> dict:
    """Train the VQ-VAE ``vq`` in place on displacement sequences, on the device ``vq`` is on
    (``mixed_precision`` there when it is a GPU)."""
    scale = float(training["motion_scale"])
    device = module_device(vq)
    items = [sequence_tensors(s, scale=scale, normalise_audio=False, device=device)[1:] for s in train]
    val_items = [sequence_tensors(s, scale=scale, normalise_audio=False, device=device)[1:] for s in val]
    w = float(training["quant_loss_weight"])

    def loss(item):
        template, verts = item
        recon, quant_loss, _ = vq(verts, template)
        return torch.nn.functional.l1_loss(recon, verts) + w * quant_loss

    def val_loss():
        return sum(float(torch.nn.functional.l1_loss(vq(v, t)[0], v)) for t, v in val_items) / len(val_items)

    if training.get("stage1_epochs") and math.isinf(max_steps) and math.isinf(max_seconds):
        max_steps = int(training["stage1_epochs"]) * len(items)
    return fit_sequences(vq, loss, items, val_loss if val_items else None, lr=training["stage1_lr"], seed=seed,
                         max_steps=max_steps, max_seconds=max_seconds, optimizer="adamw",
                         num_threads=training.get("num_threads"), grad_clip=training.get("grad_clip"),
                         desc="CodeTalker stage 1 (VQ-VAE)", loss_scale=scale,
                         lr_step_every=(int(training["stage1_step_epochs"]) * len(items)
                                        if training.get("stage1_step_epochs") else None),
                         mixed_precision=mixed_precision)


def train_stage2(model, train, val, subjects, *, training: dict, seed: int, max_steps: float, max_seconds: float,
                 on_checkpoint=None, fractions=(0.5,), step_offset: int = 0, mixed_precision=None) -> dict:
    """Train the stage-2 parts of ``model`` (a :class:`~baselines.codetalker.model.CodeTalker`) in place.

    ``on_checkpoint``: the runner's checkpoint calls, made at the ``fractions`` of this (the
    last) stage, the stage-1 steps ``step_offset`` counted in (:func:`~baselines.common.training.fit_sequences`).
    It trains on the device ``model`` is on (``mixed_precision`` there when it is a GPU); the
    scheduled-sampling draws stay on a CPU generator, so that a seed feeds back the same frames
    on every device.
    """
    scale = float(training["motion_scale"])
    n = len(subjects)
    device = module_device(model)
    items, val_items, eye = style_items(model, train, val, subjects, scale)

    steps = epochs_to_steps(training, len(items), max_steps, max_seconds)
    own_prob = float(training.get("own_input_prob") or 0.0)
    ramp = None if math.isinf(steps) else max(1.0, 0.5 * float(steps))
    gen = torch.Generator().manual_seed(int(seed))
    count = [0]

    def loss(item):
        (audio, template, verts), k = item
        one_hot = eye[k : k + 1]
        fed = None
        p = own_prob if ramp is None else own_prob * min(1.0, count[0] / ramp)
        count[0] += 1
        if p > 0:
            with torch.no_grad():
                own = model(audio, template, verts, one_hot)[0]
            pick = (torch.rand(verts.shape[1], generator=gen) < p).view(1, -1, 1).to(device)
            fed = torch.where(pick, own, verts)
        return model.loss(audio, template, verts, one_hot, fed)

    def val_loss():
        if training.get("val_free_running"):
            out = [float(torch.mean((model.predict(a, t, eye[k : k + 1], v.shape[1]) - v) ** 2))
                   for a, t, v in val_items for k in range(min(n, 2))]
        else:
            out = [float(model(a, t, v, eye[k : k + 1])[1]) for a, t, v in val_items for k in range(min(n, 2))]
        return sum(out) / len(out)

    return fit_sequences(model, loss, items, val_loss if val_items else None, lr=training["lr"], seed=seed,
                         max_steps=steps, max_seconds=max_seconds, num_threads=training.get("num_threads"),
                         grad_clip=training.get("grad_clip"), desc="CodeTalker stage 2",
                         loss_scale=scale**2, on_checkpoint=on_checkpoint, fractions=fractions, step_offset=step_offset,
                         mixed_precision=mixed_precision)
