"""Executors of the leaderboard's plan: the same stage tasks run in this process or on Ray.

:mod:`leaderboard.reproduce` turns its plan into :class:`Task` objects (the corpus and
its build, the lip-sync expert, per row and seed: training, generation and scoring,
then the row's result file; :mod:`leaderboard.executors.stages`). An executor runs
them in dependency order:

* ``sequential`` (:func:`run_sequential`, the default): one after the other in this
  process; it imports no Ray.
* ``ray`` (:mod:`leaderboard.executors.ray_executor`): each task a Ray task with the
  resources it declares, on a local Ray instance or an existing cluster; a task whose
  worker dies is run again (Ray's ``max_retries``).

Both executors call the same stage functions through :func:`execute`, which limits the
task's math libraries to its declared CPUs (so the same task computes the same floats
on either executor) and records the stage's wall time
(:func:`record_timing`). Each stage writes its outputs atomically and returns early
when they are already there, so a task run twice, or a plan run again, redoes only
what is missing.
"""

from __future__ import annotations

from leaderboard.executors.core import (
    EXECUTORS,
    Resources,
    Task,
    check_order,
    execute,
    log_progress,
    record_timing,
    result_timing_table,
    run_sequential,
    timing_records,
    timing_table,
)

__all__ = ["EXECUTORS", "Resources", "Task", "check_order", "execute", "log_progress", "record_timing",
           "result_timing_table", "run_sequential", "run_tasks", "timing_records", "timing_table"]


def run_tasks(tasks, *, executor: str = "sequential", address: str | None = None, max_retries: int = 3,
              log=log_progress) -> dict:
    """Run ``tasks`` on ``executor`` (:data:`EXECUTORS`); see :func:`run_sequential` and
    :func:`leaderboard.executors.ray_executor.run_ray`."""
    tasks = list(tasks)
    check_order(tasks)
    if executor == "sequential":
        return run_sequential(tasks, log=log)
    if executor == "ray":
        from leaderboard.executors.ray_executor import run_ray

        return run_ray(tasks, address=address, max_retries=max_retries, log=log)
    raise ValueError(f"unknown executor {executor!r}; expected one of {EXECUTORS}")
