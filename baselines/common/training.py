"""The training step of FaceFormer and CodeTalker: one sentence per step in shuffled epochs,
on the one training loop (:class:`benchmark.methods.training_loop.StepLoop`: the weights with
the lowest validation loss kept, the runner's checkpoint calls).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from baselines.common.device import MixedPrecision, module_device
from baselines.common.sequences import sequence_tensors
from benchmark.methods.training_loop import StepLoop, optimiser_step
from blendvoca.errors import UserError

__all__ = ["epochs_to_steps", "fit_sequences", "style_items"]


def style_items(model, train, val, subjects, scale: float) -> tuple[list, list, torch.Tensor]:
    """``(items, val_items, one_hot_rows)`` of a style network's training, on the device ``model`` is
    on: each train sentence's :func:`~baselines.common.sequences.sequence_tensors` with the index of
    its speaker in ``subjects``, each val sentence's tensors, and ``torch.eye(len(subjects))``."""
    w2v = model.config["audio"]["kind"] == "wav2vec2"
    device = module_device(model)
    items = [(sequence_tensors(s, scale=scale, normalise_audio=w2v, device=device), subjects.index(s.subject))
             for s in train]
    val_items = [sequence_tensors(s, scale=scale, normalise_audio=w2v, device=device) for s in val]
    return items, val_items, torch.eye(len(subjects), device=device)


def fit_sequences(model, step_loss, items, val_loss=None, *, lr: float, seed: int, max_steps: float,
                  max_seconds: float, optimizer: str = "adam", num_threads=None, grad_clip=None,
                  desc: str = "training", loss_scale: float = 1.0, lr_step_every: int | None = None,
                  lr_gamma: float = 0.5, on_checkpoint=None, fractions=(0.5,), step_offset: int = 0,
                  mixed_precision=None) -> dict:
    """Optimise ``model``'s trainable parameters, one item per step in shuffled epochs.

    Parameters
    ----------
    model : nn.Module
    step_loss : callable
        ``step_loss(item) -> scalar loss`` in train mode.
    items : list
        What ``step_loss`` takes (one sentence each).
    val_loss : callable, optional
        ``val_loss() -> float`` in eval mode; checked ten times over a step-limited run
        (every 200 steps otherwise) and at the end; the best weights are kept.
    lr : float
    optimizer : {"adam", "adamw"}
    loss_scale : float
        Divides the logged losses (undoes a unit change of the targets).
    lr_step_every : int, optional
        Multiply the learning rate by ``lr_gamma`` every this many steps (a StepLR).
    on_checkpoint : callable, optional
        The runner's checkpoint call (``TrainingRequest.on_checkpoint``), made by the loop
        at the ``fractions`` of a step-limited run (finite ``max_steps``, no ``max_seconds``),
        as ``on_checkpoint(step_offset + step, total_steps=step_offset + max_steps)``.
    step_offset : int
        Steps of earlier training stages, added to the steps reported to ``on_checkpoint``.
    mixed_precision : {"off", "bf16", "fp16"}, optional
        Autocast of ``step_loss`` (and loss scaling under ``fp16``) when ``model`` is on a
        GPU (:class:`~baselines.common.device.MixedPrecision`); nothing on the CPU.
        Validation runs in full precision. ``step_loss`` moves its item to the model's
        device itself.

    Returns
    -------
    dict
        ``train_loss`` per step, ``val`` ``[step, loss]`` pairs, ``best_step``, ``steps``, ``seconds``.
    """
    if math.isinf(max_steps) and math.isinf(max_seconds):
        raise UserError(f"{desc}: expected a step, time or epoch limit, got none")
    rng = np.random.default_rng(seed)
    params = [p for p in model.parameters() if p.requires_grad]
    opt = (torch.optim.AdamW if optimizer == "adamw" else torch.optim.Adam)(params, lr=lr)
    amp = MixedPrecision(mixed_precision, module_device(model))
    sched = torch.optim.lr_scheduler.StepLR(opt, int(lr_step_every), lr_gamma) if lr_step_every else None
    order = []

    def step(loop):
        if not order:
            order.extend(rng.permutation(len(items)))
        with amp.autocast():
            loss = step_loss(items[order.pop()])
        optimiser_step(loss, opt, amp=amp, grad_clip=grad_clip, params=params, scheduler=sched)
        return loss.item() / loss_scale

    loop = StepLoop(model=model, max_steps=max_steps, max_seconds=max_seconds, desc=desc, threads=num_threads,
                    validate=val_loss,
                    validate_every=max(1, int(max_steps // 10)) if not math.isinf(max_steps) else 200,
                    on_checkpoint=on_checkpoint if math.isinf(max_seconds) else None, fractions=fractions,
                    step_offset=step_offset)
    model.train()
    done = loop.run(step)
    return {"train_loss": done.train_loss, "val": [[s, v / loss_scale] for s, v in done.val], "best_step": done.best_step, "steps": done.steps,
            "seconds": done.seconds}


def epochs_to_steps(training: dict, n_items: int, max_steps: float, max_seconds: float) -> float:
    """``max_epochs * n_items`` when the run has no other limit, else ``max_steps``."""
    if training.get("max_epochs") and math.isinf(max_steps) and math.isinf(max_seconds):
        return int(training["max_epochs"]) * n_items
    return max_steps
