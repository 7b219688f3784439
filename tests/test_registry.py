"""One registry shape (``blendvoca.registry.Registry``) behind the four registries:
methods, dataset adapters, naming conventions and export formats."""

import importlib.metadata
import json

import pytest

from blendvoca.errors import UserError
from blendvoca.registry import Registry, import_target, is_target

JSON_DUMPS = "json:dumps"


class _NoSuchThing(UserError):
    """The registry's own error for an unknown name."""


def test_targets_are_imported_on_first_lookup_once():
    registry = Registry("thing", {"dumps": JSON_DUMPS, "loads": json.loads})
    assert registry.names() == ("dumps", "loads") and "dumps" in registry and "dump" not in registry
    assert registry.entries()["dumps"] == JSON_DUMPS  # nothing imported yet
    assert registry.get("dumps") is json.dumps
    assert registry.entries()["dumps"] is json.dumps  # resolved once
    assert registry.get("loads") is json.loads


def test_an_unknown_name_is_the_kinds_error_with_close_matches():
    registry = Registry("thing", {"dumps": JSON_DUMPS, "loads": "json:loads"}, error=_NoSuchThing, where="--thing")
    with pytest.raises(_NoSuchThing) as info:
        registry.get("dump")
    assert str(info.value) == "--thing: unknown thing 'dump' (did you mean 'dumps'?); known: dumps, loads"
    assert str(registry.unknown("zzz", where="elsewhere")) == "elsewhere: unknown thing 'zzz'; known: dumps, loads"
    assert isinstance(info.value, ValueError)  # a UserError: one error: line, exit 2


def test_adding_twice_a_bad_target_and_the_check():
    seen = []
    registry = Registry("thing", {"dumps": JSON_DUMPS}, check=lambda obj, name: seen.append((name, obj)))
    with pytest.raises(ValueError, match="'dumps' is already registered \\(to json:dumps\\)"):
        registry.add("dumps", "json:loads")
    registry.add("missing", "no_such_module_xyz:thing")
    with pytest.raises(UserError, match="thing 'missing': cannot import module 'no_such_module_xyz'"):
        registry.get("missing")
    registry.add("typo", "json:dumpz")
    with pytest.raises(UserError, match="module 'json' has no attribute 'dumpz'"):
        registry.get("typo")
    registry.remove("typo")
    assert "typo" not in registry
    assert registry.get("dumps") is json.dumps and seen == [("dumps", json.dumps)]


def test_installed_entry_points_join_the_names(monkeypatch):
    group = "blendvoca.test-registry"
    declared = [importlib.metadata.EntryPoint("loads", "json:loads", group)]
    monkeypatch.setattr(importlib.metadata, "entry_points",
                        lambda group=None: [ep for ep in declared if ep.group == group])
    registry = Registry("thing", {"dumps": JSON_DUMPS}, entry_point_group=group)
    assert registry.names() == ("dumps", "loads")
    assert registry.get("loads") is json.loads
    declared.append(importlib.metadata.EntryPoint("dumps", "json:loads", group))
    with pytest.raises(ValueError, match="also declared by an installed package"):
        registry.names()


def test_target_strings():
    assert is_target("json:dumps") and is_target("a.b:C.d")
    assert not is_target("json") and not is_target("not a: target") and not is_target(3)
    assert import_target("json:JSONDecoder.decode", label="x") is json.JSONDecoder.decode


def test_the_four_registries_share_the_shape():
    from benchmark.methods.registry import METHODS, UnknownMethodError
    from blendvoca.datasets import ADAPTERS, UnknownDatasetError
    from blendvoca.export import FORMAT_REGISTRY
    from blendvoca.names import NAMING_CONVENTIONS

    for registry, wrong, error in ((METHODS, "regresion", UnknownMethodError), (ADAPTERS, "beats", UnknownDatasetError),
                                   (FORMAT_REGISTRY, "gbl", UserError), (NAMING_CONVENTIONS, "arkit5", UserError)):
        assert isinstance(registry, Registry)
        with pytest.raises(error, match=f"unknown .*'{wrong}' \\(did you mean"):
            registry.get(wrong)


def test_a_dataset_adapter_declares_its_options():
    from blendvoca.datasets import COMMON_OPTIONS, adapter, dataset_names

    posed = [name for name in dataset_names() if adapter(name).takes("pose_fit")]
    assert posed == ["biwi", "multiface"]
    assert all(adapter(name).takes(option) for name in dataset_names() for option in COMMON_OPTIONS)


def test_an_export_format_is_one_class_and_one_registry_line():
    from blendvoca.export import FORMAT_REGISTRY, FORMATS, NEEDS_RIG, SUFFIX, ExportFormat

    assert FORMATS == ("livelink", "arkit-json", "a2f-json", "glb", "usd", "fbx", "csv")
    for name in FORMATS:
        cls = FORMAT_REGISTRY.get(name)
        assert issubclass(cls, ExportFormat) and cls.name == name and SUFFIX[name] == cls.suffix
    assert NEEDS_RIG == {"glb", "usd", "fbx"}
