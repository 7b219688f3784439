"""Method contract v3 (``train(dataset, request)``) and the one adapter that still runs a
contract-v2 plug-in (``train(dataset, *, seed, budget)``) with one ``DeprecationWarning``."""

import json
import warnings

import numpy as np
import pytest

from benchmark.methods import Budget, Method, TrainingRequest, available_methods, get_method, register, unregister
from benchmark.methods.request import CONTRACT, call_train, train_contract
from benchmark.protocol import RunSpec, run
from blendvoca.errors import MethodError

from .fakes import fake_evaluate, speech_dataset


class _V2(Method):
    """A plug-in written for contract v2: keywords, no request, no declared contract."""

    def train(self, dataset, *, seed, budget):
        self.level = 0.1 + 0.01 * seed + 0.001 * budget.steps(0)

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((samples, utterance.num_frames, 32), self.level)


class _Mislabelled(_V2):
    """Declares contract 3 but kept the v2 signature."""

    contract = 3

    def train(self, dataset, *, seed, budget):
        super().train(dataset, seed=seed, budget=budget)


def test_an_old_plugin_still_scores_with_one_warning(tmp_path):
    register("test-contract-v2")(_V2)
    try:
        dataset = speech_dataset(seed=0, sentences=2, seconds=1.0)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            spec = RunSpec("test-contract-v2", data_root="unused", results_dir=tmp_path, seed=2,
                           budget=Budget(max_steps=3))
            path = run(spec, evaluate=fake_evaluate, open_dataset=lambda root: dataset)
        deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
        assert len(deprecations) == 1, [str(w.message) for w in caught]
        message = str(deprecations[0].message)
        assert "test-contract-v2" in message and "contract v2" in message and "\n" not in message
        result = json.loads(path.read_text())
        assert result["metrics"]["coeff_mse"]["mean"] >= 0
        assert result["protocol"]["convergence_check"] == "not checked: the method's train takes no on_checkpoint"
    finally:
        unregister("test-contract-v2")


def test_the_adapter_passes_seed_and_budget_to_a_v2_train():
    method = _V2()
    with pytest.warns(DeprecationWarning, match="contract v2"):
        call_train(method, None, TrainingRequest(seed=4, budget=Budget(max_steps=7), device="cpu"))
    assert method.level == pytest.approx(0.1 + 0.04 + 0.007)
    assert train_contract(_V2) == 2


def test_a_v3_call_refused_by_a_v2_signature_names_the_contract():
    with pytest.raises(TypeError, match=f"declares method contract v{CONTRACT}.*contract v2"):
        call_train(_Mislabelled(), None, TrainingRequest(seed=0))


def test_a_type_error_inside_a_v3_train_is_the_method_own():
    class Inner(_V2):
        contract = 3

        def train(self, dataset, request):
            raise TypeError("inside")

    with pytest.raises(TypeError, match="^inside$"):
        call_train(Inner(), None, TrainingRequest())


def test_the_runner_names_the_contract_when_train_rejects_the_request(tmp_path):
    from benchmark.protocol.training import prepared_method

    register("test-contract-mislabelled")(_Mislabelled)
    try:
        with pytest.raises(MethodError, match="method contract v3"):
            prepared_method("test-contract-mislabelled", {}, speech_dataset(seed=0, sentences=1, seconds=1.0),
                            seed=0, budget=Budget(max_steps=1))
    finally:
        unregister("test-contract-mislabelled")


@pytest.mark.parametrize("name", sorted(n for n in available_methods() if not n.startswith("test")))
def test_every_in_tree_method_speaks_contract_v3(name):
    assert train_contract(get_method(name)) == CONTRACT
