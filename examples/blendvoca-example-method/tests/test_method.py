"""The example plug-in against the method contract, with the benchmark's test kit."""

import numpy as np

from benchmark.testing import FakeBlendVOCA, check_method
from blendvoca_example_method import EnergyJawMethod, energy_envelope


def test_passes_the_contract_checks():
    report = check_method(EnergyJawMethod, noise=0.02)
    assert report.output == "coefficients" and report.stochastic and report.samples == 2


def test_jaw_follows_the_energy_of_the_speech():
    dataset = FakeBlendVOCA(seed=1)
    method = EnergyJawMethod(noise=0.0)
    method.train(dataset, seed=0, budget=None)
    utterance = dataset.utterance(*next((s, q) for s in dataset.split("test") for q in dataset.sentences(s)))
    jaw = method.generate(utterance, samples=1, seed=0)[0, :, method.jaw]
    envelope = energy_envelope(utterance.audio, utterance.num_frames)
    np.testing.assert_allclose(jaw, np.clip(method.gain * envelope, 0, 1))
    truth = dataset.coeffs(utterance.subject, utterance.sentence)[:, method.jaw]
    assert np.corrcoef(jaw, truth)[0, 1] > 0.8
