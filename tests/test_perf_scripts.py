"""The performance scripts under ``perf/`` keep working: each imports and its ``--help`` runs.

They are run by hand (docs/results/ quotes what they print), so nothing else would
notice a renamed function or a moved module; this runs none of their measurements.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

PERF = Path(__file__).resolve().parents[1] / "perf"
SCRIPTS = sorted(PERF.glob("*.py"))


def test_the_folder_holds_the_scripts():
    assert len(SCRIPTS) >= 20 and not (PERF.parent / "benchmarks").exists()


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda path: path.stem)
def test_script_imports_and_its_help_runs(script, capsys):
    spec = importlib.util.spec_from_file_location(f"perf_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with pytest.raises(SystemExit) as done:
        module.main(["--help"])
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: ") and module.__doc__.strip().splitlines()[0][:40] in " ".join(out.split())
