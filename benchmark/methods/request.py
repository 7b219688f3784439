"""What ``Method.train`` is given (method contract v3): a :class:`TrainingRequest` holding
the seed, the :class:`Budget`, the device and the runner's checkpoint hook; and the one
adapter through which the runner calls a contract-v2 plug-in (:func:`call_train`).

The request is one frozen value so that the contract grows by a field with a default, not
by a new keyword every plug-in must accept.

Which contract a plug-in speaks is declared, not read from its signature: the class that
defines the ``train`` the plug-in uses says ``contract = 3`` in its own body
(:class:`~benchmark.methods.base.Method` does, for the methods that do not train); a class
that defines ``train`` without declaring it is a contract-v2 plug-in, written before the
request existed (``train(dataset, *, seed, budget, ...)``).
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["CONTRACT", "Budget", "TrainingRequest", "call_train", "checkpoint_steps", "train_contract"]

#: The method contract this runner speaks: ``train(dataset, request)``.
CONTRACT = 3

@dataclass(frozen=True)
class Budget:
    """Limits on training: a number of optimisation steps and/or wall seconds.

    Parameters
    ----------
    max_steps : int or None
        Stop after this many optimisation steps; ``None`` means no step limit.
    max_seconds : float or None
        Stop once this many seconds of wall time have passed; ``None`` means no
        time limit.
    """

    max_steps: int | None = None
    max_seconds: float | None = None

    def __post_init__(self):
        if self.max_steps is not None:
            if isinstance(self.max_steps, bool) or not isinstance(self.max_steps, (int, np.integer)):
                raise TypeError(f"Budget.max_steps: expected an int or None, got {type(self.max_steps).__name__}")
            if self.max_steps < 0:
                raise ValueError(f"Budget.max_steps: expected >= 0, got {self.max_steps}")
        if self.max_seconds is not None:
            if not isinstance(self.max_seconds, (int, float, np.floating)) or isinstance(self.max_seconds, bool):
                raise TypeError(
                    f"Budget.max_seconds: expected a number or None, got {type(self.max_seconds).__name__}"
                )
            if not math.isfinite(self.max_seconds) or self.max_seconds < 0:
                raise ValueError(f"Budget.max_seconds: expected a finite number >= 0, got {self.max_seconds}")

    def steps(self, default: int) -> int:
        """Number of steps to run: ``max_steps`` when set, else ``default``."""
        return int(default if self.max_steps is None else self.max_steps)

    def exhausted(self, step: int, started: float) -> bool:
        """True once ``step`` steps have run or the time limit since ``started`` has passed.

        Parameters
        ----------
        step : int
            Steps completed so far.
        started : float
            ``time.perf_counter()`` value taken when training began.
        """
        if self.max_steps is not None and step >= self.max_steps:
            return True
        return bool(self.max_seconds is not None and time.perf_counter() - started >= self.max_seconds)

    def to_dict(self) -> dict:
        """JSON-serialisable form, as stored in result files."""
        return asdict(self)


def checkpoint_steps(total_steps, fractions=(0.5,)) -> tuple[int, ...]:
    """The steps after which a run of ``total_steps`` steps calls the checkpoint hook: for
    each fraction ``f``, ``floor(f * total_steps)`` (the half: ``total_steps // 2``), in
    order, without repeats and without step 0; none when the step count is not known in
    advance (None, ``inf``: a time-limited run).

    Parameters
    ----------
    total_steps : int, float or None
    fractions : sequence of float in (0, 1)
    """
    if total_steps is None or isinstance(total_steps, bool):
        return ()
    try:
        total = float(total_steps)
    except (TypeError, ValueError):
        return ()
    if not math.isfinite(total):
        return ()
    steps = {math.floor(float(f) * int(total)) for f in fractions}
    return tuple(sorted(s for s in steps if s >= 1))


@dataclass(frozen=True)
class TrainingRequest:
    """What the runner asks of ``Method.train(dataset, request)`` (method contract v3).

    Attributes
    ----------
    seed : int
        Seed for every random choice made while training.
    budget : Budget
        Step and/or time limit.
    device : str, optional
        Where a method that runs a network trains it and then generates (``"cpu"``,
        ``"cuda"``, ``"cuda:N"``); None: the method's own choice (the CPU for every bundled
        baseline). ``"cpu"`` must train exactly what None trains.
    on_checkpoint : callable, optional
        The runner's check of a half-trained model (docs/methods.md, "Settled or not"):
        ``on_checkpoint(step, total_steps=N)``, called once after each step of
        :meth:`checkpoint_steps` of a run that trains a known number of steps ``N``, with the
        method able to :meth:`~benchmark.methods.base.Method.generate` as it would be had
        its training stopped there. The bundled baselines make the call through
        :class:`benchmark.methods.training_loop.StepLoop`.
    checkpoint_fractions : tuple of float
        Where in the step budget ``on_checkpoint`` is called (default: at half of it).
    """

    seed: int = 0
    budget: Budget = Budget()
    device: str | None = None
    on_checkpoint: Callable | None = None
    checkpoint_fractions: tuple = (0.5,)

    def __post_init__(self):
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise TypeError(f"TrainingRequest.seed: expected an int, got {type(self.seed).__name__}")
        if not isinstance(self.budget, Budget):
            raise TypeError(f"TrainingRequest.budget: expected a Budget, got {type(self.budget).__name__}")
        fractions = tuple(float(f) for f in self.checkpoint_fractions)
        if not all(0.0 < f < 1.0 for f in fractions):
            raise ValueError(f"TrainingRequest.checkpoint_fractions: expected fractions in (0, 1), got {fractions}")
        object.__setattr__(self, "checkpoint_fractions", fractions)

    def checkpoint_steps(self, total_steps) -> tuple[int, ...]:
        """The steps of a ``total_steps`` run after which ``on_checkpoint`` is called: none
        without a hook or under a time limit (the fractions of a time-limited run depend on
        the machine), else :func:`checkpoint_steps`."""
        if self.on_checkpoint is None or self.budget.max_seconds is not None:
            return ()
        return checkpoint_steps(total_steps, self.checkpoint_fractions)


def train_contract(cls) -> int:
    """The method contract ``cls``'s ``train`` speaks: the ``contract`` declared in the body
    of the class that defines that ``train`` (3 for :class:`~benchmark.methods.base.Method`),
    2 when that class declares none (a plug-in written before contract v3)."""
    for klass in getattr(cls, "__mro__", (type(cls),)):
        if "train" in vars(klass):
            return int(vars(klass).get("contract", 2))
    return CONTRACT


def call_train(method, dataset, request: TrainingRequest) -> None:
    """``method.train(dataset, request)``; a contract-v2 plug-in (:func:`train_contract`) is
    called ``train(dataset, seed=..., budget=...)`` instead, after one ``DeprecationWarning``
    (it gets no device and no checkpoint hook: the runner moves it afterwards and records
    the run as not checked).

    Raises
    ------
    TypeError
        The plug-in's ``train`` rejected the call (the message names the contract expected).
    """
    name = getattr(method, "name", type(method).__name__)
    if train_contract(type(method)) >= CONTRACT:
        try:
            return method.train(dataset, request)
        except TypeError as exc:
            if exc.__traceback__ is not None and exc.__traceback__.tb_next is None:  # the call itself
                raise TypeError(f"method {name!r} declares method contract v{CONTRACT}, train(dataset, request), "
                                f"but its train does not take that call ({exc}); a plug-in whose train takes "
                                f"seed=/budget= keywords is contract v2 and must not declare contract = "
                                f"{CONTRACT} (docs/methods.md)") from exc
            raise
    with warnings.catch_warnings():
        if not sys.warnoptions:  # shown once, also where DeprecationWarning is ignored by default
            warnings.simplefilter("default", DeprecationWarning)
        warnings.warn(f"method {name!r} speaks method contract v2, train(dataset, *, seed, budget): it still trains, "
                      f"without a device or the convergence check; port it to contract v{CONTRACT}, "
                      f"train(dataset, request) with contract = {CONTRACT} (docs/methods.md)",
                      DeprecationWarning, stacklevel=3)
    try:
        return method.train(dataset, seed=request.seed, budget=request.budget)
    except TypeError as exc:
        if exc.__traceback__ is not None and exc.__traceback__.tb_next is None:
            raise TypeError(f"method {name!r}: its train takes neither contract v{CONTRACT}'s call, "
                            f"train(dataset, request) (declare contract = {CONTRACT} in the class that defines it), "
                            f"nor contract v2's, train(dataset, *, seed, budget) ({exc})") from exc
        raise
