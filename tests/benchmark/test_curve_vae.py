"""The learning curve's FD is scored by the run's own VAE (``--vae``), as the row's FD is:
a checkpoint's FD replicates equal those of a run trained to that step with the same VAE."""

import json

import numpy as np
import pytest

from benchmark.methods import Budget, register, unregister
from benchmark.protocol import RunSpec, run
from tests.benchmark.test_protocol_seeds import Stepper


@pytest.fixture(scope="module", autouse=True)
def registered():
    register("test-curve-stepper")(Stepper)
    yield
    unregister("test-curve-stepper")


def _run(data, results, steps, vae=None):
    path = run(RunSpec("test-curve-stepper", data_root=data, results_dir=results, samples=1, seed=1,
                       budget=Budget(max_steps=steps), vae=vae))
    return json.loads(path.read_text())


def test_the_checkpoints_fd_is_scored_by_the_runs_vae(tmp_path):
    from benchmark.features.train import train_vae_on_build
    from benchmark.protocol import default_data_root

    built_dataset = default_data_root()  # sentences of 3-5 s: FD has windows of 120 frames

    vae = tmp_path / "vae.pth"
    train_vae_on_build(built_dataset, vae, steps=2)
    full = _run(built_dataset, tmp_path / "full", 10, vae)
    assert full["protocol"]["vae"]["path"] == str(vae.resolve())
    half = full["convergence"]["curve"][1]
    assert half["step"] == 5
    five = _run(built_dataset, tmp_path / "five", 5, vae)  # the model the checkpoint at step 5 is
    assert half["metrics"]["fd"] == pytest.approx(five["metrics"]["fd"]["mean"])
    assert half["replicates"]["fd"] == pytest.approx(five["metrics"]["fd"]["replicates"])
    # the published VAE gives other numbers: the curve above did not use it
    published = _run(built_dataset, tmp_path / "published", 5)
    assert not np.isclose(published["metrics"]["fd"]["mean"], half["metrics"]["fd"])
