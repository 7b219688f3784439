"""The benchmark protocol end to end with the real metrics: same seed and step budget,
same numbers; intervals bracket the means; one per-sentence row and one stored CSV per
sentence and sample."""

import json

import pytest

from benchmark.methods import Budget
from benchmark.run import run_method
from benchmark.runs import read_run

pytestmark = pytest.mark.slow  # six scored runs with the VAE


def _evaluate(vae):
    from benchmark.evaluate import evaluate_split

    def evaluate(generated, dataset, split="test", **kw):
        return evaluate_split(generated, dataset, split=split, extractor=vae, wind_repeats=2, wind_resamples=3,
                              fd_resamples=50, **kw)

    return evaluate


@pytest.mark.parametrize("method, samples", [("mean", 1), ("regression", 1), ("random", 3)])
def test_same_seed_and_steps_give_identical_metrics(fake_dataset_dir, assets_dir, tmp_path, method, samples):
    from benchmark.data import open_blendvoca
    from benchmark.features import load_published_vae

    vae = load_published_vae(assets_dir / "said" / "vae.pth")
    results = []
    for attempt in ("a", "b"):
        path = run_method(method, fake_dataset_dir, samples=samples, seed=4, budget=Budget(max_steps=20),
                          results_dir=tmp_path / attempt, evaluate=_evaluate(vae), progress=False)
        results.append(json.loads(path.read_text()))
    first, second = results
    assert first["metrics"] == second["metrics"] and first["per_sentence"] == second["per_sentence"]
    assert first["protocol"]["deterministic"] is True
    ds = open_blendvoca(fake_dataset_dir)
    sentences = [(s, q) for s in ds.split("test") for q in ds.sentences(s)]
    for name, entry in first["metrics"].items():
        lo, hi = entry["ci95"]
        assert lo <= entry["mean"] <= hi, name
        assert entry["n"] == len(sentences) and entry["label"] and entry["group"], name
    assert [(r["subject"], r["sentence"]) for r in first["per_sentence"]] == sentences
    assert all("lve" in row for row in first["per_sentence"])
    if samples > 1:
        assert "sample_std" in first["metrics"]["lve"] and "multimodality" in first["metrics"]
    run = read_run(next((tmp_path / "a").glob("*.json")))
    assert run.keys == sentences and run.dataset_root == fake_dataset_dir.resolve()
    for key in sentences:
        assert len(run.track_paths(*key)) == samples
        assert run.tracks(*key).shape == (samples, ds.coeffs(*key).shape[0], 32)
