"""Fixtures of the fault suite: a small corpus (3 speakers x 2 sentences of 1-1.5 s, seed 1),
its build, and helpers that run the CLIs in-process and check their single error line.

The session fixtures are read-only: tests copy them into ``tmp_path`` before breaking anything.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

SMALL_CORPUS = dict(speakers=3, sentences=2, seed=1, duration=(1.0, 1.5))


@pytest.fixture(scope="session")
def small_corpus(tmp_path_factory, assets_dir) -> Path:
    from blendvoca.synthetic import generate_corpus

    return generate_corpus(tmp_path_factory.mktemp("faults") / "S", layout="official", **SMALL_CORPUS)


@pytest.fixture(scope="session")
def small_processed(tmp_path_factory, assets_dir) -> Path:
    from blendvoca.synthetic import generate_corpus

    return generate_corpus(tmp_path_factory.mktemp("faults") / "P", layout="processed",
                           **SMALL_CORPUS)


@pytest.fixture(scope="session")
def small_build(tmp_path_factory, small_corpus) -> Path:
    from blendvoca.builder import build_dataset

    out = tmp_path_factory.mktemp("faults") / "B"
    summary = build_dataset(out, small_corpus, workers=1)
    assert summary.ok, summary.failures
    return out


@pytest.fixture
def copies(tmp_path, small_corpus, small_build):
    """``(corpus, out)``: private copies of the small corpus and of its finished build."""
    corpus, out = tmp_path / "S", tmp_path / "B"
    shutil.copytree(small_corpus, corpus)
    shutil.copytree(small_build, out)
    return corpus, out


def tree(root) -> dict:
    """``{relpath: bytes}`` of every file under ``root``."""
    root = Path(root)
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def outputs(root) -> dict:
    """``{relpath: bytes}`` of a build's files that two builds of the same inputs share byte for byte:
    all but the stage records (``.buildstate/``) and the stage timings (volatile by design)."""
    from blendvoca.builder.report import TIMINGS

    return {rel: data for rel, data in tree(root).items()
            if not rel.startswith(".buildstate/") and rel != TIMINGS}


def build_cli(capsys, *args) -> tuple[int, str]:
    """Run ``python -m blendvoca.build ARGS --quiet`` in-process; return (exit code, stderr)."""
    from blendvoca.builder.__main__ import main

    code = main([*map(str, args), "--quiet"])
    return code, capsys.readouterr().err


def assert_one_error_line(err: str, *fragments: str) -> str:
    """The stderr of a refused command: exactly one ``error:`` line, no traceback, naming ``fragments``."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]
