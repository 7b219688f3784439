"""The torch device a ``--device`` option names (:func:`blendvoca.cli.add_device_option`),
and mixed precision on a GPU (:class:`MixedPrecision`), as the trained baselines use them.

Conventions of the baselines on a device (docs/gpu.md):

- ``Method.train(..., device=None)`` trains on the CPU; ``device="cpu"`` trains exactly
  the same weights. The network and its batches move to the device; random draws that
  decide *what* is trained (sentence order, windows, diffusion timesteps and noise)
  stay on the CPU generators, so that a seed picks the same batches everywhere.
- Mixed precision is a config switch (``mixed_precision``: ``"off"``, ``"bf16"``,
  ``"fp16"``), used on a CUDA device only: on the CPU the switch changes nothing.
"""

from __future__ import annotations

import contextlib

import torch

from benchmark.methods.config import Option
from blendvoca.cli import checked_device
from blendvoca.errors import UserError

__all__ = ["PRECISIONS", "MixedPrecision", "checked_precision", "method_device", "module_device",
           "precision_config", "precision_option", "torch_device"]

#: Values of the ``mixed_precision`` config switch.
PRECISIONS = ("off", "bf16", "fp16")


def checked_precision(value) -> str:
    """``value`` of a ``mixed_precision`` switch (None: ``"off"``).

    Raises
    ------
    UserError
        Not one of :data:`PRECISIONS`.
    """
    value = "off" if value is None else value
    if value not in PRECISIONS:
        raise UserError(f"mixed_precision: expected one of {PRECISIONS}, got {value!r}")
    return str(value)


def precision_option() -> Option:
    """The ``--config mixed_precision=...`` option of a GPU-capable plug-in, with its choices."""
    return Option("mixed_precision", (str,), "off", "autocast of the training loss on a GPU (docs/gpu.md); "
                  "nothing on the CPU", PRECISIONS)


def precision_config(value) -> dict:
    """What a plug-in adds to its recorded config for the ``mixed_precision`` switch: nothing
    when it is off (configs and result files of CPU runs stay as they were), else the switch."""
    value = checked_precision(value)
    return {} if value == "off" else {"mixed_precision": value}


def torch_device(name) -> torch.device:
    """``auto`` (a GPU when there is one, else the CPU), ``cpu``, ``cuda`` or ``cuda:N`` as a
    ``torch.device`` (a ``torch.device`` is checked the same way), as
    :func:`blendvoca.cli.checked_device` reads a ``--device`` name.

    Raises
    ------
    UserError
        A name that is no such device, or a CUDA device torch does not see here.
    """
    return torch.device(checked_device(str(name)))


def method_device(device) -> torch.device:
    """The device a method's ``train(..., device=)`` or ``to(device)`` asks for: None is
    the CPU (the baselines' own choice), anything else as :func:`torch_device` reads it."""
    return torch.device("cpu") if device is None else torch_device(device)


def module_device(module: torch.nn.Module) -> torch.device:
    """The device of ``module``'s first parameter or buffer (the CPU for a module with neither)."""
    for tensor in module.parameters():
        return tensor.device
    for tensor in module.buffers():
        return tensor.device
    return torch.device("cpu")


class MixedPrecision:
    """Autocast and gradient scaling for one training loop, on when ``precision`` asks for
    it and the device is a GPU; otherwise every method is the plain operation (the CPU
    trains bit for bit as without this object).

    Parameters
    ----------
    precision : {"off", "bf16", "fp16"} or None
        The method's ``mixed_precision`` switch (None: ``"off"``).
    device : torch.device or str
        Where the loop runs.

    Notes
    -----
    ``bf16`` has float32's exponent range: no loss scaling. ``fp16`` scales the loss
    (``torch.amp.GradScaler``), unscales before gradient clipping and skips a step whose
    gradients overflowed.
    """

    def __init__(self, precision, device):
        precision = checked_precision(precision)
        self.device = torch.device(device)
        self.precision = precision
        self.enabled = precision != "off" and self.device.type == "cuda"
        self.dtype = {"bf16": torch.bfloat16, "fp16": torch.float16}.get(precision) if self.enabled else None
        self.scaler = torch.amp.GradScaler("cuda") if self.enabled and precision == "fp16" else None

    def autocast(self):
        """The forward pass's context: ``torch.autocast`` on, or nothing."""
        if not self.enabled:
            return contextlib.nullcontext()
        return torch.autocast(device_type=self.device.type, dtype=self.dtype)

    def backward(self, loss: torch.Tensor) -> None:
        """``loss.backward()``, the loss scaled first under ``fp16``."""
        (loss if self.scaler is None else self.scaler.scale(loss)).backward()

    def unscale(self, optimizer) -> None:
        """Bring the gradients back to their true scale (before clipping them)."""
        if self.scaler is not None:
            self.scaler.unscale_(optimizer)

    def step(self, optimizer) -> None:
        """``optimizer.step()`` (skipped by the scaler on overflowed gradients under ``fp16``)."""
        if self.scaler is None:
            optimizer.step()
        else:
            self.scaler.step(optimizer)
            self.scaler.update()

    def describe(self) -> str:
        """``"off"``, or the precision in use and where (for logs and benchmarks)."""
        return f"{self.precision} autocast on {self.device}" if self.enabled else "off"
