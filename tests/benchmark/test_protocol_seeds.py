"""Training seeds in the protocol (``benchmark.run --seeds``, ``RunSpec(seeds=...)``,
``benchmark.protocol.seeds``) and the half-budget convergence check of every run
(``benchmark.protocol.convergence``): one result over the seeds, each seed's run as
``--seed k`` gives it, two-level intervals, bad input refused before anything trains,
and settled or not recorded."""

import json
import re
import zlib

import numpy as np
import pytest

from benchmark.evaluation import Scores
from benchmark.methods import Method, TrainingRequest, register, unregister
from benchmark.metrics.bootstrap import (
    bootstrap_indices,
    interval,
    mean_replicates,
    two_level_mean_replicates,
    two_level_replicates,
)
from benchmark.protocol import (
    NOT_CHECKED,
    SeedRun,
    UsageError,
    combined_seed_scores,
    convergence_record,
    RunSpec,
    parse_seeds,
    run,
)
from benchmark.protocol.convergence import HalfBudget, combined_convergence
from benchmark.run import main
from benchmark.runs import read_run
from tests.methods.fakes import speech_dataset

TRAINED = []  # (seed, budget steps) of every Stepper.train call


class Stepper(Method):
    """Trains in steps towards the truth level 0.05 (from a seed-dependent start) and makes
    the half-budget call; generates its level plus a little seeded noise."""

    stochastic = True

    def __init__(self, rate=0.3, mode="ok"):
        super().__init__(rate=rate, mode=mode)
        self.level = None

    contract = 3

    def train(self, dataset, request):
        seed, budget = request.seed, request.budget
        TRAINED.append((seed, budget.max_steps))
        if self._config["mode"] == "fail-seed-1" and seed == 1:
            raise RuntimeError("seed 1 fails")
        self.level = 0.5 + 0.1 * seed
        steps = budget.steps(8)
        for step in range(1, steps + 1):
            self.level += self._config["rate"] * (0.05 - self.level)
            if step in request.checkpoint_steps(steps):
                request.on_checkpoint(step)

    def generate(self, utterance, *, samples=1, seed=0):
        rng = np.random.default_rng(seed)
        noise = rng.normal(scale=0.01, size=(samples, utterance.num_frames, 32))
        return np.clip(self.level + noise, 0, 1)


class OldStepper(Stepper):
    """A plug-in written before contract v3: its train takes seed= and budget=, no request."""

    def train(self, dataset, *, seed, budget):
        super().train(dataset, TrainingRequest(seed=seed, budget=budget))


EVALUATIONS = []  # the metrics= of every fake evaluation


def fake_scores(generated, dataset, split="test", metrics=None):
    """``lve_rig``: per-sentence mean |error| x 1000 (sentence level); ``fd``: the squared
    mean error x 100 over the set, with sentence-bootstrap replicates (set level)."""
    EVALUATIONS.append(metrics)
    keys = list(generated)
    errors = np.array([np.abs(generated[k] - dataset.coeffs(*k)[None]).mean() for k in keys])
    signed = np.array([(generated[k] - dataset.coeffs(*k)[None]).mean() for k in keys])
    lve = errors * 1000
    rows_lve = lve[bootstrap_indices(len(lve), 1000, zlib.crc32(b"lve_rig"))].mean(axis=1)
    fd = float(signed.mean() ** 2 * 100)
    fd_reps = (signed[bootstrap_indices(len(signed), 50, 1)].mean(axis=1) ** 2) * 100
    entries = {
        "lve_rig": {"mean": float(lve.mean()), "std": float(lve.std(ddof=1)), "ci95": interval(rows_lve, lve.mean()),
                    "n": len(keys), "higher_is_better": False, "unit": "mm", "label": "LVE rig", "group": "vertex"},
        "fd": {"mean": fd, "std": None, "ci95": interval(fd_reps, fd), "n": len(keys), "higher_is_better": False,
               "unit": "latent^2", "label": "FD", "group": "distribution", "replicates": [float(v) for v in fd_reps]},
    }
    if metrics is not None:
        entries = {k: v for k, v in entries.items() if k in metrics}
    rows = [{"subject": k[0], "sentence": k[1], **({"lve_rig": float(v)} if "lve_rig" in entries else {})}
            for k, v in zip(keys, lve)]
    scores = Scores(entries, rows)
    scores.replicates = {"lve_rig": rows_lve, "fd": fd_reps}
    scores.protocol = {"fd_floor_probe": 1.5}
    return scores


@pytest.fixture(scope="module", autouse=True)
def registered():
    register("test-stepper")(Stepper)
    register("test-old-stepper")(OldStepper)
    yield
    unregister("test-stepper")
    unregister("test-old-stepper")


@pytest.fixture(scope="module")
def dataset():
    return speech_dataset(seed=3, sentences=3, seconds=1.0)


def _run(dataset, results, method="test-stepper", **kw):
    kw.setdefault("samples", 2)
    kw.setdefault("budget", None)
    return run(RunSpec(method, data_root="unused", results_dir=results, **kw),
               evaluate=fake_scores, open_dataset=lambda root: dataset)


def test_one_result_over_the_seeds_each_seed_as_its_own_run(dataset, tmp_path):
    from benchmark.methods import Budget

    path = _run(dataset, tmp_path / "seeds", seeds=[0, 1, 2], budget=Budget(max_steps=6))
    assert "__s2__seeds0-1-2__c" in path.name  # not a plain run: its settings digest (issue 56)
    result = json.loads(path.read_text())
    assert result["seeds"] == [0, 1, 2] and result["protocol"]["seeds"] == [0, 1, 2]
    assert result["protocol"]["seed"] == 0 and result["protocol"]["fd_floor_probe"] == 1.5
    assert result["protocol"]["convergence_check"] == "checked"
    from benchmark.protocol.generation import LATENCY_FIELDS
    from benchmark.results import LOOKAHEAD_FIELDS

    # measured like a single-seed run's (the first seed's), the look-ahead probe included
    assert set(result["latency"]) == set(LATENCY_FIELDS + LOOKAHEAD_FIELDS)
    per_seed = result["per_seed"]
    assert [p["seed"] for p in per_seed] == [0, 1, 2]
    for k, record in enumerate(per_seed):
        single = json.loads(_run(dataset, tmp_path / f"seed{k}", seed=k, budget=Budget(max_steps=6)).read_text())
        assert record["metrics"] == {name: entry["mean"] for name, entry in single["metrics"].items()}
        assert record["per_sentence"] == single["per_sentence"]
        assert record["convergence"] == single["convergence"]
        assert set(record["replicates"]) == {"fd"}  # the set-level metrics only
        assert record["replicates"]["fd"] == pytest.approx(single["metrics"]["fd"]["replicates"], rel=1e-6)
        assert record["tracks"] == f"{path.stem}/seed{k}"
        # the seed's stored tracks are those of its own run
        mine, alone = read_run(path), read_run(next((tmp_path / f"seed{k}").glob("*.json")))
        assert mine.tracks_dir == (path.parent / per_seed[0]["tracks"]).resolve()  # the JSON's tracks: seed 0
        mine.tracks_dir = path.parent / record["tracks"]
        assert mine.keys == alone.keys
        assert all(np.array_equal(mine.tracks(*key), alone.tracks(*key)) for key in mine.keys)
    for name, entry in result["metrics"].items():
        means = [p["metrics"][name] for p in per_seed]
        assert entry["mean"] == pytest.approx(np.mean(means)) and entry["seed_range"] == [min(means), max(means)]
        assert entry["n_seeds"] == 3 and entry["ci95"][0] <= entry["mean"] <= entry["ci95"][1]
    rows = result["per_sentence"]
    assert [(r["subject"], r["sentence"]) for r in rows] == [(r["subject"], r["sentence"])
                                                             for r in per_seed[0]["per_sentence"]]
    for j, row in enumerate(rows):
        assert row["lve_rig"] == pytest.approx(np.mean([p["per_sentence"][j]["lve_rig"] for p in per_seed]))
    convergence = result["convergence"]
    assert convergence["checked_at_step"] == 3 and convergence["total_steps"] == 6
    assert convergence["settled"] == all(p["convergence"]["settled"] for p in per_seed) and \
        convergence["settled"] == all(m["settled"] for m in convergence["metrics"].values())
    # the row's learning curve: per step (1 and 3 of 6) the seed means; each seed's keeps its per-sentence values
    assert [p["step"] for p in convergence["curve"]] == [1, 3] and "sentences" not in convergence
    for i, point in enumerate(convergence["curve"]):
        assert set(point) == {"step", "metrics"}
        for name, value in point["metrics"].items():
            assert value == pytest.approx(np.mean([p["convergence"]["curve"][i]["metrics"][name] for p in per_seed]))
    assert all(len(p["convergence"]["curve"][1]["per_sentence"]["lve_rig"]) == len(rows) for p in per_seed)
    assert result["timings"]["convergence_s"] is not None and len(per_seed[0]["timings"]) == 5
    # the folder: the JSON and one tracks folder with a subfolder per seed, nothing staged left
    assert sorted(p.name for p in (tmp_path / "seeds").iterdir()) == [path.stem, path.name]
    assert sorted(p.name for p in (tmp_path / "seeds" / path.stem).iterdir()) == ["seed0", "seed1", "seed2"]


def test_the_half_budget_check_scores_two_metrics_and_changes_nothing(dataset, tmp_path):
    from benchmark.methods import Budget

    EVALUATIONS.clear()
    path = _run(dataset, tmp_path / "a", seed=1, budget=Budget(max_steps=10))
    # the learning curve's calls (a quarter and half of the steps), then the full evaluation
    assert EVALUATIONS == [("lve_rig", "fd"), ("lve_rig", "fd"), None]
    result = json.loads(path.read_text())
    convergence = result["convergence"]
    assert convergence["checked_at_step"] == 5 and convergence["total_steps"] == 10
    # the curve: steps 2 and 5, with what the tables' paired resampling reads at each
    curve = convergence["curve"]
    assert [p["step"] for p in curve] == [2, 5]
    assert convergence["sentences"] == [[r["subject"], r["sentence"]] for r in result["per_sentence"]]
    for point in curve:
        assert np.mean(point["per_sentence"]["lve_rig"]) == pytest.approx(point["metrics"]["lve_rig"])
        assert len(point["replicates"]["fd"]) == 50 and "fd" not in point["per_sentence"]
    assert curve[1]["metrics"] == {k: m["half_budget"] for k, m in convergence["metrics"].items()}
    assert curve[0]["metrics"]["lve_rig"] > curve[1]["metrics"]["lve_rig"] > result["metrics"]["lve_rig"]["mean"]
    # the checkpoint at step 5 is the model a 5-step run trains: the same per-sentence values
    five = json.loads(_run(dataset, tmp_path / "five", seed=1, budget=Budget(max_steps=5)).read_text())
    assert curve[1]["per_sentence"]["lve_rig"] == pytest.approx([r["lve_rig"] for r in five["per_sentence"]])
    assert curve[1]["replicates"]["fd"] == pytest.approx(five["metrics"]["fd"]["replicates"])
    assert set(convergence["metrics"]) == {"lve_rig", "fd"}
    for name, m in convergence["metrics"].items():
        entry = result["metrics"][name]
        assert m["full_budget"] == entry["mean"]
        assert m["half_width"] == pytest.approx((entry["ci95"][1] - entry["ci95"][0]) / 2)
        assert m["settled"] == (abs(m["full_budget"] - m["half_budget"]) <= m["half_width"])
        assert m["half_budget"] > m["full_budget"]  # half-trained: further from the truth
    assert convergence["settled"] is False  # the level still moves a lot between steps 5 and 10
    assert result["timings"]["convergence_s"] >= 0 and result["protocol"]["convergence_check"] == "checked"
    assert result["protocol"]["fd_floor_probe"] == 1.5  # what the evaluation attached (Scores.protocol)
    # the old plug-in trains the same model: the check changed nothing
    old = json.loads(_run(dataset, tmp_path / "b", method="test-old-stepper", seed=1,
                          budget=Budget(max_steps=10)).read_text())
    assert old["metrics"] == result["metrics"] and old["per_sentence"] == result["per_sentence"]
    assert "convergence" not in old and old["timings"]["convergence_s"] is None
    assert old["protocol"]["convergence_check"] == NOT_CHECKED["old_plugin"]
    assert list((tmp_path / "a").glob(".half-budget*")) == []


def test_runs_without_the_check_say_why(dataset, tmp_path):
    from benchmark.methods import Budget

    timed = json.loads(_run(dataset, tmp_path / "t", budget=Budget(max_steps=10, max_seconds=60.0)).read_text())
    assert "convergence" not in timed and timed["protocol"]["convergence_check"] == NOT_CHECKED["time"]
    reference = json.loads(_run(dataset, tmp_path / "r", method="mean").read_text())
    assert "convergence" not in reference and reference["protocol"]["convergence_check"] == NOT_CHECKED["untrained"]
    one_step = json.loads(_run(dataset, tmp_path / "o", budget=Budget(max_steps=1)).read_text())
    assert "convergence" not in one_step and one_step["protocol"]["convergence_check"] == NOT_CHECKED["no_call"]


def test_a_failing_check_stops_the_run_with_its_own_error(dataset, tmp_path):
    from benchmark.methods import Budget
    from blendvoca.errors import MethodOutputError

    class Wild(Stepper):
        def generate(self, utterance, *, samples=1, seed=0):
            if self.level > 0.1:  # half-trained: out of range
                return np.full((samples, utterance.num_frames, 32), 1.5)
            return super().generate(utterance, samples=samples, seed=seed)

    register("test-wild")(Wild)
    try:
        with pytest.raises(MethodOutputError, match=r"outside \[0, 1\]"):
            _run(dataset, tmp_path / "w", method="test-wild", budget=Budget(max_steps=8))
    finally:
        unregister("test-wild")
    assert not any((tmp_path / "w").iterdir())


def test_a_failing_seed_leaves_nothing(dataset, tmp_path):
    from benchmark.methods import MethodError

    with pytest.raises(MethodError, match="seed 1 fails"):
        _run(dataset, tmp_path / "f", seeds=[0, 1], config={"mode": "fail-seed-1"})
    assert list((tmp_path / "f").iterdir()) == []


def test_each_seed_saved_in_its_own_checkpoint_folder(dataset, tmp_path):
    _run(dataset, tmp_path / "r", seeds=[3, 4], checkpoint=tmp_path / "ckpt")
    assert sorted(p.name for p in (tmp_path / "ckpt").iterdir()) == ["seed3", "seed4"]
    with pytest.raises(UsageError, match="--checkpoint .* is not empty"):  # now loaded: nothing would train
        _run(dataset, tmp_path / "r2", seeds=[3, 4], checkpoint=tmp_path / "ckpt")


@pytest.mark.parametrize("kwargs, pattern", [
    ({"seeds": [0, 1, 0]}, "seed 0 is given twice"),
    ({"seeds": [0, "1"]}, "expected integers >= 0"),
    ({"seeds": [0, 1.5]}, "expected integers >= 0"),
    ({"seeds": [-1, 2]}, "expected integers >= 0"),
    ({"seeds": []}, "at least one seed"),
    ({"seeds": "0,1"}, "expected a list of integers"),
    ({"seeds": [0, 1], "seed": 1}, "not allowed with --seed"),
    ({"seeds": [0, 1], "method": "mean"}, "does not train .*reference"),
    ({"seeds": [0, 1], "method": "static"}, "does not train"),
])
def test_bad_seeds_are_refused_before_anything_trains(dataset, tmp_path, kwargs, pattern):
    TRAINED.clear()
    method = kwargs.pop("method", "test-stepper")
    with pytest.raises(UsageError, match=pattern):
        _run(dataset, tmp_path / "r", method=method, **kwargs)
    assert TRAINED == []
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())


def test_seeds_refused_for_released_weights_and_a_method_that_learns_nothing(dataset, tmp_path):
    weights = tmp_path / "weights.pth"
    weights.write_bytes(b"weights")
    with pytest.raises(UsageError, match="weights file, which trains nothing"):
        _run(dataset, tmp_path / "r", seeds=[0, 1], checkpoint=weights)

    class Fitter(Stepper):
        learns = False

    register("test-fitter")(Fitter)
    try:
        with pytest.raises(UsageError, match="learns nothing"):
            _run(dataset, tmp_path / "r", method="test-fitter", seeds=[0, 1])
    finally:
        unregister("test-fitter")


def _cli(dataset, monkeypatch):
    import benchmark.protocol.spec as spec_module

    monkeypatch.setattr(spec_module, "_open_default", lambda root, vocaset=None: dataset)
    monkeypatch.setattr(spec_module, "_check_evaluation_assets", lambda *a: None)


@pytest.mark.parametrize("argv, pattern", [
    (["--seeds", "0,1,1"], "seed 1 is given twice"),
    (["--seeds", "0,x"], "expected comma-separated integers"),
    (["--seeds", "0,1.0"], "expected comma-separated integers"),
    (["--seeds", "0,,1"], "expected comma-separated integers"),
    (["--seed", "1", "--seeds", "0,1"], "not allowed with argument --seed"),
    (["--seeds", "0,1", "--method", "ground-truth"], "does not train"),
])
def test_cli_bad_seeds_one_error_line_exit_2(dataset, tmp_path, monkeypatch, capsys, argv, pattern):
    _cli(dataset, monkeypatch)
    TRAINED.clear()
    if "--method" not in argv:
        argv = ["--method", "test-stepper", *argv]
    try:
        rc = main([*argv, "--data", str(tmp_path), "--results", str(tmp_path / "r"), "--quiet"])
    except SystemExit as exit:  # argparse's usage errors (blendvoca.cli: one line, exit 2)
        rc = exit.code
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("error:"), err
    assert pattern.split(".*")[0] in err[0]
    assert TRAINED == []
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())


def test_parse_seeds():
    assert parse_seeds("0,1,2") == (0, 1, 2) and parse_seeds(" 4, 2 ") == (4, 2) and parse_seeds("7") == (7,)
    for bad in ("", "a", "1,-2", "1e3", "+1"):
        with pytest.raises(UsageError):
            parse_seeds(bad)


# -- combined_seed_scores on its own -------------------------------------------------------------------------

def _seed_run(seed, lve, fd_reps, fd=None, convergence=None, keys=None):
    """A SeedRun with per-sentence ``lve`` values and FD replicates ``fd_reps``."""
    lve = np.asarray(lve, dtype=float)
    keys = keys or [("S", f"sentence{j:02d}") for j in range(len(lve))]
    reps = mean_replicates(lve, resamples=1000, seed=zlib.crc32(b"lve_rig"))
    fd = float(np.mean(fd_reps)) if fd is None else fd
    metrics = {"lve_rig": {"mean": float(lve.mean()), "std": float(lve.std(ddof=1)),
                           "ci95": interval(reps, lve.mean()), "n": len(lve), "higher_is_better": False,
                           "unit": "mm", "label": "LVE rig", "group": "vertex"},
               "fd": {"mean": fd, "std": None, "ci95": interval(fd_reps, fd), "n": len(lve),
                      "higher_is_better": False, "unit": "latent^2", "label": "FD", "group": "distribution",
                      "replicates": list(fd_reps)}}
    rows = [{"subject": k[0], "sentence": k[1], "lve_rig": float(v)} for k, v in zip(keys, lve)]
    return SeedRun(seed=seed, metrics=metrics, per_sentence=rows, convergence=convergence,
                   replicates={"lve_rig": reps, "fd": np.asarray(fd_reps)})


def test_combined_scores_are_the_two_level_bootstrap_of_the_seeds():
    rng = np.random.default_rng(0)
    runs = [_seed_run(s, rng.normal(2 + 0.3 * s, 0.2, 12), rng.normal(5 + s, 0.5, 200)) for s in range(3)]
    combined = combined_seed_scores(runs, stream=7)
    lve = combined.metrics["lve_rig"]
    matrix = np.array([[r["lve_rig"] for r in run.per_sentence] for run in runs])
    reps = two_level_mean_replicates(matrix, resamples=1000, seed=zlib.crc32(b"lve_rig"), stream=7)
    point = np.mean([run.metrics["lve_rig"]["mean"] for run in runs])
    assert lve["mean"] == pytest.approx(point) and lve["ci95"] == interval(reps, point)
    assert lve["seed_range"] == [min(matrix.mean(axis=1)), max(matrix.mean(axis=1))] and lve["n_seeds"] == 3
    assert lve["std"] == pytest.approx(matrix.mean(axis=0).std(ddof=1)) and "replicates" not in lve
    fd = combined.metrics["fd"]
    fd_reps = two_level_replicates([run.replicates["fd"] for run in runs], resamples=1000, seed=zlib.crc32(b"fd"),
                                   stream=7)
    fd_point = np.mean([run.metrics["fd"]["mean"] for run in runs])
    assert fd["ci95"] == interval(fd_reps, fd_point) and fd["replicates"] == pytest.approx(fd_reps, rel=1e-6)
    assert [r["lve_rig"] for r in combined.per_sentence] == pytest.approx(matrix.mean(axis=0))
    assert [p["seed"] for p in combined.per_seed] == [0, 1, 2]
    assert combined.per_seed[1]["metrics"] == {"lve_rig": runs[1].metrics["lve_rig"]["mean"],
                                               "fd": runs[1].metrics["fd"]["mean"]}
    assert set(combined.per_seed[1]["replicates"]) == {"fd"}
    assert combined.bootstrap == {"resamples": 1000, "stream": 7} and combined.convergence is None
    # seeds that disagree widen the interval beyond the sentence-only one of the seed mean
    sentence_only = interval(mean_replicates(matrix.mean(axis=0), resamples=1000, seed=zlib.crc32(b"lve_rig")),
                             point)
    assert lve["ci95"][1] - lve["ci95"][0] >= sentence_only[1] - sentence_only[0]


def test_one_seed_gives_its_own_sentence_interval_back():
    rng = np.random.default_rng(1)
    run = _seed_run(0, rng.normal(2, 0.3, 15), rng.normal(5, 0.5, 200))
    combined = combined_seed_scores([run])
    assert combined.metrics["lve_rig"]["ci95"] == pytest.approx(run.metrics["lve_rig"]["ci95"])
    assert combined.metrics["lve_rig"]["seed_range"] == [run.metrics["lve_rig"]["mean"]] * 2


def test_without_replicates_the_interval_is_the_envelope_of_the_seeds():
    rng = np.random.default_rng(2)
    runs = [_seed_run(s, rng.normal(2, 0.3, 6), rng.normal(5 + s, 0.5, 50)) for s in range(2)]
    bare = [SeedRun(seed=r.seed, metrics={"fd": {k: v for k, v in r.metrics["fd"].items() if k != "replicates"}},
                    per_sentence=[{"subject": x["subject"], "sentence": x["sentence"]} for x in r.per_sentence])
            for r in runs]
    fd = combined_seed_scores(bare).metrics["fd"]
    assert fd["ci95"] == [min(r.metrics["fd"]["ci95"][0] for r in runs), max(r.metrics["fd"]["ci95"][1] for r in runs)]
    assert "replicates" not in fd


def test_convergence_records_one_seed_and_several():
    entry = {"mean": 2.0, "ci95": [1.8, 2.2]}
    record = convergence_record(HalfBudget(step=30, total_steps=60, values={"lve_rig": 2.15, "fd": 9.0}),
                                {"lve_rig": entry, "fd": {"mean": 5.0, "ci95": [4.0, 7.0]}})
    assert record["checked_at_step"] == 30 and record["total_steps"] == 60
    assert record["metrics"]["lve_rig"] == {"half_budget": 2.15, "full_budget": 2.0,
                                            "half_width": pytest.approx(0.2), "settled": True}
    assert record["metrics"]["fd"]["settled"] is False and record["settled"] is False
    assert convergence_record(None, {"lve_rig": entry}) is None
    assert convergence_record(HalfBudget(step=1, total_steps=2, values={}), {"lve_rig": entry}) is None
    settled = convergence_record(HalfBudget(2, 4, {"lve_rig": 2.1}), {"lve_rig": entry})
    moved = convergence_record(HalfBudget(2, 4, {"lve_rig": 1.9}), {"lve_rig": {"mean": 2.05, "ci95": [1.8, 2.2]}})
    both = combined_convergence([settled, moved], {"lve_rig": {"mean": 2.025, "ci95": [1.5, 2.5]}})
    assert both["metrics"]["lve_rig"]["half_budget"] == pytest.approx(2.0)
    assert both["metrics"]["lve_rig"]["full_budget"] == pytest.approx(2.025)
    assert moved["settled"] and settled["settled"] and both["settled"]
    unsettled = convergence_record(HalfBudget(2, 4, {"lve_rig": 1.0}), {"lve_rig": entry})
    mixed = combined_convergence([settled, unsettled], {"lve_rig": {"mean": 2.0, "ci95": [0.0, 4.0]}})
    assert not mixed["settled"] and not mixed["metrics"]["lve_rig"]["settled"]  # one seed moved: not settled
    assert combined_convergence([settled, None], {"lve_rig": entry}) is None


def test_a_checkpoint_survives_the_reproduce_stages_json_record():
    """leaderboard.executors.stages writes each checkpoint as JSON (dataclasses.asdict) and reads it back."""
    import dataclasses
    from types import SimpleNamespace

    from benchmark.protocol.convergence import checked_convergence

    points = [HalfBudget(1, 4, {"lve_rig": 3.0}, [["S", "a"], ["S", "b"]], {"lve_rig": [2.0, 4.0]}, {}),
              HalfBudget(2, 4, {"lve_rig": 2.5, "fd": 9.0}, [["S", "a"], ["S", "b"]], {"lve_rig": [2.0, 3.0]},
                         {"fd": [8.0, 10.0]})]
    back = [HalfBudget(**json.loads(json.dumps(dataclasses.asdict(p)))) for p in points]
    assert back == points
    seen = SimpleNamespace(result=back[1], called=True, points=back)
    record, reason = checked_convergence(seen, None, {"lve_rig": {"mean": 2.0, "ci95": [1.8, 2.2]},
                                                      "fd": {"mean": 8.5, "ci95": [8.2, 8.8]}})
    assert reason == "checked" and record["checked_at_step"] == 2 and record["sentences"] == [["S", "a"], ["S", "b"]]
    assert record["curve"] == [{"step": 1, "metrics": {"lve_rig": 3.0}, "per_sentence": {"lve_rig": [2.0, 4.0]}},
                               {"step": 2, "metrics": {"lve_rig": 2.5, "fd": 9.0},
                                "per_sentence": {"lve_rig": [2.0, 3.0]}, "replicates": {"fd": [8.0, 10.0]}}]
    assert record["metrics"]["lve_rig"]["half_budget"] == 2.5 and record["metrics"]["fd"]["settled"] is False


@pytest.mark.slow  # two trained and fully scored runs with the VAE
def test_cli_regression_over_two_seeds(fake_dataset_dir, assets_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(assets_dir))
    rc = main(["--method", "regression", "--seeds", "0,1", "--max-steps", "60", "--data", str(fake_dataset_dir),
               "--results", str(tmp_path / "r"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    (path,) = (tmp_path / "r").glob("*.json")
    assert re.search(r"__s1__seeds0-1__c[0-9a-f]{10}\.json$", path.name)  # --max-steps: the settings digest
    result = json.loads(path.read_text())
    assert [p["seed"] for p in result["per_seed"]] == [0, 1] and result["seeds"] == [0, 1]
    assert {"lve_rig", "fd"} <= set(result["metrics"]) and "seed_range" in result["metrics"]["lve_rig"]
    from benchmark.evaluation import dynamics

    set_level = {"fd", "wind", "multimodality", *dynamics.METRICS}  # the split's figures, resampled as a whole
    assert set(result["per_seed"][0]["replicates"]) <= set_level
    assert result["per_seed"][0]["metrics"] != result["per_seed"][1]["metrics"]  # the seeds train other models
    assert result["convergence"]["checked_at_step"] == 30 and result["convergence"]["total_steps"] == 60
    assert all(p["convergence"]["checked_at_step"] == 30 for p in result["per_seed"])
    assert result["timings"]["convergence_s"] > 0
    run = read_run(path)
    assert run.keys and run.tracks(*run.keys[0]).shape[0] == 1
