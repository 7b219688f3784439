"""The training loop of FaceFormer and CodeTalker: one sentence per step in shuffled epochs,
the weights with the lowest validation loss kept.
"""

from __future__ import annotations

import copy
import math
import time

import numpy as np
import torch
from tqdm.auto import tqdm

from baselines.common.threads import torch_threads
from blendvoca.errors import UserError

__all__ = ["epochs_to_steps", "fit_sequences"]


def fit_sequences(model, step_loss, items, val_loss=None, *, lr: float, seed: int, max_steps: float,
                  max_seconds: float, optimizer: str = "adam", num_threads=None, grad_clip=None,
                  desc: str = "training", progress: bool = True, loss_scale: float = 1.0,
                  lr_step_every: int | None = None, lr_gamma: float = 0.5) -> dict:
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
    sched = torch.optim.lr_scheduler.StepLR(opt, int(lr_step_every), lr_gamma) if lr_step_every else None
    check_every = max(1, int(max_steps // 10)) if not math.isinf(max_steps) else 200
    history = {"train_loss": [], "val": [], "best_step": None}
    best, best_state = math.inf, None

    def check(step):
        nonlocal best, best_state
        model.eval()
        with torch.no_grad():
            v = float(val_loss())
        model.train()
        history["val"].append([step, v / loss_scale])
        if v < best:
            best, best_state, history["best_step"] = v, copy.deepcopy(model.state_dict()), step

    start, step, order = time.perf_counter(), 0, []
    bar = tqdm(total=None if math.isinf(max_steps) else int(max_steps), desc=desc, disable=not progress)
    model.train()
    with torch_threads(num_threads):
        while step < max_steps and time.perf_counter() - start < max_seconds:
            if not order:
                order = list(rng.permutation(len(items)))
            loss = step_loss(items[order.pop()])
            opt.zero_grad(set_to_none=True)
            loss.backward()
            if grad_clip:
                torch.nn.utils.clip_grad_norm_(params, grad_clip)
            opt.step()
            if sched is not None:
                sched.step()
            step += 1
            history["train_loss"].append(loss.item() / loss_scale)
            bar.update(1)
            bar.set_postfix(loss=f"{history['train_loss'][-1]:.3g}", refresh=False)
            if val_loss is not None and step % check_every == 0:
                check(step)
        if val_loss is not None and step and (not history["val"] or history["val"][-1][0] != step):
            check(step)
    bar.close()
    if best_state is not None:
        model.load_state_dict(best_state)
    model.eval()
    history["steps"], history["seconds"] = step, time.perf_counter() - start
    return history


def epochs_to_steps(training: dict, n_items: int, max_steps: float, max_seconds: float) -> float:
    """``max_epochs * n_items`` when the run has no other limit, else ``max_steps``."""
    if training.get("max_epochs") and math.isinf(max_steps) and math.isinf(max_seconds):
        return int(training["max_epochs"]) * n_items
    return max_steps
