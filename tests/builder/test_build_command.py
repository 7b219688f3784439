"""``python -m blendvoca.build`` is the build command itself (no import hook); the folder
manifest tool is ``python -m blendvoca.format manifest``; the builder's names read through
``blendvoca.build`` warn with the date they go."""

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _run(*args):
    return subprocess.run([sys.executable, "-W", "error", *args], cwd=REPO, capture_output=True, text=True,
                          check=False)


def test_the_commands_run():
    build = _run("-m", "blendvoca.build", "--help")
    assert build.returncode == 0 and "python -m blendvoca.build" in build.stdout and "--vocaset" in build.stdout
    assert build.stderr == ""
    tool = _run("-m", "blendvoca.format", "manifest", "--help")
    assert tool.returncode == 0 and "python -m blendvoca.format" in tool.stdout and "folder" in tool.stdout
    assert tool.stderr == ""
    refused = _run("-m", "blendvoca.format", "manifest", str(REPO / "no-such-folder"))
    assert refused.returncode == 2 and refused.stderr.startswith("error: ")


def test_no_import_hook_and_old_names_warn_with_a_date():
    import blendvoca.build
    import blendvoca.builder
    from blendvoca.builder.__main__ import main

    assert blendvoca.build.main is main
    assert not any(type(finder).__module__ == "blendvoca.build" for finder in sys.meta_path)
    with pytest.warns(DeprecationWarning, match="blendvoca.builder.build_dataset.*removed after 2027-06-30"):
        from blendvoca.build import build_dataset
    assert build_dataset is blendvoca.builder.build_dataset
    with pytest.raises(ModuleNotFoundError):
        import blendvoca.build.pipeline  # noqa: F401 - the old submodule paths are gone
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        blendvoca.build.nothing  # noqa: B018
