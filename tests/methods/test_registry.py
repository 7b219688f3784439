import numpy as np
import pytest

from benchmark.methods import (
    BUILTIN_METHODS,
    Budget,
    Method,
    UnknownMethodError,
    available_methods,
    get_method,
    register,
    register_lazy,
    unregister,
)


class _Tiny(Method):
    def generate(self, utterance, *, samples=1, seed=0):
        return np.zeros((samples, utterance.num_frames, 32))


@pytest.fixture
def cleanup():
    names = []
    yield names
    for name in names:
        unregister(name)


def test_decorator_registers_and_sets_name(cleanup):
    @register("tiny-decorated")
    class Tiny(_Tiny):
        pass

    cleanup.append("tiny-decorated")
    assert get_method("tiny-decorated") is Tiny
    assert Tiny.name == "tiny-decorated"
    assert "tiny-decorated" in available_methods()


def test_duplicate_name_refused(cleanup):
    register("tiny-dup")(type("A", (_Tiny,), {}))
    cleanup.append("tiny-dup")
    with pytest.raises(ValueError, match="already registered"):
        register("tiny-dup")(type("B", (_Tiny,), {}))
    with pytest.raises(ValueError, match="already registered"):
        register_lazy("tiny-dup", "x.y:Z")


def test_builtin_names_refuse_reregistration():
    with pytest.raises(ValueError, match="already registered"):
        register_lazy("mean", "somewhere:Else")


def test_lazy_registration_imports_on_lookup(cleanup):
    register_lazy("tiny-lazy", "tests.methods.test_registry:_Tiny")
    cleanup.append("tiny-lazy")
    assert get_method("tiny-lazy") is _Tiny


def test_lazy_bad_target_reports_module(cleanup):
    register_lazy("tiny-broken", "no_such_module_xyz:Cls")
    cleanup.append("tiny-broken")
    with pytest.raises(ImportError, match="no_such_module_xyz"):
        get_method("tiny-broken")
    with pytest.raises(ValueError, match="package.module:Class"):
        register_lazy("tiny-bad-format", "no_colon")


def test_unknown_name_lists_close_matches():
    with pytest.raises(UnknownMethodError) as info:
        get_method("regresion")
    assert "did you mean 'regression'" in str(info.value)
    assert isinstance(info.value, KeyError)


def test_non_method_class_refused():
    with pytest.raises(TypeError, match="must subclass"):
        register("not-a-method")(type("Plain", (), {}))
    with pytest.raises(ValueError, match="lower-case"):
        register("Bad Name")


def test_builtins_are_listed_and_importable():
    names = available_methods()
    for name in BUILTIN_METHODS:
        assert name in names
    for name in ("ground-truth", "mean", "static", "random"):
        assert issubclass(get_method(name), Method)


def test_budget_checks_and_exhaustion():
    import time

    assert Budget().steps(7) == 7
    assert Budget(max_steps=3).steps(7) == 3
    assert Budget(max_steps=2).exhausted(2, time.perf_counter())
    assert not Budget(max_steps=2).exhausted(1, time.perf_counter())
    assert Budget(max_seconds=0).exhausted(0, time.perf_counter())
    with pytest.raises(ValueError, match="max_steps"):
        Budget(max_steps=-1)
    with pytest.raises(TypeError, match="max_seconds"):
        Budget(max_seconds="5")


def test_config_must_be_json():
    with pytest.raises(TypeError, match="JSON"):
        _Tiny(x=object())
    m = _Tiny(a=1, b="x")
    assert m.config() == {"a": 1, "b": "x"}


def test_base_save_load_round_trip(tmp_path):
    m = _Tiny(a=1, b=[1, 2])
    m.save(tmp_path / "ckpt")
    again = _Tiny.load(tmp_path / "ckpt")
    assert again.config() == m.config()
    with pytest.raises(FileNotFoundError, match="written by save"):
        _Tiny.load(tmp_path / "nothing")


def test_a_module_class_string_is_a_method_without_registering_it():
    # the string form the README lists: imported on lookup, not added to the registry
    assert get_method("tests.methods.test_registry:_Tiny") is _Tiny
    assert "tests.methods.test_registry:_Tiny" not in available_methods()
    with pytest.raises(UnknownMethodError, match="cannot import module 'no_such_pkg.mod'"):
        get_method("no_such_pkg.mod:Thing")
    with pytest.raises(UnknownMethodError, match="has no attribute 'Nope'"):
        get_method("tests.methods.test_registry:Nope")
    with pytest.raises(UnknownMethodError, match="must be a class"):
        get_method("tests.methods.test_registry:pytest")
    with pytest.raises(UnknownMethodError, match="unknown method"):
        get_method("not a: target")
