"""Issue 56, deliverable 1's proof: no file the project reads can run code. Every file of a
build, a results folder and a ``leaderboard.reproduce`` work folder is replaced by a
pickle or torch payload whose unpickling would create a marker file; the commands that
read those folders end with exit 2 or 4 naming a file (or, for files they do not read,
succeed), and the marker never appears."""

from __future__ import annotations

import io
import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.faults.test_runner_faults import fast_scoring  # noqa: F401 - a fixture

ROOT = Path(__file__).resolve().parents[2]


class _Payload:
    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def _payloads(marker) -> tuple[bytes, bytes]:
    """``(pickle bytes, torch-file bytes)`` that create ``marker`` when unpickled."""
    import torch

    buffer = io.BytesIO()
    torch.save(_Payload(marker), buffer)
    return pickle.dumps(_Payload(marker)), buffer.getvalue()


def plant(folder, marker, only=None) -> list:
    """Replace every file under ``folder`` (with suffix ``only``) by a payload: torch files
    where torch files are read (.pt, .pth, .tar, .npz), pickles elsewhere; the files planted."""
    plain, torch_file = _payloads(marker)
    planted = []
    for path in sorted(Path(folder).rglob("*")):
        if path.is_file() and not path.is_symlink() and (only is None or path.suffix == only):
            path.write_bytes(torch_file if path.suffix in (".pt", ".pth", ".tar", ".npz", ".bin") else plain)
            planted.append(path)
    return planted


def _assert_refused_or_untouched(code, err, folder, marker):
    assert not Path(marker).exists(), "a payload ran"
    assert code in (0, 2, 4), err[-2000:]
    if code:
        assert "Traceback" not in err and str(folder) in err, err[-2000:]


def _benchmark(capsys, data, results, *argv):
    from benchmark.run import main

    code = main(["--method", "mean", "--data", str(data), "--results", str(results), "--quiet", *argv])
    return code, capsys.readouterr().err


def test_payloads_in_every_file_of_a_build_run_nothing(small_build, tmp_path, capsys, fast_scoring):  # noqa: F811
    marker = tmp_path / "MARKER"
    build = tmp_path / "B"
    shutil.copytree(small_build, build)
    suffixes = sorted({p.suffix for p in build.rglob("*") if p.is_file()})
    assert plant(build, marker)
    code, err = _benchmark(capsys, build, tmp_path / "r")
    assert code in (2, 4)
    _assert_refused_or_untouched(code, err, build, marker)
    # one kind of file at a time, unverified: each reader meets the payload
    for suffix in suffixes:
        shutil.rmtree(build)
        shutil.copytree(small_build, build)
        assert plant(build, marker, only=suffix)
        code, err = _benchmark(capsys, build, tmp_path / "r", "--no-verify")
        _assert_refused_or_untouched(code, err, build, marker)


@pytest.mark.slow  # a build over the planted folder (about 30 s)
def test_a_build_over_a_planted_output_folder_runs_nothing(small_build, small_corpus, tmp_path, capsys):
    from tests.faults.conftest import build_cli

    marker = tmp_path / "MARKER"
    build = tmp_path / "B"
    shutil.copytree(small_build, build)
    assert plant(build, marker)
    code, err = build_cli(capsys, "--vocaset", small_corpus, "--out", build, "--workers", "1")
    _assert_refused_or_untouched(code, err, build, marker)


def test_payloads_in_every_file_of_a_results_folder_run_nothing(small_build, tmp_path, capsys,
                                                                fast_scoring):  # noqa: F811
    from benchmark.results.__main__ import main as results_tool
    from leaderboard.build import main as build_tables
    from leaderboard.site.__main__ import main as site

    marker = tmp_path / "MARKER"
    results = tmp_path / "r"
    assert _benchmark(capsys, small_build, results)[0] == 0
    (json_file,) = results.glob("*.json")
    assert len(plant(results, marker)) > 1
    code = build_tables(["--results", str(results), "--out", str(tmp_path / "t")])
    _assert_refused_or_untouched(code, capsys.readouterr().err, results, marker)
    assert code == 2
    code = site(["--results", str(results), "--out", str(tmp_path / "site")])
    _assert_refused_or_untouched(code, capsys.readouterr().err, results, marker)
    assert code == 2
    code = results_tool(["upgrade", str(json_file)])
    _assert_refused_or_untouched(code, capsys.readouterr().err, results, marker)
    assert code == 2


@pytest.mark.slow  # a reproduce of one trained row, then a rerun over the planted work folder
def test_payloads_in_every_file_of_a_work_folder_run_nothing(small_build, tmp_path):
    marker = tmp_path / "MARKER"
    work, results = tmp_path / "w", tmp_path / "r"
    argv = [sys.executable, "-m", "leaderboard.reproduce", "--work", str(work), "--data", str(small_build),
            "--results", str(results), "--tables", str(tmp_path / "t"), "--only", "regression", "--seeds", "0",
            "--max-steps", "2", "--expert-steps", "2", "--quiet"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    first = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert first.returncode == 0, first.stderr[-2000:]
    planted = plant(work, marker)
    assert any(p.name == "seed0.json" for p in planted) and any("trained" in p.parts for p in planted)
    for path in results.glob("*.json"):  # the row's result gone: the store stage reads the work folder
        path.unlink()
    again = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    _assert_refused_or_untouched(again.returncode, again.stderr, work, marker)
    assert again.returncode in (2, 4)
