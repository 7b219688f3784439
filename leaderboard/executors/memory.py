"""The plan's memory: each task's measured peak, the memory it declares, the node's.

Ray schedules a task where the memory it declares (``Resources.memory_gb``, Ray's
``memory`` resource) still fits beside what the node's running tasks declared, so a
node is never given more declared memory than it has; what keeps the tasks' *actual*
memory within the node is declarations that are at least what the tasks use. Every
task therefore measures what it used (:class:`PeakRSS`, recorded with its wall time,
``peak_rss_gb``); ``python -m leaderboard.reproduce --work W --write-memory`` gathers
a run's peaks into the committed table :data:`MEASURED_MEMORY`, per build, row and
stage (the highest over the seeds); and the plan declares, for a row and stage the
table has, :func:`declared_memory_gb` of its peak (a margin above it), else the
plan's default.

The peak is that of the task's process *and* its child processes (a build's worker
pool, a plug-in's subprocess): the process's RSS plus what each descendant holds alone
(its USS: pages a forked worker shares with its parent are counted once), sampled by a
thread every :data:`SAMPLE_S` seconds (up to :data:`MAX_PAUSE_S` while reading the
children's USS, which walks their page tables, takes more than a tenth of that), and
two lower bounds that the sampling cannot miss:
the process's own high-water mark (``VmHWM``, reset at the task's start through
``/proc/self/clear_refs`` on Linux) and the largest waited-for child's peak
(``getrusage(RUSAGE_CHILDREN)``, when it rose during the task; Linux counts in a
child's peak what its parent held when it forked, so it is not added to the parent's).
A child that lives shorter than :data:`SAMPLE_S` is seen alone, not beside its parent.
It is the process's whole resident memory, not what the task added to it: what Ray's
memory monitor and the kernel's OOM killer count. So it depends a little on where the
task ran: the sequential executor's process carries what earlier tasks left (imported
libraries, caches), a Ray worker imports Ray and is reused for later tasks (one at a
time); the same task measured on both differed by up to about 20 %, which the margin
covers (docs/results/reproduce-memory-measurements.md), but not after a large stage: a
FaceFormer row's store stage read 9.6 GiB in the sequential process that had just scored
it, where SAiD's reads 0.9 on Ray (docs/results/leaderboard-measurements.md). The
committed table is measured on Ray.

Units are GiB (2**30 bytes) throughout, as ``Resources.memory_gb``.
"""

from __future__ import annotations

import json
import math
import os
import threading
from pathlib import Path

from blendvoca.errors import DataError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.json_file import read_json

__all__ = ["CONSTANT_GB", "MARGIN", "MAX_PAUSE_S", "MEASURED_MEMORY", "SAMPLE_S", "PeakRSS", "declared_memory_gb",
           "machine_memory_gb", "measured_memory", "measured_peak_gb", "memory_table", "oversized",
           "peak_table", "write_measured_memory"]

GIB = 2**30
#: Seconds between two samples of the process tree's RSS.
SAMPLE_S = 0.05
#: The longest pause between two samples, however long reading the children's USS takes.
MAX_PAUSE_S = 0.25
#: Declared memory = MARGIN x measured peak + CONSTANT_GB (GiB), rounded up to ROUND_GB.
#: The factor covers what changes a peak between runs of the same task: another seed
#: (another batch order and sample draws), another executor (a fresh Ray worker, or the
#: sequential process with earlier tasks' state), another machine's libraries and
#: allocator; the constant covers what the sampling can miss (an allocation living
#: shorter than SAMPLE_S in a child process) and, for a small task, the import of the
#: worker's libraries, which weigh the same in every task.
MARGIN = 1.25
CONSTANT_GB = 0.5
ROUND_GB = 0.25
#: The plan's stages, in the order a row runs them.
STAGES = ("data", "expert", "single", "train", "score", "store")
#: The committed table of measured peaks (:func:`write_measured_memory`).
MEASURED_MEMORY = Path(__file__).resolve().parents[1] / "measured-memory.json"


def _rss_of_tree(process) -> tuple:
    """``(bytes, seconds)``: the memory ``process`` (a ``psutil.Process``) and its
    descendants hold now, and what reading the descendants' USS took. The process counts
    its RSS, each descendant only what it holds alone (its USS): a forked worker's pages
    shared with its parent (copy on write) and the libraries both map are in the
    parent's RSS already, and counting them again made a pool of forked workers look like
    copies of its parent (the synthetic board's mean row: 28.4 GiB "measured" on a
    23.5 GiB machine, 2.5 GiB counted so). A process that ends while being read counts
    nothing."""
    import time

    import psutil

    try:
        children = process.children(recursive=True)
        total = process.memory_info().rss
    except psutil.Error:
        return 0, 0.0
    started = time.perf_counter()
    for child in children:
        try:
            total += child.memory_full_info().uss
        except psutil.AccessDenied:  # USS unreadable (another user's process): its RSS, an upper bound
            try:
                total += child.memory_info().rss
            except psutil.Error:
                pass
        except psutil.Error:
            pass
    return total, time.perf_counter() - started


def _reset_high_water_mark() -> bool:
    """Reset this process's peak RSS (``VmHWM``) to its current RSS (Linux >= 4.0);
    False where the system offers no such reset."""
    try:
        with open("/proc/self/clear_refs", "w") as handle:
            handle.write("5")
        return True
    except OSError:
        return False


def _high_water_mark() -> int | None:
    """This process's peak RSS since its last reset, bytes (``VmHWM``; None off Linux)."""
    try:
        with open("/proc/self/status") as handle:
            for line in handle:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def _children_max_rss() -> int:
    """The largest peak RSS of this process's waited-for descendants so far, bytes."""
    import resource
    import sys

    value = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return value if sys.platform == "darwin" else value * 1024  # bytes on macOS, KiB elsewhere


class PeakRSS:
    """The peak resident memory of this process and its children within a block.

    ``with PeakRSS() as peak: ...`` then ``peak.gb``: the highest of the sampled sums
    over the process tree, the process's own high-water mark over the block (when it
    could be reset at its start) and the largest child's peak when a child waited for
    in the block set a new one (module docstring). ``peak.start_gb`` is the process's
    RSS when the block began.
    """

    def __init__(self, sample_s: float = SAMPLE_S):
        self.sample_s = float(sample_s)
        self.peak_bytes = 0
        self.start_bytes = 0
        self._stop = threading.Event()
        self._thread = None

    def _sample(self, process) -> None:
        while not self._stop.is_set():
            used, took = _rss_of_tree(process)
            self.peak_bytes = max(self.peak_bytes, used)
            # a child's USS walks its page tables (tens of ms for a large forked worker): the
            # pause keeps the sampling under about a tenth of a core
            self._stop.wait(min(max(self.sample_s, 10 * took), MAX_PAUSE_S))

    def __enter__(self) -> PeakRSS:
        import psutil

        process = psutil.Process(os.getpid())
        self._children_before = _children_max_rss()
        self._exact = _reset_high_water_mark()
        self.start_bytes = process.memory_info().rss
        self.peak_bytes = _rss_of_tree(process)[0]
        self._thread = threading.Thread(target=self._sample, args=(process,), name="peak-rss", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> bool:
        self._stop.set()
        self._thread.join()
        import psutil

        process = psutil.Process(os.getpid())
        self.peak_bytes = max(self.peak_bytes, _rss_of_tree(process)[0])
        if self._exact:
            self.peak_bytes = max(self.peak_bytes, _high_water_mark() or 0)
        children = _children_max_rss()
        if children > self._children_before:  # a child waited for in the block set a new peak
            self.peak_bytes = max(self.peak_bytes, children)
        return False

    @property
    def gb(self) -> float:
        """The peak, GiB."""
        return self.peak_bytes / GIB

    @property
    def start_gb(self) -> float:
        """The process's RSS when the block began, GiB."""
        return self.start_bytes / GIB


def machine_memory_gb() -> float:
    """This machine's memory, GiB: its physical memory, or the memory limit of the
    control group this process runs in (a container's) when that is lower."""
    import psutil

    total = psutil.virtual_memory().total
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(path).read_text().strip()
        except OSError:
            continue
        if text.isdigit():
            total = min(total, int(text))
    return total / GIB


def declared_memory_gb(peak_gb: float) -> float:
    """The memory a task declares for a measured peak (GiB): ``MARGIN * peak +
    CONSTANT_GB`` rounded up to a multiple of ``ROUND_GB``; always above the peak."""
    peak_gb = float(peak_gb)
    if not math.isfinite(peak_gb) or peak_gb < 0:
        raise ValueError(f"declared_memory_gb: expected a peak >= 0 GiB, got {peak_gb}")
    return math.ceil((MARGIN * peak_gb + CONSTANT_GB) / ROUND_GB - 1e-9) * ROUND_GB


def _table_name(record: dict) -> str:
    """The row a timing record counts under (the corpus and expert stages: the stage)."""
    return record.get("row") or record["stage"]


def peak_table(records) -> dict:
    """``{build: {row: {stage: {"peak_rss_gb", "seeds", "measured"}}}}`` from stage timing
    records (:func:`leaderboard.executors.record_timing`): per row and stage the highest
    peak over its seeds; records without a peak (older runs) count nothing."""
    table = {}
    for record in records:
        peak = record.get("peak_rss_gb")
        if peak is None:
            continue
        build = record.get("build") or "unknown"
        entry = table.setdefault(build, {}).setdefault(_table_name(record), {}).setdefault(
            record["stage"], {"peak_rss_gb": 0.0, "seeds": [], "measured": ""})
        entry["peak_rss_gb"] = round(max(entry["peak_rss_gb"], float(peak)), 3)
        if record.get("seed") is not None and record["seed"] not in entry["seeds"]:
            entry["seeds"] = sorted([*entry["seeds"], record["seed"]])
        entry["measured"] = max(entry["measured"], str(record.get("finished") or "")[:10])
    return table


def measured_memory(path=None) -> dict:
    """The committed table of measured peaks (``{build: {row: {stage: {...}}}}``); an
    empty one when the file is missing."""
    path = Path(MEASURED_MEMORY if path is None else path)
    if not path.is_file():
        return {}
    record = read_json(path, what="a table of measured memory peaks (JSON object)")
    builds = record.get("builds") if isinstance(record, dict) else None
    if not isinstance(builds, dict):
        raise DataError(f"{path}: expected a JSON object with 'builds' (build -> row -> stage -> peak), "
                        f"got {type(record).__name__}")
    return builds


def measured_peak_gb(table: dict, build: str, row: str | None, stage: str) -> float | None:
    """The measured peak of ``row``'s ``stage`` on ``build`` in ``table``
    (:func:`measured_memory`), GiB; None when not measured."""
    entry = table.get(build, {}).get(row or stage, {}).get(stage)
    return None if entry is None else float(entry["peak_rss_gb"])


def write_measured_memory(records, path=None) -> Path:
    """Merge the peaks of timing ``records`` into the table at ``path`` (default
    :data:`MEASURED_MEMORY`): a row and stage measured now replaces its entry, the
    others stay (a run of some rows updates those rows). Written atomically."""
    path = Path(MEASURED_MEMORY if path is None else path)
    builds = measured_memory(path)
    for build, rows in peak_table(records).items():
        for row, stages in rows.items():
            builds.setdefault(build, {}).setdefault(row, {}).update(stages)
    record = {"about": "Peak RSS (GiB) of each task of leaderboard.reproduce's plan, its process and children, "
                       "the highest over the seeds, per build, row and stage; written by python -m "
                       "leaderboard.reproduce --work W --write-memory. The plan declares "
                       f"ceil(({MARGIN} x peak + {CONSTANT_GB}) / {ROUND_GB}) x {ROUND_GB} GiB for a measured task.",
              "builds": {b: {r: dict(sorted(s.items())) for r, s in sorted(rows.items())}
                         for b, rows in sorted(builds.items())}}
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "w") as handle:
        handle.write(_table_text(record))
    return path


def _table_text(record: dict) -> str:
    """The table as JSON with one line per row and stage (diffs show what was remeasured)."""
    lines = ["{", f' "about": {json.dumps(record["about"])},', ' "builds": {']
    for b, (build, rows) in enumerate(record["builds"].items()):
        lines.append(f"  {json.dumps(build)}: {{")
        for r, (row, stages) in enumerate(rows.items()):
            lines.append(f"   {json.dumps(row)}: {{")
            lines += [f"    {json.dumps(stage)}: {json.dumps(entry)}" + ("," if s < len(stages) - 1 else "")
                      for s, (stage, entry) in enumerate(stages.items())]
            lines.append("   }" + ("," if r < len(rows) - 1 else ""))
        lines.append("  }" + ("," if b < len(record["builds"]) - 1 else ""))
    return "\n".join([*lines, " }", "}", ""])


def memory_table(records) -> str:
    """A Markdown table of the peak RSS per row and stage (the highest over the seeds,
    GiB) of stage timing records, with the memory each task declared."""
    rows = {}
    for record in records:
        if record.get("peak_rss_gb") is None:
            continue
        key = (_table_name(record), record["stage"])
        peak, declared = rows.get(key, (0.0, 0.0))
        memory = (record.get("resources") or {}).get("memory_gb") or 0.0
        rows[key] = (max(peak, float(record["peak_rss_gb"])), max(declared, float(memory)))
    order = {stage: i for i, stage in enumerate(STAGES)}
    lines = ["| row | stage | peak RSS (GiB) | declared (GiB) |", "|---|---|---:|---:|"]
    lines += [f"| {row} | {stage} | {peak:.2f} | {declared:.2f} |" for (row, stage), (peak, declared)
              in sorted(rows.items(), key=lambda item: (item[0][0], order.get(item[0][1], len(order))))]
    return "\n".join(lines)


def oversized(tasks, node_gb: float) -> list:
    """The tasks that declare more memory than ``node_gb`` GiB (none could ever run)."""
    return [t for t in tasks if (t.resources.memory_gb or 0.0) > node_gb]
