"""The runner and baselines on a real (tiny) BlendVOCA build with its own corpus meshes.

Scored with the vertex metrics only (the latent metrics are the metrics module's
business and dominate the time); slow because the shared fixture builds the dataset.
"""

import json

import pytest

from baselines.mesh_adapter.export import exported_corpus_meshes
from benchmark.run import run_method

pytestmark = pytest.mark.slow


def _vertex_only(generated, dataset, split="test"):
    from benchmark.evaluate import vertex_metrics

    truth = {k: dataset.coeffs(*k) for k in generated}
    rigs = {s: dataset.rig(s) for s, _ in generated}
    return vertex_metrics(truth, generated, rigs, dataset.names)


def _run(name, built_dataset, tmp_path, **kw):
    path = run_method(name, built_dataset, results_dir=tmp_path / "results", evaluate=_vertex_only,
                      progress=False, **kw)
    return json.loads(path.read_text())


def test_reference_rows_and_mesh_adapter_on_real_build(built_dataset, synthetic_corpus, tmp_path):
    gt = _run("ground-truth", built_dataset, tmp_path)
    static = _run("static", built_dataset, tmp_path)
    assert gt["metrics"]["lve"]["mean"] == 0.0 and gt["metrics"]["mve"]["mean"] == 0.0
    assert static["metrics"]["lve"]["mean"] > 0.1  # mm: the corpus really moves the lips
    assert gt["dataset"]["manifest_hash"] == static["dataset"]["manifest_hash"]

    for fps in (60, 30):
        config = exported_corpus_meshes(synthetic_corpus, tmp_path / f"meshes{fps}", fps=fps, progress=False)
        adapted = _run("mesh-adapter", built_dataset, tmp_path, config={"config": str(config)})
        assert adapted["method"]["label"] == f"corpus meshes ({fps} fps)"
        # the corpus meshes are what the build fitted: the adapter must land near ground truth
        assert adapted["metrics"]["lve"]["mean"] < 0.25 * static["metrics"]["lve"]["mean"], fps
        assert adapted["metrics"]["mve"]["mean"] < 0.25 * static["metrics"]["mve"]["mean"], fps
