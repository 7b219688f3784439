"""``benchmark.run --method faceformer|codetalker --max-steps N`` on a real (tiny) build."""

import json

import pytest

from benchmark.methods.base import Budget
from benchmark.protocol import RunSpec, run

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name, config", [("faceformer", {"feature_dim": 16}),
                                          ("codetalker", {"feature_dim": 16, "vq_hidden_size": 16,
                                                          "vq_zquant_dim": 4, "vq_n_embed": 16})])
def test_brief_training_run_is_scored_as_a_vertex_method(built_dataset, tmp_path, name, config):
    path = run(RunSpec(name, data_root=built_dataset, results_dir=tmp_path / "results", samples=2, seed=0,
                       budget=Budget(max_steps=4), config=config))
    result = json.loads(path.read_text())
    assert result["method"]["output"] == "vertices"
    assert result["protocol"]["samples"] == 2
    metrics = result["metrics"]
    # the tiny build's sentences are shorter than the VAE window, so FD/WInD are left out here
    for key in ("lve_mesh", "lve_rig", "mve_mesh", "fdd_mesh", "apd_mesh") + tuple(k for k in ("fd", "wind")
                                                                             if k in metrics):
        assert metrics[key]["mean"] is not None and metrics[key]["mean"] == metrics[key]["mean"], key
    # the half-budget check ran on the method's own vertices (staged, then removed)
    convergence = result["convergence"]
    assert convergence["total_steps"] == 4 and "lve_rig" in convergence["metrics"]
    assert result["protocol"]["convergence_check"] == "checked" and result["timings"]["convergence_s"] > 0
    assert not list((tmp_path / "results").glob(".half-budget*"))
