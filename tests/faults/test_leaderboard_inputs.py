"""Issue 56: the leaderboard's inputs a user or an adversary controls (result files, their
names and contents): names from result files escaped in the tables, an edited result or
one stored twice refused, file names that are not text named, a dataset path that is not
the run's build not followed."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from tests.faults.conftest import assert_one_error_line

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = ROOT / "leaderboard" / "results"


def _committed(name_part: str, recipe: str = "54a623f25316") -> Path:
    """The committed result file of the row ``name_part`` on the board of ``recipe`` (default: the synthetic one)."""
    (path,) = [p for p in COMMITTED.glob("*.json") if p.name.startswith(name_part) and f"__{recipe}__" in p.name]
    return path


def _build(capsys, results, out):
    from leaderboard.build import main

    code = main(["--results", str(results), "--out", str(out)])
    return code, capsys.readouterr()


def test_html_and_bars_in_a_method_name_are_escaped_in_the_tables(tmp_path, capsys):
    results = tmp_path / "r"
    results.mkdir()
    for path in COMMITTED.glob("*.json"):
        shutil.copy(path, results / path.name)
    record = json.loads(_committed("random__").read_text())
    evil = "<script>alert(1)</script> | x`y"
    record["method"]["label"] = evil
    (results / _committed("random__").name).write_text(json.dumps(record))
    code, out = _build(capsys, results, tmp_path / "t")
    assert code == 0, out.err
    md = (tmp_path / "t" / "leaderboard.md").read_text()
    assert "<script>" not in md and "&lt;script&gt;" in md
    row = next(line for line in md.splitlines() if "alert(1)" in line)
    header = next(line for line in md.splitlines() if line.startswith("| Method"))
    bars = lambda line: len(line.replace("\\|", "").split("|"))  # noqa: E731 - the unescaped cell bars
    assert bars(row) == bars(header)
    tex = (tmp_path / "t" / "leaderboard.tex").read_text()
    assert "\\textless{}script\\textgreater{}" in tex and "\\textbar{}" in tex and "<script>" not in tex


def test_an_edited_result_is_refused(tmp_path, capsys):
    from benchmark.protocol.storing import write_run
    from benchmark.results import read

    results = tmp_path / "r"
    results.mkdir()
    source = _committed("mean__")
    path = write_run(read(source), results, source.name)  # as a run writes it: with its record digest
    assert _build(capsys, results, tmp_path / "t")[0] == 0
    record = json.loads(path.read_text())
    record["metrics"]["lve_rig"].update(mean=1.0, ci95=[0.9, 1.1])  # mean and interval edited together
    path.write_text(json.dumps(record))
    code, out = _build(capsys, results, tmp_path / "t")
    assert code == 2
    assert_one_error_line(out.err, str(path), "edited", "record_sha256")


def test_the_same_result_under_two_names_is_refused(tmp_path, capsys):
    results = tmp_path / "r"
    results.mkdir()
    source = _committed("static__")
    shutil.copy(source, results / source.name)
    shutil.copy(source, results / "static-copy.json")
    code, out = _build(capsys, results, tmp_path / "t")
    assert code == 2
    assert_one_error_line(out.err, source.name, "static-copy.json", "same result")


@pytest.mark.parametrize("raw, content", [(b"\xff\xfe.json", None), (b"\xff.json", "{not json")])
def test_result_file_names_that_are_not_text_are_named(tmp_path, capsys, raw, content):
    results = tmp_path / "r"
    results.mkdir()
    target = os.path.join(os.fsencode(results), raw)
    if content is None:
        shutil.copy(_committed("static__"), target)
    else:
        Path(os.fsdecode(target)).write_text(content)
    code, out = _build(capsys, results, tmp_path / "t")
    assert code == 2
    assert_one_error_line(out.err, repr(raw), "not plain UTF-8", "rename it")
    from leaderboard.site.__main__ import main as site

    code = site(["--results", str(results), "--out", str(tmp_path / "site")])
    assert code == 2 and repr(raw) in capsys.readouterr().err


def test_a_dataset_path_that_is_not_the_runs_build_is_not_followed(tmp_path, small_build):
    from benchmark.results import check
    from blendvoca import format as fmt
    from leaderboard.site.data import SiteRun

    record = json.loads(_committed("static__").read_text())
    for path in ("/etc", str(small_build)):  # a system folder; a build of another dataset
        record["dataset"]["path"] = path
        assert SiteRun(tmp_path / "x.json", check(record)).dataset_root is None
    record["dataset"]["recipe_id"] = fmt.dataset_id(small_build)  # the run's own build: followed
    assert SiteRun(tmp_path / "x.json", check(record)).dataset_root == Path(small_build)
