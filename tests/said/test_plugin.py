import numpy as np
import pytest

from benchmark.testing import FakeBlendVOCA

TINY = {"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 4, "num_steps": 3, "val_every": 2, "num_threads": 1}


def small_dataset(test=("s3",)):
    """Four speakers (two train, one val, the test ones as given), two sentences of 40-50 frames each."""
    return FakeBlendVOCA(0, train=["s0", "s1"], val=["s2"], test=list(test), sentences=2, frames=(40, 51))


def test_said_is_registered():
    from baselines.said.plugin import SAiDMethod
    from benchmark.methods import get_method

    assert get_method("said") is SAiDMethod
    assert SAiDMethod.stochastic


def test_plugin_train_generate_save_load(tmp_path):
    from baselines.said.plugin import SAiDMethod
    from benchmark.methods.base import Budget, TrainingRequest

    method = SAiDMethod(**TINY)
    method.train(small_dataset(), TrainingRequest(seed=0, budget=Budget(max_steps=4)))
    assert method.said.history["steps"] == 4 and method.said.history["best_step"] in (2, 4)
    audio = np.random.default_rng(1).standard_normal(16000).astype(np.float32) * 0.1
    from benchmark.methods import Utterance

    utterance = Utterance(subject="s3", sentence="sentence01", split="test", audio=audio, num_frames=61)
    out = method.generate(utterance, samples=2, seed=5)
    assert out.shape == (2, 61, 32) and out.min() >= 0 and out.max() <= 1
    method.save(tmp_path)
    back = SAiDMethod.load(tmp_path)
    assert back.config() == method.config()
    np.testing.assert_array_equal(back.generate(utterance, samples=2, seed=5), out)


def test_a_step_budget_trains_the_same_weights_whatever_the_global_rng():
    """The seed fixes the initial weights as well: two processes (here: two global RNG
    states at construction) train bit-identical networks on a step budget."""
    import torch

    from baselines.said.plugin import SAiDMethod
    from benchmark.methods.base import Budget, TrainingRequest

    states = []
    for global_seed in (1, 2):
        torch.manual_seed(global_seed)
        method = SAiDMethod(**TINY)
        method.train(small_dataset(), TrainingRequest(seed=3, budget=Budget(max_steps=3)))
        states.append(method.said.model.state_dict())
    assert states[0].keys() == states[1].keys()
    for key in states[0]:
        torch.testing.assert_close(states[0][key], states[1][key], rtol=0, atol=0, msg=key)


def test_plugin_batches_sentences_through_the_runner():
    from baselines.said.plugin import SAiDMethod
    from benchmark.methods.base import Budget, TrainingRequest
    from benchmark.protocol import generated_tracks

    method = SAiDMethod(**TINY)
    method.train(small_dataset(), TrainingRequest(seed=0, budget=Budget(max_steps=2)))
    data = small_dataset(test=["s0", "s1", "s3"])  # six sentences
    alone, _ = generated_tracks(method, data, samples=2, seed=3)
    batched, _ = generated_tracks(method, data, samples=2, seed=3, sentence_batch=4)
    assert list(alone) == list(batched)
    for key in alone:
        assert alone[key].shape == batched[key].shape
        # batched rows round differently; with non-zero weights a DDIM chain amplifies that
        # (2.6e-4 here, up to 8e-4 with random weights: docs/said.md, "Batching sentences")
        np.testing.assert_allclose(batched[key], alone[key], atol=1e-3, rtol=0)


def test_plugin_rejects_unknown_option():
    from baselines.said.plugin import SAiDMethod

    with pytest.raises(ValueError, match="unknown key"):
        SAiDMethod(widht=3)


def test_a_trained_checkpoint_samples_with_other_sampling_options(tmp_path):
    from baselines.said.plugin import SAiDMethod
    from benchmark.methods import Utterance
    from benchmark.methods.base import Budget, TrainingRequest
    from benchmark.protocol import prepared_method

    method = SAiDMethod(**TINY)
    method.train(small_dataset(), TrainingRequest(seed=0, budget=Budget(max_steps=2)))
    method.save(tmp_path)
    audio = np.random.default_rng(1).standard_normal(16000).astype(np.float32) * 0.1
    utterance = Utterance(subject="s3", sentence="sentence01", split="test", audio=audio, num_frames=61)

    # through the runner, as `benchmark.run --checkpoint DIR --config guidance=2 --config num_steps=5`
    loaded, _ = prepared_method("said", {**TINY, "guidance": 2.0, "num_steps": 5}, small_dataset(), seed=0,
                                budget=Budget(max_steps=2), checkpoint=tmp_path)
    assert loaded.said.model is not method.said.model  # loaded from the directory
    assert loaded.config()["guidance"] == 2.0 and loaded.config()["resolved"]["sampling"]["num_steps"] == 5
    expected = method.said.generate(audio, 61, samples=2, seed=4, guidance=2.0, num_steps=5)
    np.testing.assert_array_equal(loaded.generate(utterance, samples=2, seed=4), expected)

    ddpm = method.with_sampling_options(sampler="ddpm", eta=0.5)
    assert ddpm.said.model is method.said.model and method.said.config["sampling"]["sampler"] == "ddim"
    np.testing.assert_array_equal(ddpm.generate(utterance, samples=1, seed=4),
                                  method.said.generate(audio, 61, samples=1, seed=4, sampler="ddpm", eta=0.5))
    with pytest.raises(ValueError, match=r"num_steps an integer in \[1, 1000\], got 0"):
        method.with_sampling_options(num_steps=0)
    with pytest.raises(ValueError, match=r"\['lr'\] are not sampling options"):
        method.with_sampling_options(lr=1.0)
