"""The half-budget call of every trained baseline (``TrainingRequest.on_checkpoint``):
made once, after half the steps (the last stage's half for staged methods), with a
method that can generate then; and a run with the call trains exactly the model of a
run without it (weights, train/eval modes and random states restored)."""

import math

import numpy as np
import pytest
import torch

from benchmark.methods.base import Budget, Method, TrainingRequest
from benchmark.methods.request import CONTRACT, checkpoint_steps, train_contract
from benchmark.methods.training_loop import kept_state, paused_training
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

    method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=steps),
                                          on_checkpoint=on_checkpoint if hooked else None))
    final = np.asarray(method.generate(utterance, samples=2, seed=5))
    return calls, final


@pytest.mark.parametrize("name", list(CASES))
def test_the_half_budget_call_is_made_once_and_changes_nothing(name):
    factory, steps, expected = CASES[name]
    cls, _ = factory()
    assert train_contract(cls) == CONTRACT
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
    method.train(_dataset(), TrainingRequest(seed=0, budget=Budget(max_steps=6, max_seconds=60.0),
                                             on_checkpoint=lambda step, total_steps=None: calls.append(step)))
    assert calls == []


def test_checkpoint_steps_and_declared_contracts():
    assert checkpoint_steps(60) == (30,) and checkpoint_steps(7) == (3,) and checkpoint_steps(2) == (1,)
    assert checkpoint_steps(1) == () and checkpoint_steps(0) == () and checkpoint_steps(None) == ()
    assert checkpoint_steps(math.inf) == () and checkpoint_steps(True) == ()
    assert checkpoint_steps(100, (0.25, 0.5)) == (25, 50) and checkpoint_steps(7, (0.5, 0.25)) == (1, 3)
    hooked = TrainingRequest(budget=Budget(max_steps=8), on_checkpoint=print, checkpoint_fractions=(0.25, 0.5))
    assert hooked.checkpoint_steps(8) == (2, 4) and TrainingRequest().checkpoint_steps(8) == ()
    assert TrainingRequest(budget=Budget(max_seconds=5.0), on_checkpoint=print).checkpoint_steps(8) == ()
    with pytest.raises(ValueError, match="checkpoint_fractions"):
        TrainingRequest(checkpoint_fractions=(1.0,))
    with pytest.raises(TypeError, match="Budget"):
        TrainingRequest(budget=None)

    class Untrained(Method):
        def generate(self, utterance, *, samples=1, seed=0): ...

    class Old(Untrained):
        def train(self, dataset, *, seed, budget): ...

    class New(Old):
        contract = 3

        def train(self, dataset, request): ...

    class Inherits(New):
        pass

    assert train_contract(Untrained) == train_contract(New) == train_contract(Inherits) == CONTRACT
    assert train_contract(Old) == 2


def test_paused_training_restores_weights_modes_flags_and_rng():
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


def test_the_loop_calls_at_every_fraction_the_runner_asks_for():
    factory, _, _ = CASES["regression"]
    cls, config = factory()
    dataset, weights = _dataset(), []
    for fractions in ((0.5,), (0.25, 0.5)):
        torch.manual_seed(1234)
        method, calls = cls(**config), []
        method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=8), checkpoint_fractions=fractions,
                                              on_checkpoint=lambda step, total_steps=None: calls.append((step, total_steps))))
        assert calls == [(round(8 * f), 8) for f in fractions]
        weights.append([v.clone() for v in method.model.state_dict().values()])
    assert all(torch.equal(a, b) for a, b in zip(*weights))  # a quarter-budget call changes nothing either


def test_a_time_budget_that_ends_training_early_says_so(capsys):
    """Issue 57: a time-budgeted training bar stopped at 66 % without saying the budget ran out."""
    import time

    from benchmark.methods.training_loop import StepLoop
    from blendvoca.runtime.progress import progress_bars

    def step(loop):
        time.sleep(0.02)
        return 1.0

    with progress_bars(True):
        result = StepLoop(max_steps=10_000, max_seconds=0.1, desc="training").run(step)
    err = capsys.readouterr().err
    assert result.steps < 10_000
    assert f"training: the time budget of 0.1 s ran out at step {result.steps} of 10000" in err
    with progress_bars(True):
        StepLoop(max_steps=3, max_seconds=60, desc="training").run(step)  # the steps ran out: no line
    assert "time budget" not in capsys.readouterr().err
