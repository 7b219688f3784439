"""The executors' common part: tasks, their resources, running one task
(:func:`execute`), the sequential executor and the stage timing records (see
:mod:`leaderboard.executors`)."""

from __future__ import annotations

import json
import os
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from benchmark.results import read
from blendvoca.io.atomic import atomic_write
from blendvoca.io.json_file import read_json
from blendvoca.runtime.progress import progress_bars
from blendvoca.runtime.threads import limited_threads
from leaderboard.executors.memory import PeakRSS

__all__ = ["EXECUTORS", "Resources", "Task", "check_order", "execute", "log_progress", "record_timing",
           "result_timing_table", "run_sequential", "timing_records", "timing_table"]

#: The executors ``--executor`` accepts.
EXECUTORS = ("sequential", "ray")


@dataclass(frozen=True)
class Resources:
    """What one task needs of a machine (Ray schedules on it; the sequential executor
    uses ``cpus`` as the task's thread count).

    Attributes
    ----------
    cpus : int
        CPU cores (also the task's torch and BLAS threads).
    gpus : float
        GPUs (0: none; a fraction shares one).
    memory_gb : float or None
        Memory reserved on the node, GiB (None: no reservation).
    """

    cpus: int = 1
    gpus: float = 0.0
    memory_gb: float | None = None


@dataclass(frozen=True)
class Task:
    """One stage of one plan entry.

    Attributes
    ----------
    key : str
        Unique name, e.g. ``"train/regression/seed0"``; also its timing record's name.
    stage : str
        ``"data"``, ``"expert"``, ``"single"``, ``"train"``, ``"score"`` or ``"store"``.
    function : callable
        A module-level function ``function(spec, *dependency_values)`` returning
        ``(value, details)``: ``value`` goes to the tasks that depend on this one,
        ``details`` (a dict, or None when the stage found its outputs done and did
        nothing) to the timing record.
    spec : dict
        Plain, picklable arguments of the stage.
    deps : tuple of str
        Keys of the tasks whose values ``function`` takes, in this order.
    resources : Resources
    outputs : tuple of str
        What the stage writes (documentation and logs; each stage checks its own).
    row, seed : optional
        The plan row and training seed the stage belongs to (timing tables).
    """

    key: str
    stage: str
    function: object
    spec: dict
    deps: tuple = ()
    resources: Resources = field(default_factory=Resources)
    outputs: tuple = ()
    row: str | None = None
    seed: int | None = None


def record_timing(work, task: Task, details: dict, wall_s: float, peak_rss_gb: float | None = None) -> Path:
    """Write ``<work>/stages/timings/<key>.json``: the stage's wall time, its peak RSS
    (GiB, its process and children: :class:`leaderboard.executors.memory.PeakRSS`), the
    build it ran on (the spec's ``build``) and where it ran (replaced atomically; a
    stage that did nothing writes none)."""
    path = Path(work) / "stages" / "timings" / (task.key.replace("/", "__") + ".json")
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"key": task.key, "stage": task.stage, "row": task.row, "seed": task.seed,
              "wall_s": round(float(wall_s), 3),
              "peak_rss_gb": None if peak_rss_gb is None else round(float(peak_rss_gb), 3),
              "build": task.spec.get("build"), "host": socket.gethostname(), "pid": os.getpid(),
              "finished": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "resources": {"cpus": task.resources.cpus, "gpus": task.resources.gpus,
                            "memory_gb": task.resources.memory_gb},
              **{k: (round(float(v), 3) if isinstance(v, float) else v) for k, v in details.items()}}
    with atomic_write(path, "w") as handle:
        json.dump(record, handle, indent=1)
    return path


def execute(task: Task, *values):
    """Run ``task`` with its dependencies' ``values`` (both executors call this), its
    threads limited to its CPUs and progress bars as its spec's ``progress`` says (the
    switch of the process that planned it: a Ray worker does not inherit it); its wall
    time and peak memory go to its timing record (:func:`record_timing`).

    Returns
    -------
    object
        The stage's value, for the tasks that depend on it.
    """
    # torch's and the BLAS libraries' threads limited to the task's CPUs: a stage's floats then do
    # not depend on where it runs (a Ray worker starts with one thread per reserved CPU; this
    # process with as many as the machine has); torch first, so that the limiter sets its count too
    import torch  # noqa: F401

    start = time.perf_counter()
    # the task's peak memory, its child processes' included: the plan's declarations come from it
    with PeakRSS() as peak, limited_threads(max(1, int(task.resources.cpus))), \
            progress_bars(task.spec.get("progress", True)):
        value, details = task.function(task.spec, *values)
    if details is not None and task.spec.get("work"):
        record_timing(task.spec["work"], task, details, time.perf_counter() - start, peak_rss_gb=peak.gb)
    return value


def log_progress(message: str) -> None:
    """A progress line of ``leaderboard.reproduce`` on stderr."""
    print(f"[reproduce] {message}", file=sys.stderr, flush=True)


def run_sequential(tasks, *, log=log_progress) -> dict:
    """Run ``tasks`` (in dependency order) one after the other in this process.

    Returns
    -------
    dict
        ``{key: value}`` of every task. The first task that raises stops the run (its
        error is raised; what earlier tasks wrote stays and is reused by the next run).
    """
    values = {}
    for task in tasks:
        log(f"{task.key}")
        values[task.key] = execute(task, *(values[d] for d in task.deps))
    return values


def check_order(tasks) -> None:
    """ValueError unless every task's dependencies come before it and keys are unique."""
    seen = set()
    for task in tasks:
        missing = [d for d in task.deps if d not in seen]
        if missing:
            raise ValueError(f"task {task.key!r} depends on {missing}, which do not come before it")
        if task.key in seen:
            raise ValueError(f"task {task.key!r} is planned twice")
        seen.add(task.key)


def timing_records(work) -> list:
    """The stage timing records under ``<work>/stages/timings`` (:func:`record_timing`)."""
    folder = Path(work) / "stages" / "timings"
    if not folder.is_dir():
        return []
    return [read_json(p, what="a stage timing record (JSON)") for p in sorted(folder.glob("*.json"))]


def _new_timing_entry() -> dict:
    return {"train": 0.0, "check": 0.0, "generate": 0.0, "score": 0.0, "other": 0.0, "seeds": set()}


def _minutes_table(rows: dict) -> str:
    lines = ["| row | seeds | train (min) | half-budget check (min) | generate (min) | score (min) | other (min) "
             "| total (min) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for name, e in rows.items():
        total = e["train"] + e["check"] + e["generate"] + e["score"] + e["other"]
        seeds = ",".join(str(s) for s in sorted(e["seeds"])) or "-"
        lines.append(f"| {name} | {seeds} | {e['train'] / 60:.1f} | {e['check'] / 60:.1f} | "
                     f"{e['generate'] / 60:.1f} | {e['score'] / 60:.1f} | {e['other'] / 60:.1f} | {total / 60:.1f} |")
    return "\n".join(lines)


def timing_table(work) -> str:
    """A Markdown table of the wall time per row and stage (minutes), summed over seeds,
    from the work folder's timing records: train, the half-budget check (generating and
    scoring at half budget, during the training task), generate, score (the ``score``
    task's generation and evaluation seconds apart) and the single-run rows' whole run."""
    rows = {}
    shared = {}
    for r in timing_records(work):
        name = r.get("row") or r["stage"]
        entry = rows.setdefault(name, _new_timing_entry())
        if r.get("seed") is not None:
            entry["seeds"].add(r["seed"])
        if r["stage"] == "train":
            check = min(r.get("convergence_s") or 0.0, r["wall_s"])
            entry["check"] += check
            entry["train"] += r["wall_s"] - check
            shared.setdefault(name, r.get("training"))
        elif r["stage"] == "score":
            entry["generate"] += r.get("generate_s") or 0.0
            entry["score"] += r.get("evaluate_s") or 0.0
            entry["other"] += max(0.0, r["wall_s"] - (r.get("generate_s") or 0.0) - (r.get("evaluate_s") or 0.0))
        elif r["stage"] == "single":
            entry["generate"] += r.get("generate_s") or 0.0
            entry["score"] += r.get("evaluate_s") or 0.0
            entry["train"] += r.get("train_s") or 0.0
            entry["other"] += max(0.0, r["wall_s"] - sum(r.get(k) or 0.0 for k in ("generate_s", "evaluate_s",
                                                                                   "train_s")))
        else:
            entry["other"] += r["wall_s"]
    return _minutes_table(rows)


def result_timing_table(results) -> str:
    """The table of :func:`timing_table` from the result files directly in ``results``
    (each file's ``timings``, the whole row over its seeds): the record that stays with
    committed results when their work folder is gone. ``other`` is what the run spent
    outside training, the check, generation and scoring (loading, writing)."""
    rows = {}
    for path in sorted(Path(results).glob("*.json")):
        result = read(path)
        t = result.timings
        entry = rows.setdefault(result.label, _new_timing_entry())
        entry["seeds"].update(result.seeds or ())
        stages = {"train": "train_s", "check": "convergence_s", "generate": "generate_s", "score": "evaluate_s"}
        for stage, key in stages.items():
            entry[stage] += t.get(key) or 0.0
        entry["other"] += max((t.get("total_s") or 0.0) - sum(t.get(key) or 0.0 for key in stages.values()), 0.0)
    return _minutes_table(rows)
