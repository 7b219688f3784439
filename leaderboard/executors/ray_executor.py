"""The plan's tasks as Ray tasks (``leaderboard.reproduce --executor ray``).

Each :class:`~leaderboard.executors.Task` becomes one Ray task that reserves the task's
:class:`~leaderboard.executors.Resources` (``num_cpus``, ``num_gpus``, ``memory``) and
takes its dependencies' values as object references, so Ray starts it once they are
done and runs independent rows and seeds side by side on whatever nodes have room.
Ray places a task only where its declared ``memory`` fits beside that of the node's
running tasks, so the memory declared on a node never sums beyond the node's ``memory``
resource; the plan's declarations come from measured peaks
(:mod:`leaderboard.executors.memory`).

A worker process that dies (killed, out of memory, its node lost) fails its task with
a system error, which Ray retries up to ``max_retries`` times; the stage then starts
again from what it had written atomically (nothing, for a stage cut short). An error
the stage raises itself (a user or method error) is not retried: it is reported, and
the tasks that depend on it do not run.

Every node must see the work folder, the results folder and the build at the same
paths (a shared file system) and have the project installed in the same environment;
the ``BLENDVOCA_*`` variables of this process are passed to the workers.

Progress: the workers draw no bars (Ray forwards their output to this terminal, where
several bars interleave); this process shows one bar of the tasks done and a line per
finished task, and the stages' own ``[reproduce]`` lines come through as they are.
"""

from __future__ import annotations

import dataclasses
import os

from tqdm import tqdm

from blendvoca.errors import UserError
from blendvoca.runtime.progress import bar
from leaderboard.executors.core import execute

__all__ = ["run_ray"]


def _env_vars() -> dict:
    """The project's settings (asset and cache folders, ...) for the workers."""
    return {k: v for k, v in os.environ.items() if k.startswith("BLENDVOCA_")}


def _options(task, max_retries: int) -> dict:
    resources = task.resources
    options = {"num_cpus": resources.cpus, "num_gpus": resources.gpus, "max_retries": int(max_retries),
               "retry_exceptions": False, "name": task.key}
    if resources.memory_gb:
        options["memory"] = int(resources.memory_gb * 2**30)
    return options


def _unplaceable(tasks, nodes) -> list:
    """The tasks that no live node of ``nodes`` (``ray.nodes()``) has the CPUs, GPUs or
    memory for: Ray would wait for such a node forever."""
    sizes = [n.get("Resources", {}) for n in nodes if n.get("Alive")]
    out = []
    for task in tasks:
        r = task.resources
        need = {"CPU": r.cpus, "GPU": r.gpus, "memory": (r.memory_gb or 0) * 2**30}
        if not any(all(size.get(k, 0) >= v for k, v in need.items() if v) for size in sizes):
            out.append(f"{task.key} ({r.cpus} CPU, {r.gpus:g} GPU, {r.memory_gb or 0:g} GiB)")
    return out


def _largest_node(nodes) -> str:
    """The CPUs and memory of the live node with the most memory (``ray.nodes()``), in words."""
    sizes = [n.get("Resources", {}) for n in nodes if n.get("Alive")] or [{}]
    size = max(sizes, key=lambda s: (s.get("memory", 0), s.get("CPU", 0)))
    return f"{size.get('CPU', 0):g} CPU, {size.get('GPU', 0):g} GPU, {size.get('memory', 0) / 2**30:.1f} GiB"


def _cause(error):
    """The stage's own exception inside a Ray task error (itself when there is none)."""
    cause = getattr(error, "cause", None)
    return cause if isinstance(cause, BaseException) else error


def run_ray(tasks, *, address: str | None = None, max_retries: int = 3, log=print) -> dict:
    """Run ``tasks`` (in dependency order) as Ray tasks.

    Parameters
    ----------
    tasks : sequence of Task
    address : str, optional
        An existing cluster (``"auto"``, ``"HOST:6379"`` or ``"ray://HOST:10001"``);
        None starts a local Ray instance for the run (and stops it after). When Ray is
        already initialised in this process, that instance is used.
    max_retries : int
        Reruns of a task whose worker died.
    log : callable

    Returns
    -------
    dict
        ``{key: value}`` of every task.

    Raises
    ------
    BaseException
        The first failed task's own error (in plan order), once every task that could
        run has finished; the others are logged.
    """
    try:
        import ray
    except ImportError:
        raise UserError("--executor ray: Ray is not installed; install the cluster extra: "
                        "pip install -e '.[cluster]'") from None
    started_here = False
    if not ray.is_initialized():
        ray.init(address=address, runtime_env={"env_vars": _env_vars()}, log_to_driver=True,
                 **({"include_dashboard": False} if address is None else {}))
        started_here = True
    try:
        unplaceable = _unplaceable(tasks, ray.nodes())
        if unplaceable:
            message = (f"no node of the Ray cluster has the resources of {len(unplaceable)} task(s), e.g. "
                       f"{unplaceable[0]}; the largest node has {_largest_node(ray.nodes())}")
            if address is None and started_here:
                raise UserError(f"--executor ray: {message}; lower --cpus-per-task or use a cluster (--address)")
            log(f"warning: {message}; they wait for a node that has them (an autoscaler's)")
        remote = ray.remote(execute)
        refs, keys = {}, {}
        for task in tasks:
            # the workers draw no bars: forwarded to this terminal, every worker's bar updates interleave
            # (a run of two cheap rows printed 713 fragments); this process shows one bar of the tasks
            quiet = dataclasses.replace(task, spec={**task.spec, "progress": False})
            ref = remote.options(**_options(task, max_retries)).remote(quiet, *(refs[d] for d in task.deps))
            refs[task.key], keys[ref] = ref, task.key
        log(f"{len(tasks)} task(s) submitted to Ray ({ray.cluster_resources().get('CPU', 0):g} CPUs, "
            f"{ray.cluster_resources().get('GPU', 0):g} GPUs)")
        values, errors, pending = {}, {}, list(refs.values())
        with bar(total=len(tasks), desc="tasks", unit="task", mininterval=5.0) as tasks_done:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                key = keys[done[0]]
                try:
                    values[key] = ray.get(done[0])
                    with tqdm.external_write_mode():  # the line above the bar, not through it
                        log(f"{key}: done ({len(values) + len(errors)}/{len(tasks)})")
                except ray.exceptions.RayError as error:
                    errors[key] = error
                tasks_done.update(1)
        if errors:
            # the first failure in plan order; the tasks that depended on it report the same error
            first = next(t.key for t in tasks if t.key in errors)
            for task in tasks:
                if task.key in errors and task.key != first:
                    log(f"{task.key}: failed ({type(_cause(errors[task.key])).__name__})")
            raise _cause(errors[first])
        return values
    finally:
        if started_here:
            ray.shutdown()
