"""Issue 54: the Ray executor never runs more declared memory on a node than the node
has. A local Ray instance of 4 CPUs and 3 GiB of ``memory`` runs six tasks of one CPU;
declaring 1 GiB each, at most three run at once (the CPUs would allow four)."""

import json
import time
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="Ray is not installed (pip install -e '.[cluster]')")
pytestmark = pytest.mark.slow  # a local Ray instance and six tasks of 3 s (about 30 s)

GIB = 2**30
NODE_GB = 3.0


@pytest.fixture(scope="module")
def small_node():
    ray.init(num_cpus=4, _memory=int(NODE_GB * GIB), include_dashboard=False, logging_level="ERROR",
             log_to_driver=False)
    yield
    ray.shutdown()


def _intervals(folder: Path) -> list:
    return [json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))]


def _most_at_once(intervals) -> int:
    """The most intervals ``[start, end)`` holding one instant."""
    events = sorted([(s, 1) for s, _, _ in intervals] + [(e, -1) for _, e, _ in intervals])
    running = most = 0
    for _, step in events:
        running += step
        most = max(most, running)
    return most


def _run(folder: Path, memory_gb: float) -> list:
    from leaderboard.executors import Resources, Task
    from leaderboard.executors.ray_executor import run_ray

    def held(spec):  # pickled by value into the workers
        start = time.time()
        time.sleep(3.0)
        Path(spec["folder"], f"{spec['i']}.json").write_text(json.dumps([start, time.time(), spec["memory_gb"]]))
        return spec["i"], None

    folder.mkdir()
    tasks = [Task(f"t{i}", "score", held, {"folder": str(folder), "i": i, "memory_gb": memory_gb},
                  resources=Resources(cpus=1, memory_gb=memory_gb)) for i in range(6)]
    assert run_ray(tasks, log=lambda m: None) == {f"t{i}": i for i in range(6)}
    return _intervals(folder)


def test_the_declared_memory_running_on_a_node_never_sums_beyond_the_node_s(tmp_path, small_node):
    intervals = _run(tmp_path / "big", 1.0)
    most = _most_at_once(intervals)
    assert most * 1.0 <= NODE_GB, most
    assert most >= 2  # the tasks did run side by side where their memory fits


def test_a_task_larger_than_the_node_is_named_with_the_node_s_size(small_node):
    from leaderboard.executors import Resources, Task
    from leaderboard.executors.ray_executor import _largest_node, _unplaceable

    tasks = [Task("train/cdface/seed0", "train", len, {}, resources=Resources(cpus=1, memory_gb=4.0)),
             Task("score/cdface/seed0", "score", len, {}, resources=Resources(cpus=1, memory_gb=3.0))]
    assert _unplaceable(tasks, ray.nodes()) == ["train/cdface/seed0 (1 CPU, 0 GPU, 4 GiB)"]
    assert _largest_node(ray.nodes()) == "4 CPU, 0 GPU, 3.0 GiB"
