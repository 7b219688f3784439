"""The build's old import paths and commands keep working (``blendvoca.build`` -> builder / format)."""

import importlib
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_the_old_import_paths_are_the_moved_modules():
    import blendvoca.build
    import blendvoca.build.pipeline
    import blendvoca.builder
    import blendvoca.builder.pipeline

    assert blendvoca.build.pipeline is blendvoca.builder.pipeline
    assert blendvoca.builder.pipeline.__spec__.name == "blendvoca.builder.pipeline"  # it keeps its own spec
    for old, new in blendvoca.build.ALIASES.items():
        assert importlib.import_module(f"blendvoca.build.{old}") is importlib.import_module(new), old
    from blendvoca.build import ManifestError, build_dataset, listed_files, pipeline, write_folder_manifest
    from blendvoca.build.__main__ import main
    from blendvoca.build.manifest import blas_kernels

    assert build_dataset is blendvoca.builder.build_dataset and pipeline is blendvoca.builder.pipeline
    assert main is importlib.import_module("blendvoca.builder.__main__").main
    import blendvoca.format.manifest as manifest

    assert (ManifestError, listed_files, write_folder_manifest, blas_kernels) == (
        manifest.ManifestError, manifest.listed_files, manifest.write_folder_manifest, manifest.blas_kernels)


def _run(*args):
    return subprocess.run([sys.executable, "-W", "error", *args], cwd=REPO, capture_output=True, text=True,
                          check=False)


def test_the_old_commands_run():
    build = _run("-m", "blendvoca.build", "--help")
    assert build.returncode == 0 and "python -m blendvoca.build" in build.stdout and "--vocaset" in build.stdout
    assert build.stderr == ""
    tool = _run("-m", "blendvoca.build.manifest", "--help")
    assert tool.returncode == 0 and "python -m blendvoca.build.manifest" in tool.stdout
    assert tool.stderr == ""  # no warning about the alias
    refused = _run("-m", "blendvoca.build.manifest", str(REPO / "no-such-folder"))
    assert refused.returncode == 2 and refused.stderr.startswith("error: ")
