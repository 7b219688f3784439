"""Settled or not: the half-budget check of a trained method.

A method that trains a known number of steps calls ``on_checkpoint(step)`` once it has
done half of them (``Method.train``, docs/methods.md). The runner then generates the
split as the method is at that point (the same sentences, samples and seeds as the
full run) and scores two primary metrics only, :data:`CHECK_METRICS` (``lve_rig`` and
``fd``); after training it scores everything. A metric is *not settled* when its
full-budget value differs from its half-budget value by more than half the width of
its full-budget ``ci95``: the training budget, not the method, may then decide its
place. The result records::

    "convergence": {"checked_at_step", "total_steps",
                    "metrics": {"lve_rig": {"half_budget", "full_budget", "half_width", "settled"},
                                "fd": {...}},
                    "settled": bool}

``protocol.convergence_check`` says ``"checked"`` or why there was no check (and then
there is no ``convergence``): :data:`NOT_CHECKED` lists the reasons.

A row scored with another row's training (the board's CDFace rows share one training
per seed) has no half-budget state of its own; it carries that row's verdict,
:func:`shared_convergence`: ``{"shared_with": <row>, "checked_at_step", "total_steps",
"metrics": {}, "settled"}``.
"""

from __future__ import annotations

import contextlib
import inspect
import os
import random
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmark.methods import get_method
from benchmark.methods.base import takes_checkpoint_hook
from benchmark.methods.contract import COEFFICIENT_NAMES, OUTPUT_COEFFICIENTS, OUTPUT_VERTICES
from benchmark.protocol.generation import Generated, generated_tracks
from benchmark.protocol.limits import generate_limit
from benchmark.protocol.spec import trains_nothing
from benchmark.runs import TrackWriter

__all__ = [
    "CHECKED",
    "CHECK_METRICS",
    "NOT_CHECKED",
    "HalfBudget",
    "HalfBudgetCheck",
    "combined_convergence",
    "convergence_record",
    "half_budget_check",
    "not_checked_reason",
    "shared_convergence",
    "preserved_random_state",
]

#: The metrics scored at half the budget: the primary vertex error and the primary
#: distribution distance.
CHECK_METRICS = ("lve_rig", "fd")

#: ``protocol.convergence_check`` of a checked run.
CHECKED = "checked"

#: ``protocol.convergence_check`` of a run without the check, by reason.
NOT_CHECKED = {
    "loaded": "not checked: loaded from a checkpoint (nothing trained, no half-budget state)",
    "time": "not checked: time budget (the half of a time-limited run depends on the machine)",
    "untrained": "not checked: the method trains nothing",
    "old_plugin": "not checked: the method's train takes no on_checkpoint",
    "no_call": "not checked: the method made no half-budget call (no step limit, or fewer than 2 steps)",
    "no_metrics": "not checked: the evaluation gave neither lve_rig nor fd",
}


@contextlib.contextmanager
def preserved_random_state():
    """The global random states (Python's ``random``, numpy's legacy one, torch's CPU and
    initialised CUDA generators) are what they were once the body ends: a method that
    generates with a seed mid-training then trains on as it would have."""
    python_state, numpy_state = random.getstate(), np.random.get_state()
    torch = sys.modules.get("torch")  # torch is never imported here for a method that does not use it
    torch_state = cuda_states = None
    if torch is not None:
        torch_state = torch.random.get_rng_state()
        if torch.cuda.is_available() and torch.cuda.is_initialized():
            cuda_states = torch.cuda.get_rng_state_all()
    try:
        yield
    finally:
        random.setstate(python_state)
        np.random.set_state(numpy_state)
        if torch_state is not None:
            torch.random.set_rng_state(torch_state)
        if cuda_states is not None:
            torch.cuda.set_rng_state_all(cuda_states)


@dataclass(frozen=True)
class HalfBudget:
    """What the half-budget call measured.

    Attributes
    ----------
    step : int
        The step the method called at.
    total_steps : int or None
        The steps of the whole run (the method's word, else the budget's), None when unknown.
    values : dict
        ``{metric: value}`` of :data:`CHECK_METRICS` the evaluation gave.
    """

    step: int
    total_steps: int | None
    values: dict = field(default_factory=dict)


def _accepts(function, name: str) -> bool:
    """Whether ``function`` takes the keyword ``name`` (or ``**kwargs``)."""
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == name or p.kind == p.VAR_KEYWORD for p in parameters)


class HalfBudgetCheck:
    """The runner's ``on_checkpoint``: at the first call, the split generated by the method
    as it is and scored on :data:`CHECK_METRICS`; later calls are ignored.

    Parameters
    ----------
    spec : RunSpec
        Split, samples, seed, clip, generation limit, batch and progress of the run.
    inputs : Inputs
        The dataset, and the results folder (a vertex method's vertices are staged there
        while they are scored, then removed).
    evaluate : callable, optional
        The run's evaluation (called with ``metrics=CHECK_METRICS`` when it takes that
        keyword); default ``benchmark.evaluation.evaluate_split(..., metrics=CHECK_METRICS)``.
    """

    def __init__(self, spec, inputs, *, evaluate=None):
        self.spec, self.inputs, self.evaluate = spec, inputs, evaluate
        self.result: HalfBudget | None = None
        self.seconds = 0.0

    @property
    def called(self) -> bool:
        """Whether the method made the call (and it was measured)."""
        return self.result is not None

    def __call__(self, method, step: int, total_steps=None) -> None:
        if self.result is not None:
            return
        start = time.perf_counter()
        try:
            with preserved_random_state():
                values = self._measure(method)
        finally:
            self.seconds += time.perf_counter() - start
        if total_steps is None:
            total_steps = self.spec.budget.max_steps
        self.result = HalfBudget(step=int(step), total_steps=None if total_steps is None else int(total_steps),
                                 values=values)

    def _measure(self, method) -> dict:
        spec, dataset = self.spec, self.inputs.dataset
        vertex_method = getattr(method, "output", OUTPUT_COEFFICIENTS) == OUTPUT_VERTICES
        writer = None
        if vertex_method:  # the vertices go to disk, as in the full run, and are read back lazily
            names = tuple(getattr(dataset, "names", ()) or COEFFICIENT_NAMES)
            writer = TrackWriter(Path(self.inputs.results_dir) / f".half-budget-{os.getpid()}", names)
        try:
            tracks, _ = generated_tracks(method, dataset, split=spec.split, samples=spec.samples, seed=spec.seed,
                                         clip=spec.clip, name=spec.method, progress=spec.progress, store=writer,
                                         time_limit=generate_limit(spec.generate_time_limit),
                                         sentence_batch=spec.sentence_batch)
            extra = {} if writer is None else {"vertices": writer.stored_vertices()}
            if self.evaluate is None:
                from benchmark.evaluation import EvaluationSettings, evaluate_split
                from blendvoca.runtime.progress import progress_bars

                with progress_bars(spec.progress):
                    scores = evaluate_split(Generated(tracks, vertices=extra.get("vertices")), dataset, spec.split,
                                            EvaluationSettings(), metrics=CHECK_METRICS)
            elif _accepts(self.evaluate, "metrics"):
                scores = self.evaluate(tracks, dataset, split=spec.split, metrics=CHECK_METRICS, **extra)
            else:
                scores = self.evaluate(tracks, dataset, split=spec.split, **extra)
        finally:
            if writer is not None:
                writer.discard()
        return {name: float(scores[name]["mean"]) for name in CHECK_METRICS if name in scores}


def not_checked_reason(spec) -> str | None:
    """Why the run ``spec`` asks for gets no half-budget check (a :data:`NOT_CHECKED`
    value), judged before training; None when it may get one (the method still has to
    make the call)."""
    if spec.checkpoint is not None:
        path = Path(os.fspath(spec.checkpoint)).expanduser()
        if path.is_file() or (path.is_dir() and any(path.iterdir())):
            return NOT_CHECKED["loaded"]
    cls = get_method(spec.method)
    if trains_nothing(cls) is not None:
        return NOT_CHECKED["untrained"]
    if spec.budget.max_seconds is not None:
        return NOT_CHECKED["time"]
    if not takes_checkpoint_hook(cls.train):
        return NOT_CHECKED["old_plugin"]
    return None


def half_budget_check(spec, inputs, *, evaluate=None) -> tuple[HalfBudgetCheck | None, str | None]:
    """The check for the run ``spec`` and, when it gets none, why.

    Returns
    -------
    check : HalfBudgetCheck or None
    reason : str or None
        A :data:`NOT_CHECKED` value when ``check`` is None.
    """
    reason = not_checked_reason(spec)
    if reason is not None:
        return None, reason
    return HalfBudgetCheck(spec, inputs, evaluate=evaluate), None


def _half_width(entry) -> float:
    ci = entry.get("ci95")
    if not ci:
        return 0.0
    return (float(ci[1]) - float(ci[0])) / 2.0


def convergence_record(half: HalfBudget | None, metrics) -> dict | None:
    """The ``convergence`` section of one run from its half-budget values and its
    full-budget metric entries (``{"mean", "ci95", ...}``); None without a half-budget
    call or when neither metric of :data:`CHECK_METRICS` was scored both times.

    A metric is settled when ``|full - half| <= half_width``, ``half_width`` being half
    the width of the full-budget ``ci95``; the run is settled when each checked metric is.
    """
    if half is None:
        return None
    out = {}
    for name in CHECK_METRICS:
        if name not in half.values or name not in metrics:
            continue
        full, value = float(metrics[name]["mean"]), float(half.values[name])
        width = _half_width(metrics[name])
        out[name] = {"half_budget": value, "full_budget": full, "half_width": width,
                     "settled": bool(abs(full - value) <= width)}
    if not out:
        return None
    return {"checked_at_step": half.step, "total_steps": half.total_steps, "metrics": out,
            "settled": all(m["settled"] for m in out.values())}


def checked_convergence(check: HalfBudgetCheck | None, reason: str | None, metrics) -> tuple[dict | None, str | None]:
    """A run's ``convergence`` record and what ``protocol.convergence_check`` says of it.

    Parameters
    ----------
    check, reason
        What :func:`half_budget_check` returned for the run.
    metrics : mapping
        The run's full-budget metric entries.

    Returns
    -------
    (record or None, :data:`CHECKED` or the reason it was not checked)
    """
    if check is None:
        return None, reason
    record = convergence_record(check.result, metrics)
    if not check.called:
        return record, NOT_CHECKED["no_call"]
    return record, NOT_CHECKED["no_metrics"] if record is None else CHECKED


def shared_convergence(owner, owner_row: str) -> dict | None:
    """The ``convergence`` record of a row scored with the training of ``owner_row``,
    whose own record (a seed's or the row's) is ``owner``: that training's verdict and
    budget, no metrics of its own (its half-budget model generated only ``owner_row``'s
    samples). None when ``owner`` is None (that training was not checked)."""
    if owner is None:
        return None
    return {"shared_with": str(owner_row), "checked_at_step": owner.get("checked_at_step"),
            "total_steps": owner.get("total_steps"), "metrics": {}, "settled": bool(owner["settled"])}


def combined_convergence(per_seed, metrics) -> dict | None:
    """The top-level ``convergence`` of a run over several seeds from each seed's record
    (``per_seed``, :func:`convergence_record` outputs) and the combined metric entries.

    Per metric: the half- and full-budget values are the means over the seeds,
    ``half_width`` is half the width of the combined (two-level) ``ci95``, and the
    metric is settled when the seed means moved by at most that *and* every seed's
    value is settled. None unless every seed was checked.
    """
    records = list(per_seed)
    if not records or any(r is None for r in records):
        return None
    names = [n for n in CHECK_METRICS if all(n in r["metrics"] for r in records) and n in metrics]
    if not names:
        return None
    out = {}
    for name in names:
        half = float(np.mean([r["metrics"][name]["half_budget"] for r in records]))
        full = float(np.mean([r["metrics"][name]["full_budget"] for r in records]))
        width = _half_width(metrics[name])
        out[name] = {"half_budget": half, "full_budget": full, "half_width": width,
                     "settled": bool(abs(full - half) <= width and all(r["metrics"][name]["settled"]
                                                                     for r in records))}
    # one budget for every seed: the first seed's steps stand for all
    return {"checked_at_step": records[0]["checked_at_step"], "total_steps": records[0]["total_steps"],
            "metrics": out, "settled": all(m["settled"] for m in out.values()) and all(r["settled"] for r in records)}
