"""The example plug-in, installed as a separate package, is found by name and scored."""

import importlib.util
import os
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from benchmark.methods import ENTRY_POINT_GROUP, available_methods, get_method
from benchmark.protocol import RunSpec, run

from .fakes import fake_evaluate, speech_dataset

pytestmark = pytest.mark.slow  # a pip install into a temporary folder

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "blendvoca-example-method"


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """pip-install the example into a private folder and put it on sys.path."""
    target = tmp_path_factory.mktemp("site")
    build = tmp_path_factory.mktemp("build")
    # build from a copy: an in-tree build would leave build/ and *.egg-info in examples/
    source = shutil.copytree(EXAMPLE, build / EXAMPLE.name, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(source)]
    if importlib.util.find_spec("setuptools") is not None:
        cmd[5:5] = ["--no-build-isolation", "--no-index"]  # offline: build with the installed setuptools
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=build, check=False)
    assert proc.returncode == 0, proc.stderr
    assert list(target.glob("blendvoca_example_method-*.dist-info")), "no dist-info: entry point not installed"
    sys.path.insert(0, str(target))
    yield target
    sys.path.remove(str(target))
    for name in [m for m in sys.modules if m.startswith("blendvoca_example_method")]:
        del sys.modules[name]


def test_example_found_through_entry_point(installed):
    assert "example-energy" in available_methods()
    cls = get_method("example-energy")
    assert cls.__module__ == "blendvoca_example_method"
    assert Path(sys.modules[cls.__module__].__file__).is_relative_to(installed)


def test_example_scored_without_touching_the_project(installed, tmp_path):
    dataset = speech_dataset(seed=4, sentences=2, seconds=1.0)
    path = run(RunSpec("example-energy", data_root="fake", samples=3, seed=1, results_dir=tmp_path),
               evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    result = json.loads(path.read_text())
    assert result["method"]["class"] == "blendvoca_example_method:EnergyJawMethod"
    assert result["protocol"]["samples"] == 3
    # the jaw follows the loudness: better than the mean baseline on this data
    mean_path = run(RunSpec("mean", data_root="fake", results_dir=tmp_path),
                    evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    mean = json.loads(mean_path.read_text())
    assert result["metrics"]["coeff_mse"]["mean"] < mean["metrics"]["coeff_mse"]["mean"]


def test_example_listed_by_cli_in_a_fresh_process(installed):
    env_path = f"{installed}:{Path(__file__).resolve().parents[2]}"
    proc = subprocess.run([sys.executable, "-m", "benchmark.run", "--list"], capture_output=True, text=True,
                          env={"PYTHONPATH": env_path, "PATH": "/usr/bin:/bin"}, check=False)
    assert proc.returncode == 0, proc.stderr
    assert "example-energy" in proc.stdout.split()
    assert ENTRY_POINT_GROUP == "blendvoca.methods"


def test_example_passes_check_method_and_its_own_tests(installed):
    from benchmark.testing import check_method

    report = check_method(get_method("example-energy"))
    assert report.name == "example-energy" and report.samples == 2
    # the plug-in's own test suite (which uses benchmark.testing) passes in a fresh process
    repo = Path(__file__).resolve().parents[2]
    env = {"PYTHONPATH": f"{installed}:{repo}", "PATH": "/usr/bin:/bin"}
    for key in ("BLENDVOCA_ASSETS", "BLENDVOCA_CACHE", "HOME"):
        if key in os.environ:
            env[key] = os.environ[key]
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(EXAMPLE / "tests")],
                          capture_output=True, text=True, env=env, cwd=EXAMPLE, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
