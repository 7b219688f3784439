"""Typed method config: declarations, ``--config`` checking before any work, ``--list-config``."""

from __future__ import annotations

import re

import pytest

import benchmark.run as run_module
from benchmark.methods import Method, available_methods, get_method
from benchmark.methods import method_schema
from benchmark.methods.config import ConfigSchema, Option, parse_value
from blendvoca import cli
from blendvoca.errors import UserError


class _Undeclared(Method):
    """A third-party plug-in as before declarations: its constructor takes ``**config`` only."""

    name = "undeclared-test"

    def generate(self, utterance, *, samples=1, seed=0):  # pragma: no cover - never run here
        raise NotImplementedError


class _Typed(Method):
    """A plug-in with an annotated constructor.

    Parameters
    ----------
    rate : float
        Learning rate. Second sentence.
    mode : {"fast", "slow"}
        How to run.
    name_ : str
        A free string.
    """

    name = "typed-test"

    def __init__(self, rate: float = 0.1, mode: str = "fast", name_: str = "x", width: int | None = None):
        super().__init__(rate=rate, mode=mode, name_=name_, width=width)

    def generate(self, utterance, *, samples=1, seed=0):  # pragma: no cover
        raise NotImplementedError


def test_schema_from_signature_reads_types_defaults_help_and_choices():
    schema = _Typed.config_schema()
    assert list(schema.options) == ["rate", "mode", "name_", "width"]
    assert (schema["rate"].type, schema["rate"].default, schema["rate"].help) == ("float", 0.1, "Learning rate")
    assert schema["mode"].choices == ("fast", "slow")
    assert schema["width"].type == "int | null"
    assert not schema.open


def test_values_are_read_against_their_declared_type():
    schema = _Typed.config_schema()
    assert schema.parse(["rate=1", "width=null", "name_=12", "mode=slow"]) == {
        "rate": 1, "width": None, "name_": "12", "mode": "slow"}  # a declared str keeps its text
    for pair, words in (("rate=abc", ["rate", "float", '"abc"', "str"]), ("width=2.5", ["width", "int | null", "2.5"]),
                        ("mode=medium", ["mode", '"fast"', '"medium"']), ("rat=1", ["rat", "did you mean rate"])):
        with pytest.raises(UserError) as info:
            schema.parse([pair], method="typed-test")
        assert all(word in str(info.value) for word in words), str(info.value)
    assert parse_value("abc") == "abc" and parse_value("[1, 2]") == [1, 2]


def test_undeclared_plugins_keep_working_with_json_values():
    assert _Undeclared.config_schema() is None
    assert cli.parse_config(["anything=[1, 2]", "x=abc"], schema=method_schema(_Undeclared)) == {
        "anything": [1, 2], "x": "abc"}

    class Attribute(_Typed):
        config_schema = None  # a plug-in may also declare nothing explicitly

    assert method_schema(Attribute) is None


def test_open_signature_passes_unknown_keys():
    def init(self, a: int = 1, **rest):
        pass

    schema = ConfigSchema.from_signature(init)
    assert schema.open and schema.parse(["a=2", "other=x"]) == {"a": 2, "other": "x"}
    with pytest.raises(UserError, match="expects int"):
        schema.parse(["a=x"])


@pytest.mark.parametrize("name, key, good, bad", [
    ("regression", "lr", "0.01", "abc"),
    ("said", "lr", "1e-4", "abc"),
    ("said", "num_steps", "20", "fifty"),
    ("faceformer", "max_steps", "10", "ten"),
    ("codetalker", "vq_n_embed", "64", "many"),
    ("cdface", "control", "lips", "eyes"),
])
def test_builtin_methods_declare_their_keys(name, key, good, bad):
    schema = get_method(name).config_schema()
    assert key in schema
    schema.parse([f"{key}={good}"], method=name)
    with pytest.raises(UserError, match=f"--config {key}: {name} expects"):
        schema.parse([f"{key}={bad}"], method=name)


def test_preset_methods_are_closed_to_keys_their_presets_do_not_know():
    from baselines.said.presets import PRESETS

    schema = get_method("said").config_schema()
    assert schema["preset"].choices == tuple(PRESETS)
    assert schema["cond_dim"].type == "int | null" and schema["encoder"].type == "dict | str"
    with pytest.raises(UserError, match="no such option"):
        schema.parse(["chanels=8"], method="said")


def test_every_registered_declaration_accepts_its_own_defaults():
    for name in available_methods():
        schema = method_schema(name)
        if schema is not None:
            schema.check({option.name: option.default for option in schema}, method=name)


@pytest.mark.parametrize("argv, words", [
    (["--method", "regression", "--config", "lr=abc"], ["--config lr", "float", '"abc"']),
    (["--method", "said", "--config", "nope=1"], ["--config nope", "said"]),
    (["--method", "said", "--preset", "fast"], ["--preset", '"cpu-demo"', '"fast"']),
])
def test_run_refuses_a_bad_config_before_any_work(argv, words, monkeypatch, tmp_path, capsys):
    def no_work(*args, **kwargs):
        raise AssertionError("the run started before the config was checked")

    monkeypatch.setattr(run_module, "run", no_work)
    assert run_module.main([*argv, "--results", str(tmp_path)]) == cli.EXIT_USER
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and all(w in err[0] for w in words), err


def test_list_config_prints_each_option(capsys):
    assert run_module.main(["--method", "regression", "--list-config"]) == cli.EXIT_OK
    out = capsys.readouterr().out
    assert "lr (float, default 0.002): Adam learning rate" in out
    assert run_module.main(["--method", "said", "--list-config"]) == cli.EXIT_OK
    assert 'preset (str, default "cpu-demo"; one of "cpu-demo", "paper")' in capsys.readouterr().out


def test_option_describe():
    assert Option("k", (int, type(None)), 3, "help").describe() == "k (int | null, default 3): help"


def test_list_config_gives_each_key_its_own_help_without_markup(capsys):
    # numpydoc's "channels, hidden : int" gave both keys one sentence; each key now has its own entry
    assert run_module.main(["--method", "regression", "--list-config"]) == cli.EXIT_OK
    lines = {line.split(" ", 1)[0]: line for line in capsys.readouterr().out.splitlines()}
    assert lines["channels"].endswith(": Channels of the CNN layers")
    assert lines["hidden"].endswith(": Hidden size of the GRU")
    assert lines["batch"] != lines["window"].replace("window", "batch")
    assert 'one of "off", "bf16", "fp16"' in lines["mixed_precision"] and "Autocast" in lines["mixed_precision"]
    assert "Budget.max_steps" in lines["steps"] and "``" not in lines["steps"]
    for name in available_methods():
        schema = method_schema(name)
        if schema is None:
            continue
        options = list(schema)
        for option in options:
            assert "``" not in option.help and ":`" not in option.help, (name, option.name, option.help)
        # every key has a sentence of its own (a preset key's is followed by its section and the presets' values)
        for option in options:
            assert option.help and not option.help.startswith("preset "), (name, option.name, option.help)
        own = [o.help.split(" (preset ")[0] for o in options]
        for a, b, text_a, text_b in zip(options, options[1:], own, own[1:]):
            assert text_a != text_b, (name, a.name, b.name, text_a)


def test_plain_text_reads_rst_as_a_terminal_shows_it():
    from benchmark.methods.config import plain_text

    assert plain_text("the ``vocaset.pth`` of :meth:`config` and :class:`~a.b.Budget`") == \
        "the vocaset.pth of config and Budget"


def test_list_gives_kind_row_and_description(capsys):
    assert run_module.main(["--list"]) == cli.EXIT_OK
    rows = {line.split()[0]: line.split(None, 3) for line in capsys.readouterr().out.splitlines()[1:]}
    assert set(rows) == set(available_methods())
    assert rows["said"][1:3] == ["coefficients", "ranked"] and "diffusion" in rows["said"][3]
    assert rows["faceformer"][1:3] == ["vertices", "ranked"]
    assert rows["static"][1:3] == ["coefficients", "reference"] and rows["static"][3].startswith("Lower reference")
    assert all("``" not in row[3] for row in rows.values())


def test_a_preset_key_gets_its_help_then_section_and_values(capsys):
    assert run_module.main(["--method", "said", "--list-config"]) == cli.EXIT_OK
    lines = {line.split(" ", 1)[0]: line for line in capsys.readouterr().out.splitlines()}
    assert lines["lr"] == ("lr (float, default 0.001): learning rate of the optimiser (preset training section: "
                           "cpu-demo: 0.001, paper: 1e-05)")
    assert lines["guidance"].startswith("guidance (float, default 1.0): classifier-free guidance scale")
    assert lines["audio_shift_prob"].split(": ", 1)[1] != lines["mirror_prob"].split(": ", 1)[1]


@pytest.mark.parametrize("method", ["faceformer", "codetalker", "said", "cdface"])
@pytest.mark.parametrize("pairs, message", [
    (["chunk_frames=0"], "chunk_frames: {m} expects a number >= 2, got 0"),
    (["chunk_frames=-5"], "chunk_frames: {m} expects a number >= 2, got -5"),
    (["chunk_frames=1"], "chunk_frames: {m} expects a number >= 2, got 1"),
    (["chunk_overlap=-1"], "chunk_overlap: {m} expects a number >= 0, got -1"),
    (["chunk_frames=60", "chunk_overlap=60"], "chunk_overlap: {m} expects a number below chunk_frames (60), got 60"),
])
def test_chunk_settings_are_refused_before_any_training(method, pairs, message):
    """Issue 56: chunk_frames 0, 1 or -5 and chunk_overlap >= chunk_frames or -1 were found only when
    generating, after training (exit 3, blaming the method)."""
    schema = method_schema(method)
    with pytest.raises(UserError, match=re.escape(message.format(m=method))):
        schema.parse(pairs, method=method)
    assert schema.parse(["chunk_frames=60", "chunk_overlap=59"], method=method) == {"chunk_frames": 60,
                                                                                       "chunk_overlap": 59}
