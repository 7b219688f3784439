"""The training loop of FaceFormer and CodeTalker: one sentence per step in shuffled epochs,
the weights with the lowest validation loss kept; and the half-budget checkpoint call
every trained baseline makes (:func:`paused_training`, :func:`call_checkpoint`).
"""

from __future__ import annotations

import contextlib
import copy
import math
import time

import numpy as np
import torch
from tqdm.auto import tqdm

from baselines.common.device import MixedPrecision, module_device
from baselines.common.threads import torch_threads
from benchmark.methods.base import checkpoint_step
from blendvoca.errors import UserError

__all__ = ["call_checkpoint", "epochs_to_steps", "fit_sequences", "kept_state", "paused_training"]


@contextlib.contextmanager
def _forked_torch_rng():
    """Torch's CPU (and initialised CUDA) random states as they were once the body ends."""
    devices = list(range(torch.cuda.device_count())) if torch.cuda.is_initialized() else []
    with torch.random.fork_rng(devices=devices):
        yield


@contextlib.contextmanager
def paused_training(model, state=None):
    """Within the body ``model`` is as it would be handed over if training stopped now:
    ``state`` loaded when given (the weights training would keep: the best on validation,
    EMA weights), every module in eval mode, no gradients. Afterwards its weights, each
    submodule's train/eval mode and ``requires_grad`` flags and torch's random states
    are what they were before (generation may call ``eval()`` or seed the global RNG).

    Parameters
    ----------
    model : torch.nn.Module
    state : dict, optional
        A ``state_dict`` of ``model`` to generate with; None: its current weights.
    """
    modes = [(module, module.training) for module in model.modules()]
    flags = [(param, param.requires_grad) for param in model.parameters()]
    saved = None
    if state is not None:
        saved = {k: v.detach().clone() for k, v in model.state_dict().items()}
        model.load_state_dict(state)
    try:
        model.eval()
        with _forked_torch_rng(), torch.no_grad():
            yield model
    finally:
        if saved is not None:
            model.load_state_dict(saved)
        for module, mode in modes:
            module.training = mode
        for param, flag in flags:
            param.requires_grad_(flag)


def kept_state(best_loss, best_state, current_loss):
    """The weights a training loop that keeps its best validation weights would hand over
    if it stopped now, after a last validation of ``current_loss``: ``best_state`` when it
    is at least as good, None (the current weights) otherwise or when there is none yet."""
    if best_state is None or best_loss is None or current_loss < best_loss:
        return None
    return best_state


def call_checkpoint(on_checkpoint, step: int, model, *, total_steps=None, state=None) -> None:
    """``on_checkpoint(step, total_steps=...)`` with ``model`` paused (:func:`paused_training`):
    the method's half-budget call of the contract (``Method.train``, docs/methods.md)."""
    with paused_training(model, state):
        if total_steps is None:
            on_checkpoint(int(step))
        else:
            on_checkpoint(int(step), total_steps=int(total_steps))


def fit_sequences(model, step_loss, items, val_loss=None, *, lr: float, seed: int, max_steps: float,
                  max_seconds: float, optimizer: str = "adam", num_threads=None, grad_clip=None,
                  desc: str = "training", progress: bool = True, loss_scale: float = 1.0,
                  lr_step_every: int | None = None, lr_gamma: float = 0.5, on_checkpoint=None,
                  step_offset: int = 0, mixed_precision=None) -> dict:
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
        The runner's half-budget call (``Method.train``): in a step-limited run (finite
        ``max_steps``, no ``max_seconds``) called once after step ``max_steps // 2``,
        as ``on_checkpoint(step_offset + step, total_steps=step_offset + max_steps)``,
        with the weights this loop would keep if it stopped there (the best on
        validation, a validation at that step included; it is not recorded, so the
        run goes on exactly as without the call).
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
    check_every = max(1, int(max_steps // 10)) if not math.isinf(max_steps) else 200
    half = checkpoint_step(max_steps) if on_checkpoint is not None and math.isinf(max_seconds) else None
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

    def at_half(step):
        state = None
        if val_loss is not None:
            if history["val"] and history["val"][-1][0] == step:
                state = best_state  # validated at this very step: the kept weights are known
            else:
                with paused_training(model):
                    state = kept_state(best, best_state, float(val_loss()))
        call_checkpoint(on_checkpoint, step_offset + step, model, total_steps=step_offset + int(max_steps),
                        state=state)

    start, step, order = time.perf_counter(), 0, []
    bar = tqdm(total=None if math.isinf(max_steps) else int(max_steps), desc=desc, disable=not progress)
    model.train()
    with torch_threads(num_threads):
        while step < max_steps and time.perf_counter() - start < max_seconds:
            if not order:
                order = list(rng.permutation(len(items)))
            with amp.autocast():
                loss = step_loss(items[order.pop()])
            opt.zero_grad(set_to_none=True)
            amp.backward(loss)
            if grad_clip:
                amp.unscale(opt)
                torch.nn.utils.clip_grad_norm_(params, grad_clip)
            amp.step(opt)
            if sched is not None:
                sched.step()
            step += 1
            history["train_loss"].append(loss.item() / loss_scale)
            bar.update(1)
            bar.set_postfix(loss=f"{history['train_loss'][-1]:.3g}", refresh=False)
            if val_loss is not None and step % check_every == 0:
                check(step)
            if step == half:
                at_half(step)
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
