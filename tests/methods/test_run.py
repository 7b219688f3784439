import argparse
import json

import numpy as np
import pytest

from benchmark.methods import (
    Budget,
    Method,
    MethodError,
    MethodOutputError,
    progress_bars,
    register,
    show_progress,
    unregister,
)
from benchmark.protocol import RunSpec, UsageError, generated_tracks, run, sentence_seed
from benchmark.run import main
from blendvoca import cli
from blendvoca.errors import MethodTimeout, UserError

from .fakes import fake_evaluate, fake_evaluate_split, speech_dataset


@pytest.fixture(scope="module")
def dataset():
    return speech_dataset(seed=0, sentences=2, seconds=1.0)


def _run(name, dataset, tmp_path, **kw):
    spec = RunSpec(name, data_root="unused", samples=kw.pop("samples", 3), seed=kw.pop("seed", 0),
                   results_dir=tmp_path / "results", **kw)
    return run(spec, evaluate=fake_evaluate, open_dataset=lambda root: dataset)


class _Broken(Method):
    """Misbehaves as configured."""

    stochastic = True

    def __init__(self, mode="ok"):
        super().__init__(mode=mode)

    def train(self, dataset, *, seed, budget):  # contract v2: the old plug-in of these tests
        if self._config["mode"] == "train-raises":
            raise RuntimeError("boom in train")

    def generate(self, utterance, *, samples=1, seed=0):
        mode = self._config["mode"]
        out = np.full((samples, utterance.num_frames, 32), 0.5)
        if mode == "generate-raises":
            raise ZeroDivisionError("boom in generate")
        if mode == "nan":
            out[0, -1, 0] = np.nan
        if mode == "range":
            out[0, 0, 0] = -0.2
        if mode == "frames":
            out = out[:, :-1]
        if mode == "shape":
            out = out[0]
        return out


@pytest.fixture(scope="module", autouse=True)
def broken_registered():
    register("test-broken")(_Broken)
    yield
    unregister("test-broken")


@pytest.mark.parametrize(
    "mode, error, pattern",
    [
        ("train-raises", MethodError, "train failed: RuntimeError: boom in train"),
        ("generate-raises", MethodError, "subject 'D', sentence 'sentence01': generate failed: ZeroDivisionError"),
        ("nan", MethodOutputError, "subject 'D', sentence 'sentence01'.*non-finite"),
        ("range", MethodOutputError, r"outside \[0, 1\]"),
        ("frames", MethodOutputError, "wrong frame count"),
        ("shape", MethodOutputError, "2-d shape"),
    ],
)
def test_misbehaving_plugin_caught_and_no_result_file(mode, error, pattern, dataset, tmp_path):
    with pytest.raises(error, match=pattern):
        _run("test-broken", dataset, tmp_path, config={"mode": mode})
    assert not (tmp_path / "results").exists() or not any((tmp_path / "results").iterdir())


def test_bad_config_reported(dataset, tmp_path):
    # a config the constructor refuses is a user mistake, reported before any training
    with pytest.raises(UsageError, match="construction with config"):
        _run("test-broken", dataset, tmp_path, config={"nope": 1})


def _cli_on(dataset, monkeypatch):
    """``main`` runs on ``dataset`` with the fake evaluation, whatever ``--data`` names."""
    from benchmark.protocol import scoring, spec

    monkeypatch.setattr(spec, "_open_default", lambda root: dataset)
    monkeypatch.setattr(scoring, "evaluate_split", fake_evaluate_split)


def test_cli_reports_misbehaviour_without_traceback(dataset, tmp_path, monkeypatch, capsys):
    _cli_on(dataset, monkeypatch)
    data = str(tmp_path)
    rc = main(["--method", "test-broken", "--data", data, "--config", "mode=nan", "--results",
               str(tmp_path / "r"), "--quiet"])
    assert rc == 3
    assert "non-finite" in capsys.readouterr().err
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())
    rc = main(["--method", "grund-truth", "--data", data, "--results", str(tmp_path / "r"), "--quiet"])
    assert rc == 2 and "ground-truth" in capsys.readouterr().err
    rc = main(["--method", "test-broken", "--data", data, "--results", str(tmp_path / "r"),
               "--samples", "2", "--seed", "5"])
    assert rc == 0
    assert "coeff_mse" in capsys.readouterr().err  # the metric summary
    (path,) = (tmp_path / "r").glob("*.json")
    result = json.loads(path.read_text())
    assert result["protocol"]["samples"] == 2 and result["protocol"]["seed"] == 5
    # the stored tracks: one CSV per sentence and sample, in the folder the JSON names
    tracks = sorted(p.relative_to(tmp_path / "r" / result["tracks"]).as_posix()
                    for p in (tmp_path / "r" / result["tracks"]).rglob("*.csv"))
    assert tracks == [f"{s}/sentence{q:02d}-{k}.csv" for s in ("D", "E") for q in (1, 2) for k in (0, 1)]
    # beside them the run's figure (benchmark.run_figure)
    assert sorted(p.name for p in (tmp_path / "r").iterdir()) == sorted([result["tracks"], path.name,
                                                                        path.with_suffix(".png").name])


def test_result_file_contents(dataset, tmp_path):
    path = _run("test-broken", dataset, tmp_path, samples=4, seed=3, budget=Budget(max_steps=5))
    r = json.loads(path.read_text())
    assert r["method"]["name"] == "test-broken" and r["method"]["stochastic"] is True
    assert r["method"]["config"] == {"mode": "ok"}
    assert r["dataset"]["manifest_hash"] == dataset.manifest_hash
    assert r["dataset"]["num_sentences"] == 4 and r["dataset"]["num_subjects"] == 2
    # issue 56: the digest of the measured record, and the threads the evaluation used
    from benchmark.results import read

    assert r["protocol"].pop("record_sha256") == read(path).record_digest() and not read(path).edited()
    assert set(r["protocol"].pop("threads", {})) <= {"torch"}
    assert r["protocol"].pop("motionless_sentences", 0) in (0, 4)  # its tracks may be constant
    assert r["protocol"] == {"samples": 4, "seed": 3, "budget": {"max_steps": 5, "max_seconds": None},
                             "clip": False, "n_clipped": 0, "checkpoint": None, "deterministic": True,
                             "generate_time_limit": {"base_s": 120.0, "per_audio_second_s": 60.0},
                             "verified": False,
                             "convergence_check": "not checked: the method's train takes no on_checkpoint"}
    assert "convergence" not in r and r["timings"]["convergence_s"] is None  # an old plug-in: no check
    assert set(r["metrics"]) == {"coeff_mse", "sync"}
    assert r["metrics"]["coeff_mse"]["higher_is_better"] is False
    assert {"train_s", "generate_s", "evaluate_s", "total_s"} <= set(r["timings"])
    assert {"versions", "hardware", "git_revision", "date"} <= set(r["provenance"])


def test_deterministic_methods_get_one_sample(dataset):
    from benchmark.methods import get_method

    generated, _ = generated_tracks(get_method("static")(), dataset, samples=7)
    assert all(v.shape[0] == 1 for v in generated.values())
    generated, _ = generated_tracks(get_method("random")(), dataset, samples=7, seed=1)
    assert all(v.shape[0] == 7 for v in generated.values())
    again, _ = generated_tracks(get_method("random")(), dataset, samples=7, seed=1)
    assert all(np.array_equal(generated[k], again[k]) for k in generated)


class _Batching(Method):
    """Seeded noise per sentence; records how the runner grouped the sentences."""

    stochastic = True

    def __init__(self):
        super().__init__()
        self.calls = []

    def generate(self, utterance, *, samples=1, seed=0):
        rng = np.random.default_rng(seed)
        return rng.uniform(0, 1, size=(samples, utterance.num_frames, 32))

    def generate_many(self, utterances, *, samples=1, seeds):
        self.calls.append([(u.subject, u.sentence, u.num_frames, seed) for u, seed in zip(utterances, seeds)])
        return super().generate_many(utterances, samples=samples, seeds=seeds)


def test_sentence_batches_go_by_length_with_each_sentence_seed():
    data = speech_dataset(seed=4, sentences=4, seconds=1.0)
    one = _Batching()
    alone, _ = generated_tracks(one, data, samples=2, seed=9)
    assert one.calls == []  # one sentence per call: plain generate
    batching = _Batching()
    batched, _ = generated_tracks(batching, data, samples=2, seed=9, sentence_batch=3)
    items = [(s, n) for s in data.split("test") for n in data.sentences(s)]
    assert list(batched) == items == list(alone)  # the split's order, whatever the batches
    assert all(np.array_equal(batched[k], alone[k]) for k in items)
    assert [len(call) for call in batching.calls] == [3, 3, 2]
    flat = [entry for call in batching.calls for entry in call]
    assert [e[2] for e in flat] == sorted(e[2] for e in flat)  # shortest first
    assert {(e[0], e[1]): e[3] for e in flat} == {k: sentence_seed(9, i) for i, k in enumerate(items)}


def test_sentence_batch_is_recorded_and_checked(dataset, tmp_path):
    register("batching-test")(_Batching)
    try:
        r = json.loads(_run("batching-test", dataset, tmp_path, sentence_batch=2).read_text())
        assert r["protocol"]["sentence_batch"] == 2
        with pytest.raises(Exception, match="--sentence-batch: expected an integer >= 1, got 0"):
            _run("batching-test", dataset, tmp_path, sentence_batch=0)
    finally:
        unregister("batching-test")


def test_checkpoint_train_then_load(dataset, tmp_path):
    ckpt = tmp_path / "ckpt"
    p1 = _run("mean", dataset, tmp_path, checkpoint=ckpt)
    assert (ckpt / "mean.json").is_file()
    r1 = json.loads(p1.read_text())
    p2 = _run("mean", dataset, tmp_path, checkpoint=ckpt)
    r2 = json.loads(p2.read_text())
    assert r1["timings"]["load_s"] is None and r2["timings"]["train_s"] is None
    assert r1["metrics"] == r2["metrics"]
    # the checkpoint is named by its content too: the digest of the folder's files
    from blendvoca.format.hashing import content_digest

    assert r1["protocol"]["checkpoint_sha256"] == r2["protocol"]["checkpoint_sha256"] == content_digest(ckpt)
    # another method's checkpoint is the user's mistake (exit status 2), not the method's
    with pytest.raises(UserError, match="holds method 'mean', not 'static'"):
        _run("static", dataset, tmp_path, checkpoint=ckpt)


def test_parse_budget_and_config():
    assert cli.parse_budget_text("500") == (500, None)
    assert cli.parse_budget_text("90s") == (None, 90.0)
    assert cli.parse_budget_text("5m") == (None, 300.0)
    assert cli.parse_budget_text("steps=10,seconds=2.5") == (10, 2.5)
    assert cli.budget_limits(argparse.Namespace(budget=None, max_steps=3, max_seconds=None)) == (3, None)
    with pytest.raises(ValueError, match="--budget"):
        cli.parse_budget_text("lots")
    assert cli.parse_config(["a=1", "b=x", "c=[1,2]"], preset="cpu-demo") == {
        "a": 1, "b": "x", "c": [1, 2], "preset": "cpu-demo"}
    with pytest.raises(ValueError, match="KEY=VALUE"):
        cli.parse_config(["novalue"])


def test_sentence_seeds_distinct():
    seeds = {sentence_seed(0, i) for i in range(100)} | {sentence_seed(1, i) for i in range(100)}
    assert len(seeds) == 200


def test_default_data_root_builds_once_into_the_cache(tmp_path, monkeypatch):
    from benchmark.protocol import default_data_root
    from blendvoca.builder import pipeline

    calls = []

    class Summary:
        failures = ()

    def fake_build(out, vocaset):
        calls.append((out, vocaset))
        (out / "manifest.json").parent.mkdir(parents=True, exist_ok=True)
        (out / "manifest.json").write_text("{}")
        return Summary()

    monkeypatch.delenv("BLENDVOCA_DATA", raising=False)
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(pipeline, "build_dataset", fake_build)
    root = default_data_root()
    assert root == tmp_path / "cache" / "blendvoca-default"
    assert calls == [(root, None)]  # None: the bundled synthetic corpus
    assert default_data_root() == root and len(calls) == 1  # built once
    monkeypatch.setenv("BLENDVOCA_DATA", str(tmp_path / "mine"))
    assert default_data_root() == tmp_path / "mine"


class _Slow(Method):
    """Ignores its budget in train / sleeps in generate, as configured."""

    def __init__(self, where="generate"):
        super().__init__(where=where)

    contract = 3

    def train(self, dataset, request):
        if self._config["where"] == "train":
            import time

            end = time.perf_counter() + 30
            while time.perf_counter() < end:  # never looks at the budget
                time.sleep(0.01)

    def generate(self, utterance, *, samples=1, seed=0):
        if self._config["where"] == "generate":
            import time

            time.sleep(30)
        return np.full((samples, utterance.num_frames, 32), 0.5)


def test_runner_enforces_generate_time_limit_and_training_budget(dataset, tmp_path, monkeypatch):
    from benchmark.protocol import training

    register("test-slow")(_Slow)
    try:
        with pytest.raises(MethodTimeout, match="sentence 'sentence01'.*limit of 0.3 s"):
            _run("test-slow", dataset, tmp_path, generate_time_limit=0.3)
        monkeypatch.setattr(training, "TRAIN_GRACE_S", 0.2)
        with pytest.raises(MethodTimeout, match="train"):
            _run("test-slow", dataset, tmp_path, config={"where": "train"}, budget=Budget(max_seconds=0.1))
        # a time budget is recorded as non-deterministic
        path = _run("test-slow", dataset, tmp_path, config={"where": "nowhere"}, budget=Budget(max_seconds=5))
        assert json.loads(path.read_text())["protocol"]["deterministic"] is False
    finally:
        unregister("test-slow")


class _Stuck(Method):
    """A plug-in whose ``generate`` never returns (``sleep`` seconds, if given, then answers)."""

    def __init__(self, sleep=None):
        super().__init__(sleep=sleep)

    contract = 3

    def train(self, dataset, request):
        pass

    def generate(self, utterance, *, samples=1, seed=0):
        import time

        if self._config["sleep"] is not None:
            time.sleep(self._config["sleep"])
        else:
            while True:
                time.sleep(0.05)
        return np.full((samples, utterance.num_frames, 32), 0.5)


@pytest.fixture()
def stuck_method():
    register("test-stuck")(_Stuck)
    yield
    unregister("test-stuck")


def test_a_generate_that_never_returns_is_stopped_by_the_default_limit(dataset, tmp_path, monkeypatch, capsys,
                                                                        stuck_method):
    from benchmark.protocol import GenerateLimit, limits

    _cli_on(dataset, monkeypatch)
    # the default's shape (fixed part + part per second of audio), made small so that the test is fast
    monkeypatch.setattr(limits, "DEFAULT_GENERATE_LIMIT", GenerateLimit(base_s=0.1, per_audio_second_s=0.1))
    assert _cli(tmp_path, "--method", "test-stuck") == 3
    _one_error_line(capsys, "the method misbehaved", "method 'test-stuck'", "subject 'D'", "sentence 'sentence01'",
                    "0.1 s + 0.1 s per second of audio")
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())
    # 0: no limit, for a method that takes longer than the default allows
    assert _cli(tmp_path, "--method", "test-stuck", "--config", "sleep=0.35", "--generate-time-limit", "0") == 0
    (path,) = (tmp_path / "r").glob("test-stuck*.json")
    assert json.loads(path.read_text())["protocol"]["generate_time_limit"] is None
    capsys.readouterr()
    # a limit given in seconds is per call, whatever the audio's length
    assert _cli(tmp_path, "--method", "test-stuck", "--generate-time-limit", "0.2") == 3
    _one_error_line(capsys, "exceeded the limit of 0.2 s")


def test_cli_runs_a_method_named_as_module_and_class(dataset, tmp_path, monkeypatch, capsys):
    _cli_on(dataset, monkeypatch)
    target = f"{_Stuck.__module__}:_Stuck"  # a plug-in nobody registered
    assert _cli(tmp_path, "--method", target, "--config", "sleep=0") == 0, capsys.readouterr().err
    (path,) = (tmp_path / "r").glob("*.json")
    assert json.loads(path.read_text())["method"]["name"] == target
    capsys.readouterr()
    assert _cli(tmp_path, "--method", "no_such_pkg.mod:Thing") == 2
    _one_error_line(capsys, "cannot import module 'no_such_pkg.mod'")


def test_the_default_generate_limit_is_generous_and_in_the_help(capsys):
    from benchmark.protocol import DEFAULT_GENERATE_LIMIT, generate_limit

    assert generate_limit(None) == DEFAULT_GENERATE_LIMIT and generate_limit(0) is None
    assert DEFAULT_GENERATE_LIMIT.seconds(4.0) == 120 + 60 * 4.0
    with pytest.raises(SystemExit):
        main(["--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert "120 s + 60 s per second of audio" in help_text and "0: no limit" in help_text


@pytest.mark.parametrize("argv, message", [
    (["--method", "mean", "--data", "/no/such/dir"], "--data /no/such/dir: no such folder"),
    (["--method", "mean", "--samples", "many"], "--samples"),
    (["--method", "mean", "--vocaset", "/no/such/corpus"], "--vocaset"),
])
def test_cli_user_mistakes_are_one_error_line(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert exit_info.value.code == 2 and len(err) == 1 and err[0].startswith("error: ") and message in err[0]


def test_cli_results_must_be_a_writable_folder(dataset, tmp_path, monkeypatch, capsys):
    from benchmark.protocol import spec

    monkeypatch.setattr(spec, "_open_default", lambda root: dataset)
    (tmp_path / "file").write_text("x")
    for argv in (["--results", str(tmp_path / "file")], ["--split", "nope", "--results", str(tmp_path / "r")],
                 ["--budget", "5 parsecs", "--results", str(tmp_path / "r")]):
        assert main(["--method", "mean", "--data", str(tmp_path), "--quiet", *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: "), err


class _Tunable(Method):
    """A trained state in a file, and one sampling option (``level``)."""

    sampling_options = ("level",)

    def __init__(self, level=0.5, width=1):
        super().__init__(level=level, width=width)
        self.trained = False

    contract = 3

    def train(self, dataset, request):
        self.trained = True

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((1, utterance.num_frames, 32), self.config()["level"])

    def save(self, directory):
        super().save(directory)
        (directory / "state.txt").write_text("trained")

    @classmethod
    def load(cls, directory):
        method = super().load(directory)
        method.trained = (directory / "state.txt").read_text() == "trained"
        return method

    def with_sampling_options(self, **options):
        twin = type(self)(**{**self.config(), **options})
        twin.trained = self.trained
        return twin


def test_a_loaded_checkpoint_takes_sampling_options_and_refuses_other_config(dataset, tmp_path):
    from benchmark.protocol import prepared_method

    register("test-tunable")(_Tunable)
    try:
        ckpt = tmp_path / "ckpt"
        trained, _ = prepared_method("test-tunable", {}, dataset, seed=0, budget=Budget(max_steps=1),
                                     checkpoint=ckpt)
        loaded, timings = prepared_method("test-tunable", {"level": 0.25, "width": 1}, dataset, seed=0,
                                          budget=Budget(max_steps=1), checkpoint=ckpt)
        assert timings["train_s"] is None and loaded.trained
        assert loaded.config() == {"level": 0.25, "width": 1}
        # the result file records the option that sampled
        path = _run("test-tunable", dataset, tmp_path, checkpoint=ckpt, config={"level": 0.75})
        assert json.loads(path.read_text())["method"]["config"]["level"] == 0.75
        # a config the checkpoint was not trained with is the user's mistake (exit status 2)
        with pytest.raises(UserError, match=r"--config width=2 differs from the checkpoint .*trained with "
                                              r"width=1.*here: \['level'\]"):
            prepared_method("test-tunable", {"width": 2}, dataset, seed=0, budget=Budget(max_steps=1),
                            checkpoint=ckpt)
    finally:
        unregister("test-tunable")
    # a method without sampling options refuses any changed key
    ckpt = tmp_path / "mean-ckpt"
    _run("mean", dataset, tmp_path, checkpoint=ckpt)
    with pytest.raises(UserError, match=r"--config split='val' differs .*trained with split='train'.*here: none"):
        _run("mean", dataset, tmp_path, checkpoint=ckpt, config={"split": "val"})


def test_the_base_method_has_no_sampling_options():
    class Plain(Method):
        def generate(self, utterance, *, samples=1, seed=0):
            raise NotImplementedError

    plain = Plain()
    assert plain.with_sampling_options() is plain
    with pytest.raises(ValueError, match=r"\['speed'\] are not sampling options"):
        plain.with_sampling_options(speed=2)


class _Chatty(Method):
    """Draws its own tqdm bars in train and generate, as the built-in plug-ins do."""

    contract = 3

    def train(self, dataset, request):
        from tqdm.auto import tqdm

        for _ in tqdm(range(3), desc="chatty training", disable=not show_progress()):
            pass

    def generate(self, utterance, *, samples=1, seed=0):
        from tqdm import tqdm

        for _ in tqdm(range(2), desc="chatty sampling", disable=not show_progress()):
            pass
        return np.full((samples, utterance.num_frames, 32), 0.5)


@pytest.mark.parametrize("progress", [False, True])
def test_quiet_runs_silence_the_plugins_own_bars(progress, dataset, tmp_path, capsys):
    register("test-chatty")(_Chatty)
    try:
        with progress_bars(progress):  # as benchmark.run --quiet sets it
            run(RunSpec("test-chatty", data_root="unused", samples=1, results_dir=tmp_path / "results"),
                evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    finally:
        unregister("test-chatty")
    err = capsys.readouterr().err
    assert ("chatty training" in err and "chatty sampling" in err) is progress
    assert ("chatty" in err) is progress
    assert show_progress()  # the runner's setting ends with the run


# ----------------------------------------------------------------------------- whose fault: exit status 2 or 3


class _Released(Method):
    """Loads released weights: an ``.npy`` of 32 levels (``bug=True``: its loader has a bug)."""

    def __init__(self, level=0.5, bug=False):
        super().__init__(level=level, bug=bug)

    @classmethod
    def from_official_checkpoint(cls, path, **config):
        if config.get("bug"):
            raise AttributeError("'NoneType' object has no attribute 'levels'")
        levels = np.load(path, allow_pickle=False)
        if levels.shape != (32,):
            raise ValueError(f"{path}: expected 32 levels, got shape {levels.shape}")
        return cls(**{**config, "level": float(levels.mean())})

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((1, utterance.num_frames, 32), self.config()["level"])


class _Fragile(Method):
    """Saves a checkpoint its own ``load`` then fails on."""

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((1, utterance.num_frames, 32), 0.5)

    @classmethod
    def load(cls, directory):
        raise RuntimeError("index out of sync with the weights")


@pytest.fixture()
def checkpoint_methods():
    register("test-released")(_Released)
    register("test-fragile")(_Fragile)
    yield
    unregister("test-released")
    unregister("test-fragile")


def _cli(tmp_path, *argv):
    return main(["--data", str(tmp_path), "--results", str(tmp_path / "r"), "--quiet", *map(str, argv)])


def _one_error_line(capsys, *fragments):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    assert all(f in err[0] for f in fragments), err[0]
    return err[0]


def test_cli_a_bad_checkpoint_is_a_user_error(dataset, tmp_path, monkeypatch, capsys, checkpoint_methods):
    _cli_on(dataset, monkeypatch)
    text = tmp_path / "notes.txt"
    text.write_text("not weights\n")
    assert _cli(tmp_path, "--method", "mean", "--checkpoint", text) == 2  # mean reads no released weights
    _one_error_line(capsys, "is a file, but this method loads only directories")
    assert _cli(tmp_path, "--method", "test-released", "--checkpoint", text) == 2  # not a weights file
    _one_error_line(capsys, "--checkpoint", "cannot load this file", "pickled (object) data")
    wrong = tmp_path / "wrong.npy"
    np.save(wrong, np.zeros(7))
    assert _cli(tmp_path, "--method", "test-released", "--checkpoint", wrong) == 2  # another method's weights
    _one_error_line(capsys, "expected 32 levels")
    cut = tmp_path / "cut.npz"
    np.savez(cut, levels=np.zeros(32))
    cut.write_bytes(cut.read_bytes()[:40])
    assert _cli(tmp_path, "--method", "test-released", "--checkpoint", cut) == 2
    _one_error_line(capsys, "damaged zip archive")
    assert _cli(tmp_path, "--method", "mean", "--checkpoint", text / "ckpt") == 2  # cannot be made: before training
    _one_error_line(capsys, "is a file, so no folder can be made there")
    static = tmp_path / "static-ckpt"
    assert _cli(tmp_path, "--method", "static", "--checkpoint", static) == 0
    capsys.readouterr()
    assert _cli(tmp_path, "--method", "mean", "--checkpoint", static) == 2  # another method's folder
    _one_error_line(capsys, "holds method 'static', not 'mean'")
    stray = tmp_path / "stray"
    stray.mkdir()
    (stray / "weights.bin").write_bytes(b"\0" * 8)
    assert _cli(tmp_path, "--method", "mean", "--checkpoint", stray) == 2  # a folder of no method
    _one_error_line(capsys, "not a method checkpoint (no method_config.json)")
    assert not list((tmp_path / "r").glob("mean*"))
    good = tmp_path / "good.npy"
    np.save(good, np.full(32, 0.25))
    assert _cli(tmp_path, "--method", "test-released", "--checkpoint", good) == 0
    (path,) = (tmp_path / "r").glob("test-released*.json")
    assert json.loads(path.read_text())["method"]["config"] == {"level": 0.25, "bug": False}


def test_cli_a_method_failing_on_its_own_checkpoint_misbehaved(dataset, tmp_path, monkeypatch, capsys,
                                                               checkpoint_methods):
    _cli_on(dataset, monkeypatch)
    own = tmp_path / "fragile-ckpt"
    assert _cli(tmp_path, "--method", "test-fragile", "--checkpoint", own) == 0  # trained and saved
    capsys.readouterr()
    assert _cli(tmp_path, "--method", "test-fragile", "--checkpoint", own) == 3
    _one_error_line(capsys, "the method misbehaved", "load from", "RuntimeError: index out of sync")
    good = tmp_path / "good.npy"
    np.save(good, np.full(32, 0.25))
    assert _cli(tmp_path, "--method", "test-released", "--checkpoint", good, "--config", "bug=true") == 3
    _one_error_line(capsys, "the method misbehaved", "AttributeError")


class _MissingFile:
    """``dataset`` with a file gone after the build: reading ``reader`` of ``key`` raises
    ``error`` from its ``after + 1``-th read on."""

    def __init__(self, dataset, reader, key, error, after=0):
        self._dataset, self._reader, self._key, self._error, self._after = dataset, reader, key, error, after
        self._reads = 0

    def __getattr__(self, name):
        value = getattr(self._dataset, name)
        if name != self._reader:
            return value

        def read(subject, sentence):
            if (subject, sentence) == self._key:
                self._reads += 1
                if self._reads > self._after:
                    raise self._error
            return value(subject, sentence)

        return read


@pytest.mark.parametrize("reader, key, error, after, fragment", [
    # training reads the train split (the mean of its tracks)
    ("coeffs", ("A", "sentence02"), "data", 0, "A/sentence02.csv"),
    ("coeffs", ("B", "sentence01"), "missing", 0, "No such file or directory"),
    # generating reads the test split's audio and frame counts
    ("audio", ("E", "sentence01"), "missing", 0, "No such file or directory"),
    ("coeffs", ("D", "sentence02"), "data", 0, "D/sentence02.csv"),
    # scoring reads the ground truth again
    ("coeffs", ("E", "sentence02"), "data", 1, "E/sentence02.csv"),
    ("coeffs", ("E", "sentence02"), "missing", 1, "No such file or directory"),
])
def test_cli_a_build_file_gone_after_the_build_is_a_data_error(reader, key, error, after, fragment, dataset,
                                                               tmp_path, monkeypatch, capsys):
    from blendvoca.errors import DataError

    path = f"/build/blendshape_coeffs/{key[0]}/{key[1]}.csv"
    error = {"data": DataError(f"{path}: row 7 has 3 fields, the header has 32"),
             "missing": FileNotFoundError(2, "No such file or directory", path)}[error]
    _cli_on(_MissingFile(dataset, reader, key, error, after), monkeypatch)
    assert _cli(tmp_path, "--method", "mean") == 2
    line = _one_error_line(capsys, fragment)
    assert "misbehaved" not in line
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())
