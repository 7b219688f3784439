"""Issue 54, measured memory in the plan: each task's peak RSS (its process and
children) is recorded with its timing, the plan declares memory from the measured
peaks with a margin, and a task needing more than the machine is refused."""

import json
import subprocess
import sys
import time

import pytest

pytest.importorskip("psutil", reason="psutil measures the tasks' memory (pip install -e '.[benchmark]')")

MIB = 2**20
GIB = 2**30

#: A child that allocates and touches ``N`` MiB, says so, and holds it until its input closes.
HOLDER = ("import sys\n"
          "block = b'x' * (int(sys.argv[1]) * 2**20)\n"  # a bytes literal's pages are written: resident
          "print('ready', flush=True)\n"
          "sys.stdin.read()\n")


def _hold(mib: int) -> subprocess.Popen:
    child = subprocess.Popen([sys.executable, "-c", HOLDER, str(mib)], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "ready"
    return child


def _release(child: subprocess.Popen) -> None:
    time.sleep(0.5)  # held over several of PeakRSS's samples, as a task's worker process is
    child.stdin.close()
    child.wait()


def _child_baseline() -> int:
    """A bare child interpreter's RSS, bytes (what the holder adds beside its block)."""
    import psutil

    child = _hold(0)
    rss = psutil.Process(child.pid).memory_info().rss
    _release(child)
    return rss


# The three measurements below run in a fresh interpreter: the test session's own process
# carries other tests' threads, children and allocator state, which PeakRSS (rightly) counts.

def _child_allocation() -> tuple:
    from leaderboard.executors.memory import PeakRSS

    interpreter = _child_baseline()
    with PeakRSS() as peak:
        child = _hold(300)
        _release(child)
    return peak.peak_bytes - peak.start_bytes, interpreter


def _tree_allocation() -> tuple:
    from leaderboard.executors.memory import PeakRSS

    interpreter = _child_baseline()
    with PeakRSS() as peak:
        child = _hold(300)
        mine = b"y" * (200 * MIB)
        _release(child)
        del mine
    return peak.peak_bytes - peak.start_bytes, interpreter


def _forked_copy() -> tuple:
    """The parent holds 300 MiB and forks a child that holds the same pages (copy on
    write, untouched) while the block is measured."""
    import os

    from leaderboard.executors.memory import PeakRSS

    block = b"w" * (300 * MIB)
    with PeakRSS() as peak:
        pid = os.fork()
        if pid == 0:  # the child: keeps the parent's pages shared, over several samples
            time.sleep(0.6)
            os._exit(0)
        os.waitpid(pid, 0)
    del block
    return peak.peak_bytes - peak.start_bytes, 0


def _own_allocation() -> tuple:
    from leaderboard.executors.memory import PeakRSS

    with PeakRSS(sample_s=10.0) as peak:  # no sample in the block: the high-water mark alone sees it
        block = b"z" * (200 * MIB)
        del block
    return peak.peak_bytes - peak.start_bytes, 0


def _measured_in_a_fresh_process(scenario: str) -> tuple:
    """``(bytes added to the peak, a bare child interpreter's RSS)`` of ``scenario`` (a function
    of this module), run in a new interpreter."""
    import os
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = f"import tests.leaderboard.test_reproduce_memory as t; print(*t.{scenario}())"
    done = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(root)})
    assert done.returncode == 0, done.stderr[-2000:]
    added, interpreter = (int(v) for v in done.stdout.split())
    return added, interpreter


def test_a_child_process_s_allocation_is_measured_in_the_task_s_peak():
    added, interpreter = _measured_in_a_fresh_process("_child_allocation")
    # the child's 300 MiB block and its interpreter, within 10 % of the block
    assert abs(added - (300 * MIB + interpreter)) < 30 * MIB, (added / MIB, interpreter / MIB)


def test_the_peak_sums_the_tree_not_only_the_largest_process():
    """Parent and child hold memory at once: neither's own peak (the parent's high-water
    mark, the largest waited child's) gives their sum; the sampled tree does."""
    added, interpreter = _measured_in_a_fresh_process("_tree_allocation")
    assert abs(added - (500 * MIB + interpreter)) < 50 * MIB, (added / MIB, interpreter / MIB)


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="needs os.fork")
def test_pages_a_forked_worker_shares_with_its_parent_are_counted_once():
    """A pool of forked workers is not a set of copies of its parent: a child sharing the
    parent's 300 MiB adds only what it holds alone (the RSS sum counted 600 MiB)."""
    added, _ = _measured_in_a_fresh_process("_forked_copy")
    assert added < 60 * MIB, added / MIB


def test_an_allocation_in_the_task_s_own_process_is_measured():
    added, _ = _measured_in_a_fresh_process("_own_allocation")
    if sys.platform.startswith("linux"):
        assert abs(added - 200 * MIB) < 20 * MIB, added / MIB


def _allocating_stage(spec):
    block = b"w" * (spec["mib"] * MIB)
    return len(block), {}


def test_each_task_s_peak_is_recorded_with_its_timing(tmp_path):
    from leaderboard.executors import Resources, Task, run_sequential

    task = Task("train/row/seed0", "train", _allocating_stage, {"mib": 150, "work": str(tmp_path), "build": "b"},
                resources=Resources(cpus=1, memory_gb=1.0), row="row", seed=0)
    run_sequential([task], log=lambda m: None)
    record = json.loads((tmp_path / "stages" / "timings" / "train__row__seed0.json").read_text())
    assert record["peak_rss_gb"] * GIB >= 150 * MIB and record["build"] == "b"
    assert record["resources"]["memory_gb"] == 1.0 and record["wall_s"] >= 0


def test_declared_memory_is_the_peak_with_its_margin_and_always_above_it():
    from leaderboard.executors.memory import CONSTANT_GB, MARGIN, ROUND_GB, declared_memory_gb

    assert declared_memory_gb(0.0) == 0.5
    assert declared_memory_gb(11.0) == 14.25  # 11 x 1.25 + 0.5 = 14.25
    assert declared_memory_gb(1.0) == 1.75
    assert declared_memory_gb(1.01) == 2.0  # 1.7625 rounded up to a quarter
    for peak in (0.013, 0.4, 0.77, 2.3, 5.9, 7.0, 10.99):
        declared = declared_memory_gb(peak)
        assert declared >= MARGIN * peak + CONSTANT_GB > peak
        assert declared - (MARGIN * peak + CONSTANT_GB) < ROUND_GB
    with pytest.raises(ValueError):
        declared_memory_gb(-1.0)


def _records(build="blendvoca-default"):
    def record(key, stage, row, seed, peak, memory=2.0):
        return {"key": key, "stage": stage, "row": row, "seed": seed, "wall_s": 1.0, "peak_rss_gb": peak,
                "build": build, "finished": "2026-12-06T20:00:00Z", "resources": {"memory_gb": memory}}

    return [record("data", "data", None, None, 0.9, 4.0), record("expert", "expert", None, None, 0.7),
            record("row/mean", "single", "mean", None, 1.1),
            *(record(f"train/regression/seed{s}", "train", "regression", s, p) for s, p in ((0, 1.3), (1, 1.6))),
            *(record(f"score/regression/seed{s}", "score", "regression", s, p) for s, p in ((0, 2.2), (1, 2.1))),
            record("store/regression", "store", "regression", None, 0.8)]


def test_the_plan_declares_memory_from_the_measured_peaks_else_the_default(tmp_path):
    from leaderboard.executors.memory import declared_memory_gb, peak_table
    from leaderboard.reproduce import BUILD_NAME, plan_tasks

    table = peak_table(_records("blendvoca-default"))
    assert table["blendvoca-default"]["regression"]["train"]["peak_rss_gb"] == 1.6  # the highest seed
    assert table["blendvoca-default"]["regression"]["train"]["seeds"] == [0, 1]
    data = tmp_path / "blendvoca-default"
    tasks = {t.key: t for t in plan_tasks(tmp_path / "w", tmp_path / "r", only=["mean", "regression", "said"],
                                          data=data, seeds=(0, 1), memory=table)}
    expected = {"data": 0.9, "expert": 0.7, "row/mean": 1.1, "train/regression/seed0": 1.6,
                "train/regression/seed1": 1.6, "score/regression/seed0": 2.2, "store/regression": 0.8}
    for key, peak in expected.items():
        assert tasks[key].resources.memory_gb == declared_memory_gb(peak) >= peak, key
    # unmeasured: the plan's defaults (a row's 2 GiB, the build's 4 GiB)
    assert tasks["train/said/seed0"].resources.memory_gb == 2.0
    assert tasks["score/regression/seed0"].spec["build"] == "blendvoca-default"
    other = {t.key: t for t in plan_tasks(tmp_path / "w", tmp_path / "r", only=["regression"], memory=table)}
    assert other["data"].resources.memory_gb == 4.0  # measured on another build: not this one's
    assert other["train/regression/seed0"].spec["build"] == BUILD_NAME


def test_write_memory_gathers_a_run_s_peaks_and_keeps_the_other_rows(tmp_path, capsys):
    from leaderboard.executors.memory import measured_memory
    from leaderboard.reproduce import main

    folder = tmp_path / "w" / "stages" / "timings"
    folder.mkdir(parents=True)
    for record in _records():
        (folder / (record["key"].replace("/", "__") + ".json")).write_text(json.dumps(record))
    table = tmp_path / "measured-memory.json"
    table.write_text(json.dumps({"builds": {"blendvoca-default": {
        "said": {"train": {"peak_rss_gb": 3.0, "seeds": [0], "measured": "2026-12-01"}},
        "regression": {"train": {"peak_rss_gb": 9.0, "seeds": [0], "measured": "2026-12-01"}}}}}))
    assert main(["--work", str(tmp_path / "w"), "--write-memory", str(table)]) == 0
    builds = measured_memory(table)["blendvoca-default"]
    assert builds["said"]["train"]["peak_rss_gb"] == 3.0  # not in this run: kept
    assert builds["regression"]["train"] == {"peak_rss_gb": 1.6, "seeds": [0, 1], "measured": "2026-12-06"}
    assert builds["regression"]["score"]["peak_rss_gb"] == 2.2 and builds["data"]["data"]["peak_rss_gb"] == 0.9
    capsys.readouterr()
    assert main(["--work", str(tmp_path / "w"), "--timings"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "| regression | score | 2.20 | 2.00 |" in out and "| data | data | 0.90 | 4.00 |" in out


def test_write_memory_without_measured_records_is_refused(tmp_path, capsys):
    from leaderboard.reproduce import main

    assert main(["--work", str(tmp_path / "w"), "--write-memory", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --write-memory: expected stage timing records")
    assert not (tmp_path / "m.json").exists()


def test_the_committed_table_declares_at_least_every_measured_peak(tmp_path):
    from leaderboard.executors.memory import measured_memory
    from leaderboard.reproduce import plan_tasks

    table = measured_memory()
    for build, rows in table.items():
        tasks = plan_tasks(tmp_path / "w", tmp_path / "r", data=tmp_path / build, memory=table)
        for task in tasks:
            entry = rows.get(task.row or task.stage, {}).get(task.stage)
            if entry is not None:
                assert task.resources.memory_gb >= entry["peak_rss_gb"], (build, task.key)


@pytest.mark.parametrize("executor", ["sequential", "ray"])
def test_a_plan_entry_needing_more_than_the_machine_is_refused_before_anything_runs(tmp_path, capsys,
                                                                                    monkeypatch, executor):
    from leaderboard.executors import memory
    from leaderboard.reproduce import main

    monkeypatch.setattr(memory, "machine_memory_gb", lambda: 1.5)  # a small node: the plan's 2 GiB rows exceed it
    monkeypatch.setattr(memory, "MEASURED_MEMORY", tmp_path / "none.json")  # every task at the plan's default
    assert main(["--work", str(tmp_path / "w"), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
                 "--only", "mean", "--executor", executor, "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("error: plan entry data needs 4 GiB of memory (the plan's default), more than the "
                             "1.5 GiB this machine has (and 2 more task(s))"), err[0]
    assert not (tmp_path / "w").exists() and not (tmp_path / "r").exists() and not (tmp_path / "t").exists()


def test_the_refusal_names_the_measured_peak_behind_a_declaration(tmp_path):
    from leaderboard.executors.memory import declared_memory_gb
    from leaderboard.reproduce import memory_refusal, plan_tasks

    table = {"blendvoca-default": {"cdface": {"train": {"peak_rss_gb": 11.0, "seeds": [0], "measured": "x"}}}}
    data = tmp_path / "blendvoca-default"
    tasks = plan_tasks(tmp_path / "w", tmp_path / "r", only=["cdface"], data=data, seeds=(0,), memory=table)
    message = memory_refusal(tasks, 8.0, memory=table, build="blendvoca-default")
    assert message == (f"plan entry train/cdface/seed0 needs {declared_memory_gb(11.0):g} GiB of memory (its measured "
                       "peak 11.00 GiB with the margin), more than the 8.0 GiB this machine has; nothing was run")
    assert memory_refusal(tasks, 24.0, memory=table, build="blendvoca-default") is None


def test_every_ray_task_reserves_its_declared_memory():
    from leaderboard.executors import Resources, Task
    from leaderboard.executors.ray_executor import _options

    task = Task("score/r/seed0", "score", _allocating_stage, {}, resources=Resources(cpus=2, memory_gb=1.75))
    assert _options(task, 3)["memory"] == int(1.75 * GIB) and _options(task, 3)["num_cpus"] == 2
