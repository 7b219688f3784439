"""The half-budget call of every trained baseline (``Method.train(..., on_checkpoint=...)``):
made once, after half the steps (the last stage's half for staged methods), with a
method that can generate then; and a run with the call trains exactly the model of a
run without it (weights, train/eval modes and random states restored)."""

import math

import numpy as np
import pytest
import torch

from benchmark.methods.base import Budget, checkpoint_step, takes_checkpoint_hook
from benchmark.protocol.convergence import preserved_random_state
from benchmark.testing import FakeBlendVOCA


def _regression():
    from baselines.regression.plugin import RegressionMethod

    return RegressionMethod, {"steps": 100, "channels": 16, "hidden": 16, "batch": 8, "window": 40}


def _faceformer():
    from baselines.faceformer.plugin import FaceFormerMethod

    return FaceFormerMethod, {"feature_dim": 16, "max_seconds": None}


def _codetalker():
    from baselines.codetalker.plugin import CodeTalkerMethod

    return CodeTalkerMethod, {"feature_dim": 16, "vq_hidden_size": 16, "vq_zquant_dim": 4, "vq_n_embed": 16,
                              "max_seconds": None}


def _cdface():
    from baselines.cdface.plugin import CDFaceMethod
    from tests.cdface.test_plugin import PLUGIN_TINY

    return CDFaceMethod, PLUGIN_TINY


def _said():
    from baselines.said.plugin import SAiDMethod

    return SAiDMethod, {"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 4, "num_steps": 3,
                        "val_every": 2, "num_threads": 1}


# (method, step budget, expected (step, total_steps) of the call)
CASES = {
    "regression": (_regression, 6, (3, 6)),
    "faceformer": (_faceformer, 4, (2, 4)),
    # stage 1 takes 2 of the 6 steps (stage1_fraction); the call is at half of stage 2
    "codetalker": (_codetalker, 6, (4, 6)),
    # a step budget caps each of the three stages: 4 + 4 VQ steps, then half of the 4 querying steps
    "cdface": (_cdface, 4, (10, 12)),
    "said": (_said, 4, (2, 4)),
}


def _dataset():
    return FakeBlendVOCA(0, train=["A", "B"], val=["C"], test=["D"], sentences=2, frames=(62, 80))


def _train(factory, steps, dataset, *, hooked):
    cls, config = factory()
    torch.manual_seed(1234)  # the same global state before both runs
    method = cls(**config)
    calls = []
    subject = dataset.split("test")[0]
    utterance = dataset.utterance(subject, dataset.sentences(subject)[0], "test")

    def on_checkpoint(step, total_steps=None):
        with preserved_random_state():  # as the runner does
            out = np.asarray(method.generate(utterance, samples=2, seed=5))
            torch.manual_seed(99)  # what a generator may do to the global state
        calls.append((step, total_steps, out))

    hook = {"on_checkpoint": on_checkpoint} if hooked else {}
    method.train(dataset, seed=0, budget=Budget(max_steps=steps), **hook)
    final = np.asarray(method.generate(utterance, samples=2, seed=5))
    return calls, final


@pytest.mark.parametrize("name", list(CASES))
def test_the_half_budget_call_is_made_once_and_changes_nothing(name):
    factory, steps, expected = CASES[name]
    cls, _ = factory()
    assert takes_checkpoint_hook(cls.train)
    dataset = _dataset()
    calls, final = _train(factory, steps, dataset, hooked=True)
    assert [(step, total) for step, total, _ in calls] == [expected], name
    half = calls[0][2]
    assert np.all(np.isfinite(half)) and half.shape == final.shape
    _, alone = _train(factory, steps, dataset, hooked=False)
    np.testing.assert_array_equal(final, alone, err_msg=f"{name}: the half-budget call changed the training")


def test_a_time_limited_run_makes_no_call():
    factory, _, _ = CASES["regression"]
    cls, config = factory()
    method, calls = cls(**config), []
    method.train(_dataset(), seed=0, budget=Budget(max_steps=6, max_seconds=60.0),
                 on_checkpoint=lambda step, total_steps=None: calls.append(step))
    assert calls == []


def test_checkpoint_step_and_signature_inspection():
    assert checkpoint_step(60) == 30 and checkpoint_step(7) == 3 and checkpoint_step(2) == 1
    assert checkpoint_step(1) is None and checkpoint_step(0) is None and checkpoint_step(None) is None
    assert checkpoint_step(math.inf) is None and checkpoint_step(True) is None

    def old(self, dataset, *, seed, budget): ...
    def new(self, dataset, *, seed, budget, on_checkpoint=None): ...
    def open_ended(self, dataset, **kwargs): ...
    assert not takes_checkpoint_hook(old) and takes_checkpoint_hook(new) and takes_checkpoint_hook(open_ended)
    assert not takes_checkpoint_hook(42)


def test_paused_training_restores_weights_modes_flags_and_rng():
    from baselines.common.training import kept_state, paused_training

    torch.manual_seed(0)
    model = torch.nn.Sequential(torch.nn.Linear(3, 3), torch.nn.Dropout(0.5), torch.nn.Linear(3, 1))
    model.train()
    model[0].eval()  # a frozen part in eval mode, as CDFace's VQs while the querying model trains
    model[2].weight.requires_grad_(False)
    before = {k: v.clone() for k, v in model.state_dict().items()}
    other = {k: torch.zeros_like(v) for k, v in before.items()}
    rng = torch.random.get_rng_state()
    with paused_training(model, other) as paused:
        assert not any(m.training for m in paused.modules()) and not torch.is_grad_enabled()
        assert float(paused(torch.ones(1, 3))) == 0.0  # the given weights
        torch.manual_seed(5)
        paused.train()
    assert [m.training for m in model.modules()] == [True, False, True, True]
    assert model[0].weight.requires_grad and not model[2].weight.requires_grad
    assert all(torch.equal(v, before[k]) for k, v in model.state_dict().items())
    assert torch.equal(torch.random.get_rng_state(), rng)
    # the weights a best-on-validation loop would keep if it stopped now
    assert kept_state(None, None, 1.0) is None and kept_state(2.0, "best", 1.0) is None
    assert kept_state(1.0, "best", 2.0) == "best" and kept_state(1.0, "best", 1.0) == "best"
