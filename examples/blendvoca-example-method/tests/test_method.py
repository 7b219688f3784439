"""The example plug-in against the method contract, with the benchmark's test kit."""

import numpy as np

from benchmark.methods import Budget, TrainingRequest
from benchmark.testing import FakeBlendVOCA, check_method
from blendvoca_example_method import EnergyJawMethod, energy_envelope


def test_passes_the_contract_checks():
    report = check_method(EnergyJawMethod, noise=0.02)
    assert report.output == "coefficients" and report.stochastic and report.samples == 2


def test_jaw_follows_the_energy_of_the_speech():
    dataset = FakeBlendVOCA(seed=1)
    method = EnergyJawMethod(noise=0.0)
    method.train(dataset, TrainingRequest(seed=0))
    utterance = dataset.utterance(*next((s, q) for s in dataset.split("test") for q in dataset.sentences(s)))
    jaw = method.generate(utterance, samples=1, seed=0)[0, :, method.jaw]
    envelope = energy_envelope(utterance.audio, utterance.num_frames)
    np.testing.assert_allclose(jaw, np.clip(method.gain * envelope, 0, 1))
    truth = dataset.coeffs(utterance.subject, utterance.sentence)[:, method.jaw]
    assert np.corrcoef(jaw, truth)[0, 1] > 0.8


def test_half_budget_check_sees_the_fit_of_half_the_sentences():
    dataset = FakeBlendVOCA(seed=1)
    n = sum(len(dataset.sentences(s)) for s in dataset.split("train"))
    method = EnergyJawMethod(noise=0.0)
    calls = []

    def on_checkpoint(step, total_steps=None):
        calls.append((step, total_steps, method.gain))

    method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=10_000), on_checkpoint=on_checkpoint))
    assert [(step, total) for step, total, _ in calls] == [(n // 2, n)]
    half = EnergyJawMethod(noise=0.0)
    half.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=n // 2)))
    assert calls[0][2] == half.gain  # the checkpoint saw exactly a run stopped there
    method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_seconds=60), on_checkpoint=on_checkpoint))
    assert len(calls) == 1  # a time-limited run has no known half
