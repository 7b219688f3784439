"""The benchmark protocol: its steps and their records composed by hand give what
``run`` gives; and end to end with the real metrics, same seed and step budget,
same numbers; intervals bracket the means; one per-sentence row and one stored CSV per
sentence and sample."""

import dataclasses
import json

import numpy as np
import pytest

from benchmark.methods import Budget
from benchmark.protocol import (
    NOT_CHECKED,
    Generated,
    RunSpec,
    Scored,
    Trained,
    UsageError,
    check_inputs,
    generate,
    half_budget_check,
    run,
    run_method,
    score,
    store,
    track_writer,
    train,
)
from benchmark.runs import read_run
from tests.methods.fakes import fake_evaluate, speech_dataset


@pytest.mark.parametrize("field, value, flag", [("samples", 0, "--samples"), ("samples", True, "--samples"),
                                                ("sentence_batch", 1.5, "--sentence-batch"),
                                                ("generate_time_limit", -1, "--generate-time-limit"),
                                                ("generate_time_limit", float("nan"), "--generate-time-limit")])
def test_a_run_spec_is_checked_when_made(field, value, flag):
    with pytest.raises(UsageError, match=flag):
        RunSpec("mean", **{field: value})


def test_a_run_spec_is_frozen_and_keeps_its_own_config():
    config = {"split": "train"}
    spec = RunSpec("mean", config=config, budget=None)
    config["split"] = "val"
    assert spec.config == {"split": "train"} and spec.budget == Budget()
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.samples = 3


def test_the_steps_by_hand_give_what_run_gives(tmp_path):
    dataset = speech_dataset(seed=1, sentences=2, seconds=1.0)
    spec = RunSpec("random", data_root="unused", samples=2, seed=3, budget=Budget(max_steps=2),
                   results_dir=tmp_path / "steps")
    inputs = check_inputs(spec, open_dataset=lambda root: dataset, evaluation_assets=False)
    assert inputs.subjects == ("D", "E") and inputs.results_dir.is_dir()
    check, reason = half_budget_check(spec, inputs, evaluate=fake_evaluate)
    assert check is None and reason == NOT_CHECKED["untrained"]  # a reference method: nothing to check
    trained = train(spec, inputs.dataset, check=check)
    assert isinstance(trained, Trained) and trained.stochastic and trained.load_s is None
    assert trained.train_s is not None and trained.label == "random"
    writer = track_writer(spec, inputs, trained)
    generated = generate(spec, inputs.dataset, trained, store=writer)
    assert isinstance(generated, Generated) and generated.vertices is None and generated.n_clipped == 0
    assert list(generated.tracks) == [(s, q) for s in ("D", "E") for q in ("sentence01", "sentence02")]
    assert all(t.shape[0] == 2 for t in generated.tracks.values())
    scored = score(spec, inputs.dataset, generated, evaluate=fake_evaluate)
    assert isinstance(scored, Scored) and set(scored.metrics) == {"coeff_mse", "sync"}
    assert [(r["subject"], r["sentence"]) for r in scored.per_sentence] == list(generated.tracks)
    timings = {**trained.timings, "generate_s": generated.seconds, "evaluate_s": scored.seconds, "total_s": 1.0}
    by_hand = store(spec, inputs, trained, generated, scored, writer=writer, timings=timings, provenance={},
                    convergence_check=reason)
    composed = run(RunSpec("random", data_root="unused", samples=2, seed=3, budget=Budget(max_steps=2),
                           results_dir=tmp_path / "run"),
                   evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    a, b = json.loads(by_hand.read_text()), json.loads(composed.read_text())
    assert by_hand.name == composed.name
    for record in (a, b):  # torch's threads are recorded once torch is loaded, which run() may do first
        record["protocol"].pop("threads", None)
    for section in ("method", "dataset", "protocol", "metrics", "per_sentence", "tracks"):
        assert a[section] == b[section], section
    run_a, run_b = read_run(by_hand), read_run(composed)
    assert run_a.keys == run_b.keys
    assert all(np.array_equal(run_a.tracks(*key), run_b.tracks(*key)) for key in run_a.keys)
    # the old keyword facade still runs the same spec, with a dated DeprecationWarning
    with pytest.warns(DeprecationWarning, match="run_method is removed after 2027-06-30"):
        old = run_method("random", "unused", samples=2, seed=3, budget=Budget(max_steps=2),
                         results_dir=tmp_path / "old", evaluate=fake_evaluate,
                         open_dataset=lambda root: dataset)
    assert json.loads(old.read_text())["metrics"] == b["metrics"]


def test_a_failing_step_leaves_nothing(tmp_path):
    dataset = speech_dataset(seed=1, sentences=1, seconds=1.0)

    def evaluate(tracks, dataset, split="test"):
        raise RuntimeError("the evaluation broke")

    spec = RunSpec("mean", data_root="unused", results_dir=tmp_path / "r")
    with pytest.raises(RuntimeError, match="evaluation broke"):
        run(spec, evaluate=evaluate, open_dataset=lambda root: dataset)
    assert list((tmp_path / "r").iterdir()) == []  # no result, no tracks, no staging folder


def _evaluate(vae):
    from benchmark.evaluation import EvaluationSettings, evaluate_split

    def evaluate(generated, dataset, split="test", vertices=None, metrics=None):
        settings = EvaluationSettings(extractor=vae, wind_repeats=2, wind_resamples=3, fd_resamples=50)
        return evaluate_split(generated if vertices is None else Generated(generated, vertices=vertices), dataset,
                              split, settings, metrics=metrics)

    return evaluate


@pytest.mark.slow  # six scored runs with the VAE
@pytest.mark.parametrize("method, samples", [("mean", 1), ("regression", 1), ("random", 3)])
def test_same_seed_and_steps_give_identical_metrics(fake_dataset_dir, assets_dir, tmp_path, method, samples):
    from benchmark.data import open_blendvoca
    from benchmark.features import load_published_vae

    vae = load_published_vae(assets_dir / "said" / "vae.pth")
    results = []
    for attempt in ("a", "b"):
        path = run(RunSpec(method, data_root=fake_dataset_dir, samples=samples, seed=4, budget=Budget(max_steps=20),
                           results_dir=tmp_path / attempt), evaluate=_evaluate(vae))
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
    assert all("lve_rig" in row for row in first["per_sentence"])
    if samples > 1:
        assert "sample_std" in first["metrics"]["lve_rig"] and "multimodality" in first["metrics"]
    stored = read_run(next((tmp_path / "a").glob("*.json")))
    assert stored.keys == sentences and stored.dataset_root == fake_dataset_dir.resolve()
    for key in sentences:
        assert len(stored.track_paths(*key)) == samples
        assert stored.tracks(*key).shape == (samples, ds.coeffs(*key).shape[0], 32)
