"""The one training loop: optimisation steps under a budget (steps and/or seconds), the
validation and the weights a run keeps (the best on validation, or an EMA copy's), the
progress bar, the torch thread count, and the runner's checkpoint calls, in one place.

Each trainer supplies its step (draw a batch, compute the loss, :func:`optimiser_step`)
and its validation loss; the loop decides when to validate, which weights to keep and
when to hand the half-trained model to the runner's hook (``TrainingRequest.on_checkpoint``
at the ``checkpoint_fractions`` of the step budget, docs/methods.md, "Settled or not").
"""

from __future__ import annotations

import collections
import contextlib
import copy
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import torch

from blendvoca.runtime.progress import bar
from blendvoca.runtime.threads import limited_threads

from .request import checkpoint_steps

__all__ = ["LoopResult", "StepLoop", "ema_decay_at", "kept_state", "loops_finished", "loss_histories",
           "optimiser_step", "paused_training"]

#: How many finished loops :func:`loss_histories` keeps (a process that trains many runs, such as
#: the leaderboard's reproduce, does not keep every run's losses).
HISTORY_LIMIT = 32
#: The latest finished :meth:`StepLoop.run` of this process, oldest first: ``(number, desc,
#: step_offset, LoopResult)`` (the per-step training losses and the validations).
_HISTORIES: collections.deque = collections.deque(maxlen=HISTORY_LIMIT)
_FINISHED = [0]


def loops_finished() -> int:
    """How many :meth:`StepLoop.run` calls have finished in this process."""
    return _FINISHED[0]


def loss_histories(since: int = 0) -> list:
    """The training loops finished in this process since :func:`loops_finished` was ``since``
    (the latest `HISTORY_LIMIT` of them), oldest first: ``(desc, step_offset, LoopResult)``.
    ``benchmark.run`` notes ``loops_finished()`` before a run and draws the loss curves of
    the loops after it (its per-run figure): the one place the losses of every trainer on
    :class:`StepLoop` are kept."""
    return [(desc, offset, result) for number, desc, offset, result in _HISTORIES if number >= since]


def ema_decay_at(step: int, max_decay: float) -> float:
    """The EMA decay after ``step`` updates, ``min(max_decay, (1 + step) / (10 + step))``: the
    warm-up keeps a short run's average from being dominated by the random initialisation."""
    return min(max_decay, (1.0 + step) / (10.0 + step))


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
    devices = list(range(torch.cuda.device_count())) if torch.cuda.is_initialized() else []
    try:
        model.eval()
        with torch.random.fork_rng(devices=devices), torch.no_grad():
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


def optimiser_step(loss, optimizer, *, amp=None, grad_clip=None, params=None, clip_foreach=None,
                   scheduler=None) -> None:
    """One update from ``loss``: gradients cleared, ``loss`` back-propagated (scaled by
    ``amp``, a :class:`~baselines.common.device.MixedPrecision`, when given), their norm
    clipped at ``grad_clip`` over ``params`` (unscaled first), the optimiser's step (skipped
    by ``amp`` on overflow), then ``scheduler.step()``."""
    optimizer.zero_grad(set_to_none=True)
    if amp is None:
        loss.backward()
    else:
        amp.backward(loss)
    if grad_clip:
        if amp is not None:
            amp.unscale(optimizer)
        torch.nn.utils.clip_grad_norm_(params, grad_clip, foreach=clip_foreach)
    if amp is None:
        optimizer.step()
    else:
        amp.step(optimizer)
    if scheduler is not None:
        scheduler.step()


@dataclass
class LoopResult:
    """What :meth:`StepLoop.run` did.

    Attributes
    ----------
    steps : int
    seconds : float
    train_loss : list of float
        What the step returned, per step.
    val : list of [step, loss]
    best_step : int or None
        The validation whose weights were kept (None: none was kept).
    best_loss : float or None
    """

    steps: int = 0
    seconds: float = 0.0
    train_loss: list = field(default_factory=list)
    val: list = field(default_factory=list)
    best_step: int | None = None
    best_loss: float | None = None


class StepLoop:
    """Optimisation steps until the budget is spent, with validation, kept weights and the
    runner's checkpoint calls.

    Parameters
    ----------
    model : torch.nn.Module, optional
        What is trained: validated in eval mode (then put back in train mode), paused for
        the checkpoint calls, and left in eval mode holding the kept weights.
    max_steps, max_seconds : number, optional
        Stop after this many steps or seconds (None or ``inf``: no such limit).
    desc : str
        The progress bar's label (:func:`blendvoca.runtime.progress.bar`).
    threads : int, optional
        Torch CPU threads while training (None: unchanged).
    validate : callable, optional
        ``validate() -> float``; run every ``validate_every`` steps and after the last
        step, the weights of the lowest value kept (copied from ``kept_from``).
    kept_from : torch.nn.Module, optional
        The module whose weights are kept (an EMA copy of ``model``); default ``model``.
        Without a better validation, the run hands over ``kept_from``'s current weights.
    on_checkpoint : callable, optional
        The runner's call (``TrainingRequest.on_checkpoint``), made once after each step
        of :func:`~benchmark.methods.request.checkpoint_steps` of a finite ``max_steps``
        and ``fractions``, as ``on_checkpoint(step_offset + step, total_steps=step_offset +
        max_steps)``, with ``model`` holding the weights the run would keep if it stopped
        there (a validation at that step included, not recorded), paused
        (:func:`paused_training`); afterwards training goes on exactly as without it.
    fractions : tuple of float
        Where in the budget ``on_checkpoint`` is called (default: half).
    step_offset : int
        Steps of earlier training stages, added to the steps reported to ``on_checkpoint``.
    stop : callable, optional
        Checked before each step; True ends the run early.
    interruptible : bool
        Ctrl-C ends the run (keeping what it trained) instead of raising.
    """

    def __init__(self, *, model=None, max_steps=None, max_seconds=None, desc: str = "training", unit: str = "step",
                 threads=None, validate: Callable | None = None, validate_every: int | None = None,
                 kept_from=None, on_checkpoint: Callable | None = None, fractions=(0.5,), step_offset: int = 0,
                 stop: Callable | None = None, interruptible: bool = False):
        self.model, self.desc, self.unit, self.threads = model, desc, unit, threads
        self.max_steps = math.inf if max_steps is None else max_steps
        self.max_seconds = math.inf if max_seconds is None else max_seconds
        self.validate, self.validate_every = validate, validate_every
        self.kept_from = model if kept_from is None else kept_from
        self.on_checkpoint, self.step_offset = on_checkpoint, int(step_offset)
        self.stop, self.interruptible = stop, interruptible
        self.checkpoints = set()
        if on_checkpoint is not None and not math.isinf(self.max_steps):
            self.checkpoints = set(checkpoint_steps(self.max_steps, fractions))
        self.step = 0
        self.started = time.perf_counter()
        self.result = LoopResult()
        self._best_state = None

    def elapsed(self) -> float:
        """Seconds since the loop was made."""
        return time.perf_counter() - self.started

    def fraction_done(self) -> float:
        """The larger of the budget's step and time fractions spent (0 for a limit not set)."""
        steps = self.step / self.max_steps if self.max_steps else 1.0
        seconds = self.elapsed() / self.max_seconds if self.max_seconds else 1.0
        return max(steps, seconds)

    def spent(self) -> bool:
        """Whether the budget is spent (or ``stop`` says so)."""
        if self.step >= self.max_steps or self.elapsed() >= self.max_seconds:
            return True
        return bool(self.stop is not None and self.stop())

    def run(self, step: Callable) -> LoopResult:
        """Call ``step(loop) -> float loss`` until the budget is spent; returns :class:`LoopResult`
        (the kept weights loaded into ``model``, which is left in eval mode)."""
        result = self.result
        progress = bar(total=None if math.isinf(self.max_steps) else int(self.max_steps), desc=self.desc,
                       unit=self.unit)
        with limited_threads(self.threads, torch_only=True):
            try:
                while not self.spent():
                    loss = float(step(self))
                    self.step += 1
                    result.train_loss.append(loss)
                    progress.update(1)
                    progress.set_postfix(loss=f"{loss:.4g}", refresh=False)
                    if self.validate is not None and self.validate_every and self.step % self.validate_every == 0:
                        self._validated()
                    if self.step in self.checkpoints:
                        self._checkpoint()
            except KeyboardInterrupt:
                if not self.interruptible:
                    raise
            finally:
                if self.step < self.max_steps and self.elapsed() >= self.max_seconds and not progress.disable:
                    # the bar stops short of its total: say why, not leave it at 66 %
                    progress.write(f"{self.desc}: the time budget of {self.max_seconds:g} s ran out at "
                                   f"{self.unit} {self.step}" + ("" if math.isinf(self.max_steps) else
                                                                 f" of {int(self.max_steps)}"), file=sys.stderr)
                progress.close()
            if self.validate is not None and self.step and (not result.val or result.val[-1][0] != self.step):
                self._validated()
        kept = self._kept(None)
        if self.model is not None:
            if kept is not None:
                self.model.load_state_dict(kept)
            self.model.eval()
        result.steps, result.seconds = self.step, self.elapsed()
        _HISTORIES.append((_FINISHED[0], self.desc, self.step_offset, result))
        _FINISHED[0] += 1
        return result

    def _validated(self) -> None:
        """Validate now, record it, and keep the weights when they are the best yet."""
        self.model.eval()
        with torch.no_grad():
            value = float(self.validate())
        self.model.train()
        result = self.result
        result.val.append([self.step, value])
        if value < (math.inf if result.best_loss is None else result.best_loss):
            result.best_loss, result.best_step = value, self.step
            self._best_state = copy.deepcopy(self.kept_from.state_dict())

    def _kept(self, current_loss):
        """The weights the run would hand over now (None: ``model``'s own), given a last
        validation of ``current_loss`` (None: no new validation)."""
        best = self._best_state
        if current_loss is not None:
            best = kept_state(self.result.best_loss, best, current_loss)
        if best is None and self.kept_from is not self.model:
            best = {k: v.detach().clone() for k, v in self.kept_from.state_dict().items()}
        return best

    def _checkpoint(self) -> None:
        """The runner's call, with ``model`` paused holding the weights the run would keep now."""
        if self.validate is None or (self.result.val and self.result.val[-1][0] == self.step):
            state = self._kept(None)
        else:
            with paused_training(self.model):
                current = float(self.validate())
            state = self._kept(current)
        with paused_training(self.model, state):
            self.on_checkpoint(self.step_offset + self.step, total_steps=self.step_offset + int(self.max_steps))
