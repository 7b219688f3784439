"""Exponential moving average of model weights."""

from __future__ import annotations

import copy

import torch
from torch import nn

from benchmark.methods.training_loop import ema_decay_at


class EMA:
    """A shadow copy of a model whose trainable weights track an exponential moving average.

    The frozen speech encoder is shared with the live model, not copied.

    Parameters
    ----------
    model : baselines.said.model.SAiDModel
    max_decay : float, default 0.9999
    """

    def __init__(self, model: nn.Module, max_decay: float = 0.9999):
        memo = {id(model.encoder): model.encoder} if hasattr(model, "encoder") else {}
        self.model = copy.deepcopy(model, memo)
        self.model.requires_grad_(False)
        self.max_decay = float(max_decay)
        self.steps = 0
        self._names = [name for name, _ in self.model.named_parameters() if not name.startswith("encoder.")]
        shadows = dict(self.model.named_parameters())
        self._shadows = [shadows[name] for name in self._names]

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        """Move the shadow weights towards ``model``'s by one EMA step (one fused lerp over all of them)."""
        decay = ema_decay_at(self.steps, self.max_decay)
        live = dict(model.named_parameters())
        torch._foreach_lerp_(self._shadows, [live[name].detach() for name in self._names], 1.0 - decay)
        self.steps += 1
