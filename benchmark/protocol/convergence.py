"""Settled or not: the learning curve of a trained method.

A method that trains a known number of steps calls ``on_checkpoint(step)`` once it has
done each :data:`CURVE_FRACTIONS` of them (a quarter and half; ``Method.train``,
docs/methods.md; ``benchmark.run --checkpoint-fractions``). At each call the runner
generates the split as the method is at that point (the same sentences, samples and
seeds as the full run) and scores two primary metrics only, :data:`CHECK_METRICS`
(``lve_rig`` and ``fd``); after training it scores everything. The half-budget call
(the checkpoint nearest half the steps) gives the record's per-metric move: a metric
moved when its full-budget value differs from its half-budget value by more than half
the width of its full-budget ``ci95`` (``settled`` below, kept as information). Whether
the move matters is the table's judgement: :mod:`leaderboard.settled` puts the
half-budget values in place of the full-budget ones and names the statements of the
table that would change. For that the record keeps, per checkpoint, what the paired
resampling reads: the per-sentence values of the sentence-level check metrics (in the
order of ``sentences``) and the bootstrap replicates of the set-level ones::

    "convergence": {"checked_at_step", "total_steps",
                    "metrics": {"lve_rig": {"half_budget", "full_budget", "half_width", "settled"},
                                "fd": {...}},
                    "settled": bool,
                    "sentences": [[subject, sentence], ...],
                    "curve": [{"step", "metrics": {"lve_rig": v, "fd": v},
                               "per_sentence": {"lve_rig": [v per sentence]},
                               "replicates": {"fd": [bootstrap replicates]}}, ...]}

The full budget's point of the curve is the row's own metrics (``total_steps``).

``protocol.convergence_check`` says ``"checked"`` or why there was no check (and then
there is no ``convergence``): :data:`NOT_CHECKED` lists the reasons.

A row scored with another row's training (the board's CDFace rows share one training
per seed) has no half-budget state of its own; it carries that row's verdict,
:func:`shared_convergence`: ``{"shared_with": <row>, "checked_at_step", "total_steps",
"metrics": {}, "settled"}``.
"""

from __future__ import annotations

import contextlib
import os
import random
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmark.methods import get_method
from benchmark.methods.request import CONTRACT, train_contract
from benchmark.methods.contract import COEFFICIENT_NAMES, OUTPUT_COEFFICIENTS, OUTPUT_VERTICES
from benchmark.protocol.generation import Generated, generated_tracks
from benchmark.protocol.limits import generate_limit
from benchmark.protocol.spec import checked_fractions, trains_nothing
from benchmark.runs import TrackWriter

__all__ = [
    "CHECKED",
    "CHECK_METRICS",
    "CURVE_FRACTIONS",
    "NOT_CHECKED",
    "HalfBudget",
    "HalfBudgetCheck",
    "combined_convergence",
    "convergence_record",
    "curve_record",
    "half_budget_check",
    "not_checked_reason",
    "shared_convergence",
    "preserved_random_state",
]

#: The metrics scored at half the budget: the primary vertex error and the primary
#: distribution distance.
CHECK_METRICS = ("lve_rig", "fd")

#: Where in the step budget the learning curve is scored (the full budget is the run itself).
CURVE_FRACTIONS = (0.25, 0.5)

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
    sentences : list
        ``[[subject, sentence], ...]``: the order of ``per_sentence``'s values.
    per_sentence : dict
        ``{metric: [value per sentence]}`` of the sentence-level check metrics (what the
        paired resampling of the tables reads).
    replicates : dict
        ``{metric: [bootstrap replicates]}`` of the set-level check metrics.
    """

    step: int
    total_steps: int | None
    values: dict = field(default_factory=dict)
    sentences: list = field(default_factory=list)
    per_sentence: dict = field(default_factory=dict)
    replicates: dict = field(default_factory=dict)


class HalfBudgetCheck:
    """The runner's ``on_checkpoint``: at each call (each of ``fractions`` of the step
    budget), the split generated by the method as it is and scored on :data:`CHECK_METRICS`;
    :attr:`points` holds every call, :attr:`result` the one nearest half the budget.

    Parameters
    ----------
    spec : RunSpec
        Split, samples, seed, clip, generation limit and batch of the run.
    inputs : Inputs
        The dataset, and the results folder (a vertex method's vertices are staged there
        while they are scored, then removed).
    evaluate : callable, optional
        The run's evaluation, ``evaluate(tracks, dataset, split=..., metrics=..., [vertices=...])``
        as in :func:`benchmark.protocol.scoring.score`, called with ``metrics=CHECK_METRICS``
        (it may compute more; only those are kept); default
        ``benchmark.evaluation.evaluate_split(..., metrics=CHECK_METRICS)``.
    fractions : sequence of float, optional
        Where the method calls (:func:`checked_fractions`); default ``spec.checkpoint_fractions``,
        else :data:`CURVE_FRACTIONS`. A fraction of 1 is the full budget (scored anyway).
    """

    def __init__(self, spec, inputs, *, evaluate=None, fractions=None):
        self.spec, self.inputs, self.evaluate = spec, inputs, evaluate
        if fractions is None:
            fractions = getattr(spec, "checkpoint_fractions", None) or CURVE_FRACTIONS
        #: The fractions handed to the method's training (those below 1).
        self.fractions = tuple(f for f in checked_fractions(fractions) if f < 1.0)
        self.points: list[HalfBudget] = []
        self.seconds = 0.0

    @property
    def result(self) -> HalfBudget | None:
        """The call nearest half the budget (the record's half-budget values); None before any."""
        if not self.points:
            return None
        return min(self.points, key=lambda p: (abs(2 * p.step - (p.total_steps or 2 * p.step)), -p.step))

    @property
    def called(self) -> bool:
        """Whether the method made the call (and it was measured)."""
        return self.result is not None

    def __call__(self, method, step: int, total_steps=None) -> None:
        if any(p.step == int(step) for p in self.points):
            return
        start = time.perf_counter()
        try:
            with preserved_random_state():
                measured = self._measure(method)
        finally:
            self.seconds += time.perf_counter() - start
        if total_steps is None:
            total_steps = self.spec.budget.max_steps
        self.points.append(HalfBudget(step=int(step), total_steps=None if total_steps is None else int(total_steps),
                                      **measured))

    def _measure(self, method) -> dict:
        spec, dataset = self.spec, self.inputs.dataset
        vertex_method = getattr(method, "output", OUTPUT_COEFFICIENTS) == OUTPUT_VERTICES
        writer = None
        if vertex_method:  # the vertices go to disk, as in the full run, and are read back lazily
            names = tuple(getattr(dataset, "names", ()) or COEFFICIENT_NAMES)
            writer = TrackWriter(Path(self.inputs.results_dir) / f".half-budget-{os.getpid()}", names)
        try:
            tracks, _ = generated_tracks(method, dataset, split=spec.split, samples=spec.samples, seed=spec.seed,
                                         clip=spec.clip, name=spec.method, store=writer,
                                         time_limit=generate_limit(spec.generate_time_limit),
                                         sentence_batch=spec.sentence_batch)
            extra = {} if writer is None else {"vertices": writer.stored_vertices()}
            if self.evaluate is None:  # the run's own VAE scores the curve's FD, as it scores the row's
                from benchmark.evaluation import evaluate_split
                from benchmark.protocol.scoring import run_settings

                scores = evaluate_split(Generated(tracks, vertices=extra.get("vertices")), dataset, spec.split,
                                        run_settings(spec, lipsync=False), metrics=CHECK_METRICS)
            else:
                scores = self.evaluate(tracks, dataset, split=spec.split, metrics=CHECK_METRICS, **extra)
        finally:
            if writer is not None:
                writer.discard()
        return checkpoint_scores(scores)


def checkpoint_scores(scores) -> dict:
    """What a checkpoint keeps of an evaluation's ``scores`` (the fields of
    :class:`HalfBudget` but its steps): each check metric's mean, the sentence-level ones'
    per-sentence values (``scores.per_sentence`` rows, when the evaluation gives them) and
    the set-level ones' bootstrap ``replicates``."""
    values = {name: float(scores[name]["mean"]) for name in CHECK_METRICS if name in scores}
    rows = [r for r in getattr(scores, "per_sentence", None) or () if "subject" in r and "sentence" in r]
    sentences = [[str(r["subject"]), str(r["sentence"])] for r in rows]
    per_sentence, replicates = {}, {}
    for name in values:
        column = [r.get(name) for r in rows]
        if rows and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in column):
            per_sentence[name] = [float(v) for v in column]
        reps = scores[name].get("replicates") if isinstance(scores[name], dict) else None
        if reps is not None and name not in per_sentence:
            reps = np.asarray(reps, dtype=float).ravel()
            if reps.size and np.all(np.isfinite(reps)):
                replicates[name] = reps.tolist()
    return {"values": values, "sentences": sentences if per_sentence else [], "per_sentence": per_sentence,
            "replicates": replicates}


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
    if train_contract(cls) < CONTRACT:  # a contract-v2 plug-in gets no request, hence no hook
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


def curve_record(points) -> dict:
    """``{"sentences", "curve"}`` of a run's checkpoints (:class:`HalfBudget`, any order):
    the curve's points by step, each ``{"step", "metrics"[, "per_sentence"][, "replicates"]}``;
    per-sentence values are kept where they follow the first point's sentences. Empty
    without points."""
    points = sorted(points or (), key=lambda p: p.step)
    if not points:
        return {}
    sentences = next((list(p.sentences) for p in points if p.per_sentence), [])
    curve = []
    for point in points:
        entry = {"step": int(point.step), "metrics": {k: float(v) for k, v in point.values.items()}}
        if point.per_sentence and [list(k) for k in point.sentences] == sentences:
            entry["per_sentence"] = {k: list(v) for k, v in point.per_sentence.items()}
        if point.replicates:
            entry["replicates"] = {k: list(v) for k, v in point.replicates.items()}
        curve.append(entry)
    return {"sentences": [list(k) for k in sentences], "curve": curve} if sentences else {"curve": curve}


def convergence_record(half: HalfBudget | None, metrics, points=None) -> dict | None:
    """The ``convergence`` section of one run from its half-budget values, its
    full-budget metric entries (``{"mean", "ci95", ...}``) and its learning curve
    (``points``: every checkpoint's :class:`HalfBudget`, :func:`curve_record`); None
    without a half-budget call or when neither metric of :data:`CHECK_METRICS` was scored
    both times.

    A metric is settled (moved within its interval) when ``|full - half| <= half_width``,
    ``half_width`` being half the width of the full-budget ``ci95``; the run is when each
    checked metric is. Whether a move changes what the table says is decided by the table
    (:mod:`leaderboard.settled`).
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
            "settled": all(m["settled"] for m in out.values()), **curve_record(points or [half])}


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
    record = convergence_record(check.result, metrics, getattr(check, "points", None))
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
    record = {"checked_at_step": records[0]["checked_at_step"], "total_steps": records[0]["total_steps"],
              "metrics": out, "settled": all(m["settled"] for m in out.values()) and all(r["settled"] for r in records)}
    curve = _mean_curve([r.get("curve") or () for r in records], names)
    return {**record, "curve": curve} if curve else record


def _mean_curve(curves, names) -> list:
    """The seeds' learning curves as one: per step that every seed has, the seed means of
    ``names`` (the per-sentence values and replicates stay in each seed's record)."""
    steps = [{int(p["step"]): p["metrics"] for p in curve} for curve in curves]
    if not steps or not all(steps):
        return []
    common = sorted(set.intersection(*(set(s) for s in steps)))
    out = []
    for step in common:
        metrics = {n: float(np.mean([s[step][n] for s in steps])) for n in names if all(n in s[step] for s in steps)}
        if metrics:
            out.append({"step": step, "metrics": metrics})
    return out
