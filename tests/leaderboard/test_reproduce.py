import pytest

from benchmark.methods import get_method
from leaderboard.reproduce import PLAN


def test_rows_that_share_a_training_differ_only_in_sampling_options():
    groups = {}
    for entry in PLAN:
        if entry.shared_training is not None:
            groups.setdefault(entry.shared_training, []).append(entry)
    assert groups, "the CDFace rows share one training"
    for entries in groups.values():
        first = entries[0]
        options = set(get_method(first.method).sampling_options)
        for entry in entries[1:]:
            assert (entry.method, entry.max_steps, entry.samples) == (first.method, first.max_steps, first.samples)
            changed = {k for k in set(entry.config) | set(first.config) if entry.config.get(k) != first.config.get(k)}
            assert changed and changed <= options, changed


def test_an_unknown_only_row_is_refused_before_any_work(tmp_path, capsys):
    from leaderboard.reproduce import main

    assert main(["--work", str(tmp_path / "w"), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
                 "--only", "nothing", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --only: unknown plan entries ['nothing']")
    assert not (tmp_path / "w").exists()


def test_only_takes_names_comma_separated_and_repeated():
    from leaderboard.reproduce import _entries, _split_names

    assert _split_names(["mean,regression", " said ", "static,"]) == ["mean", "regression", "said", "static"]
    assert _split_names(None) is None
    assert [e.row for e in _entries(_split_names(["mean,regression"]))] == ["mean", "regression"]
    # a method name selects each of its rows, a row name one
    assert [e.row for e in _entries(["cdface"])] == ["cdface", "cdface-lips"]
    assert [e.row for e in _entries(["cdface-lips"])] == ["cdface-lips"]


def test_the_plan_corpus_is_the_one_to_many_corpus_with_oracle_rows():
    import inspect

    from blendvoca.synthetic import generate_corpus
    from leaderboard.reproduce import CORPUS, PLAN

    inspect.signature(generate_corpus).bind("out", **CORPUS)  # every key is one of its parameters
    assert CORPUS["audio_determined"] == 0.7 and CORPUS["oracle_samples"] == 8
    rows = {e.row: e for e in PLAN}
    assert rows["oracle-sample"].samples == 8 and "oracle-mean" in rows and "corpus-meshes" in rows
    assert len(rows) == len(PLAN)  # row names are unique


def test_trained_rows_run_per_seed_and_the_cdface_rows_share_their_trainings(tmp_path):
    from leaderboard.reproduce import plan_tasks

    tasks = plan_tasks(tmp_path / "w", tmp_path / "r", only=["mean", "cdface"])
    keys = [t.key for t in tasks]
    assert keys[:3] == ["data", "expert", "row/mean"]
    by_key = {t.key: t for t in tasks}
    for seed in (0, 1, 2):
        train = by_key[f"train/cdface/seed{seed}"]
        assert train.deps == ("data",) and train.spec["config"].get("control") is None  # the owner's config
        assert [r["row"] for r in train.spec["rows"]] == ["cdface", "cdface-lips"]
        for row, owns in (("cdface", True), ("cdface-lips", False)):
            score = by_key[f"score/{row}/seed{seed}"]
            assert score.deps == ("data", "expert", f"train/cdface/seed{seed}")
            assert score.spec["owns_training"] is owns and score.spec["training"] == "cdface"
    assert sum(k.startswith("train/") for k in keys) == 3  # one training per seed for both rows
    # the lips-fixed row's result waits for the owner's, whose half-budget verdict it carries
    assert by_key["store/cdface-lips"].deps == ("data", "expert", *(f"score/cdface-lips/seed{s}" for s in (0, 1, 2)),
                                                "store/cdface")
    assert by_key["store/cdface-lips"].spec["training_owner"]["row"] == "cdface"
    assert by_key["store/cdface"].spec["training_owner"] is None
    assert by_key["store/cdface-lips"].spec["seeds"] == [0, 1, 2]
    assert by_key["row/mean"].spec["seeds"] is None  # a reference row runs once
    assert by_key["score/cdface/seed0"].resources.cpus == 2 and by_key["data"].resources.cpus == 2
    # a step cap lowers every row's budget (quick runs), never raises it
    capped = {t.key: t for t in plan_tasks(tmp_path / "w", tmp_path / "r", only=["regression"], max_steps=40,
                                           seeds=(0,), cpus_per_task=1)}
    assert capped["store/regression"].spec["max_steps"] == 40 and "train/regression/seed1" not in capped
    assert capped["train/regression/seed0"].resources.cpus == 1


def test_the_sequential_executor_imports_no_ray():
    import subprocess
    import sys

    code = ("import sys, leaderboard.reproduce, leaderboard.executors.stages\n"
            "from leaderboard.executors import Task, run_sequential\n"
            "assert run_sequential([Task('a', 'data', lambda spec: (1, None), {})], log=print) == {'a': 1}\n"
            "assert 'ray' not in sys.modules, 'ray imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True)


def _value(spec, *values):
    return spec["value"] + sum(values), None


def test_the_sequential_executor_hands_values_down_in_dependency_order():
    import pytest

    from leaderboard.executors import Task, run_tasks

    tasks = [Task("a", "data", _value, {"value": 1}), Task("b", "expert", _value, {"value": 10}, deps=("a",)),
             Task("c", "store", _value, {"value": 100}, deps=("a", "b"))]
    assert run_tasks(tasks, log=lambda m: None) == {"a": 1, "b": 11, "c": 112}
    with pytest.raises(ValueError, match="depends on"):
        run_tasks(tasks[::-1], log=lambda m: None)


def test_archive_moves_the_old_results_out_of_the_tables_reach(tmp_path):
    import pytest

    from blendvoca.errors import UserError
    from leaderboard.reproduce import archive_results

    results = tmp_path / "results"
    (results / "mean__abc__s1__seed0").mkdir(parents=True)
    (results / "mean__abc__s1__seed0" / "t.csv").write_text("x")
    (results / "mean__abc__s1__seed0.json").write_text("{}")
    (results / "said__abc__s5__seed0.json").write_text("{}")
    archive = tmp_path / "results-archive" / "v2"
    (archive).mkdir(parents=True)
    (archive / "said__abc__s5__seed0.json").write_text("{}")
    with pytest.raises(UserError, match="nothing was moved"):
        archive_results(results, archive)
    assert len(list(results.iterdir())) == 3
    (archive / "said__abc__s5__seed0.json").unlink()
    moved = archive_results(results, archive)
    assert [p.name for p in moved] == ["mean__abc__s1__seed0.json", "said__abc__s5__seed0.json"]
    assert not list(results.iterdir()) and (archive / "mean__abc__s1__seed0" / "t.csv").is_file()


def test_address_needs_the_ray_executor(tmp_path, capsys):
    from leaderboard.reproduce import main

    assert main(["--work", str(tmp_path / "w"), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
                 "--only", "mean", "--address", "auto", "--quiet"]) == 2
    assert "--address: only with --executor ray" in capsys.readouterr().err
    assert not (tmp_path / "w").exists()


def test_timings_are_tabled_per_row_and_stage(tmp_path, capsys):
    import json

    from leaderboard.reproduce import main

    folder = tmp_path / "w" / "stages" / "timings"
    folder.mkdir(parents=True)
    records = [{"key": "train/cdface/seed0", "stage": "train", "row": "cdface", "seed": 0, "wall_s": 600.0,
                "train_s": 420.0, "convergence_s": 180.0},
               {"key": "score/cdface/seed0", "stage": "score", "row": "cdface", "seed": 0, "wall_s": 300.0,
                "generate_s": 120.0, "evaluate_s": 150.0},
               {"key": "row/mean", "stage": "single", "row": "mean", "seed": None, "wall_s": 60.0,
                "generate_s": 6.0, "evaluate_s": 48.0, "train_s": 0.0}]
    for record in records:
        (folder / (record["key"].replace("/", "__") + ".json")).write_text(json.dumps(record))
    assert main(["--work", str(tmp_path / "w"), "--timings"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "| cdface | 0 | 7.0 | 3.0 | 2.0 | 2.5 | 0.5 | 15.0 |" in lines  # the half-budget check apart
    assert "| mean | - | 0.0 | 0.0 | 0.1 | 0.8 | 0.1 | 1.0 |" in lines


def test_timings_of_committed_rows_come_from_their_result_files(tmp_path, capsys):
    from benchmark.results import build_result, write
    from leaderboard.reproduce import main

    prov = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}
    for label, seeds, timings in (
            ("said", [0, 1, 2], {"train_s": 270.0, "convergence_s": 660.0, "generate_s": 510.0,
                                 "evaluate_s": 420.0, "load_s": 0.1, "total_s": 1866.0}),
            ("mean", None, {"train_s": 0.6, "convergence_s": None, "generate_s": 0.3, "evaluate_s": 21.0,
                            "total_s": 22.5})):
        result = build_result(method={"name": label, "label": label, "reference": seeds is None, "config": {}},
                              dataset={"manifest_hash": "h1", "split": "test", "num_sentences": 80},
                              protocol={"samples": 1, "seed": 0},
                              metrics={"fd": {"mean": 1.0, "std": 0.1, "higher_is_better": False, "unit": "latent^2"}},
                              timings=timings, provenance=prov, seeds=seeds)
        write(tmp_path / "results" / result.filename(), result)
    # no work folder left: the result files still give every row's stages (minutes)
    assert main(["--work", str(tmp_path / "gone"), "--results", str(tmp_path / "results"), "--timings"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "| said | 0,1,2 | 4.5 | 11.0 | 8.5 | 7.0 | 0.1 | 31.1 |" in lines
    assert "| mean | - | 0.0 | 0.0 | 0.0 | 0.3 | 0.0 | 0.4 |" in lines


def test_tasks_no_node_can_hold_are_found_before_ray_waits_for_them():
    from leaderboard.executors import Resources, Task
    from leaderboard.executors.ray_executor import _unplaceable

    nodes = [{"Alive": True, "Resources": {"CPU": 2.0, "memory": 8 * 2**30}},
             {"Alive": False, "Resources": {"CPU": 16.0, "GPU": 1.0, "memory": 64 * 2**30}}]
    tasks = [Task("fits", "train", _value, {}, resources=Resources(cpus=2, memory_gb=4)),
             Task("gpu", "train", _value, {}, resources=Resources(cpus=1, gpus=1)),
             Task("big", "train", _value, {}, resources=Resources(cpus=4))]
    assert [t.split(" ")[0] for t in _unplaceable(tasks, nodes)] == ["gpu", "big"]


def test_a_training_that_fails_leaves_no_trained_method_and_no_record(tmp_path):
    import pytest

    from benchmark.protocol import default_data_root
    from blendvoca.errors import UserError
    from leaderboard.executors.stages import train_stage
    from leaderboard.reproduce import plan_tasks

    root = default_data_root()
    task = next(t for t in plan_tasks(tmp_path / "w", tmp_path / "r", only=["regression"], seeds=(0,), max_steps=4)
                if t.stage == "train")
    spec = {**task.spec, "config": {"no_such_option": 1}}  # refused by the run's checks, after the folder is made
    with pytest.raises(UserError):
        train_stage(spec, str(root))
    assert list((tmp_path / "w" / "trained" / "regression").iterdir()) == []
    assert not (tmp_path / "w" / "stages" / "train").exists()


def test_rows_read_the_meshes_of_the_plans_own_corpus_where_the_work_folder_now_is(tmp_path):
    """A work folder moved after its build (the build recorded the old corpus path)
    still gives the rows their mesh-space metrics: they read ``<work>/<corpus>``."""
    from leaderboard.executors import stages
    from leaderboard.reproduce import BUILD_NAME, CORPUS_NAME, plan_tasks

    work = tmp_path / "moved-work"
    (work / CORPUS_NAME).mkdir(parents=True)
    spec = {t.key: t for t in plan_tasks(work, tmp_path / "r", only=["mean"])}["row/mean"].spec
    build = work / BUILD_NAME
    assert stages._source_corpus(spec, build) is None  # no corpus there: the build's recorded one
    (work / CORPUS_NAME / "synthetic.json").write_text("{}")
    assert stages._source_corpus(spec, build) == str((work / CORPUS_NAME).resolve())
    assert stages._source_corpus(spec, tmp_path / "elsewhere" / "build") is None  # --data: its own record


def test_a_row_sharing_a_training_stores_the_owners_verdict_per_seed(tmp_path, monkeypatch):
    from benchmark.protocol.seeds import CombinedScores
    from benchmark.results import build_result, write
    from leaderboard.executors import stages

    def verdict(settled, step=3750):
        return {"checked_at_step": step, "total_steps": 4500, "settled": settled,
                "metrics": {"fd": {"half_budget": 9.0, "full_budget": 3.0, "half_width": 0.5, "settled": settled}}}

    def owner(**parts):
        return build_result(method={"name": "cdface", "config": {}}, dataset={"recipe_id": "r"},
                            protocol={"samples": 1, "seed": 0},
                            metrics={"fd": {"mean": 3.0, "std": None, "higher_is_better": False}},
                            timings={}, provenance={}, **parts)

    owner_file = tmp_path / "owner.json"
    write(owner_file, owner(convergence=verdict(False), per_seed=[{"seed": 0, "convergence": verdict(True)},
                                                                  {"seed": 1, "convergence": verdict(False)}]))
    monkeypatch.setattr(stages, "row_result_path", lambda spec, root: owner_file if spec["row"] == "cdface" else None)
    combined = CombinedScores(metrics={}, per_sentence=[], per_seed=[{"seed": 0, "metrics": {}},
                                                                     {"seed": 1, "metrics": {}}])
    spec = {"row": "cdface-lips", "training_owner": {"row": "cdface"}}
    stored, reason = stages._with_shared_verdict(spec, tmp_path, combined, "not checked: loaded")
    assert stored.convergence == {"shared_with": "cdface", "checked_at_step": 3750, "total_steps": 4500,
                                  "metrics": {}, "settled": False}
    assert [r["convergence"]["settled"] for r in stored.per_seed] == [True, False]
    assert reason == "shared training: checked on row cdface"
    # the owner's file holding other seeds, or missing: nothing is claimed
    write(owner_file, owner(convergence=verdict(False), per_seed=[{"seed": 0}]))
    assert stages._with_shared_verdict(spec, tmp_path, combined, "r") == (combined, "r")
    owner_file.unlink()
    assert stages._with_shared_verdict(spec, tmp_path, combined, "r") == (combined, "r")


def test_seed_scores_pass_between_stages_as_result_json_and_combine_as_before(tmp_path):
    """The score stage writes a seed's scores as a result file (no pickle: a work folder
    holds no code to run); read back, the seeds combine to the same row."""
    from types import SimpleNamespace

    import numpy as np

    from benchmark.protocol import SeedRun
    from benchmark.protocol.seeds import combined_seed_scores
    from benchmark.results import read, write
    from leaderboard.executors import stages

    rng = np.random.default_rng(0)
    keys = [("S1", f"sentence{i:02d}") for i in range(6)]

    def seed_run(seed):
        rows = [{"subject": s, "sentence": q, "lve_rig": float(v)} for (s, q), v in zip(keys, rng.normal(2, 1, 6))]
        mean = float(np.mean([r["lve_rig"] for r in rows]))
        fd = rng.normal(5.0, 0.5, 300)
        metrics = {"lve_rig": {"mean": mean, "std": 0.5, "ci95": [mean - 1, mean + 1], "higher_is_better": False,
                               "unit": "mm", "n": 6, "label": "LVE rig", "group": "vertex"},
                   "fd": {"mean": float(fd.mean()), "std": 0.1, "ci95": [float(fd.min()), float(fd.max())],
                          "higher_is_better": False, "unit": "latent^2", "n": 6, "sample_std": 0.25},
                   "wind": {"mean": 1.0, "std": None, "higher_is_better": False, "unit": "latent^2"}}
        convergence = {"checked_at_step": 5, "total_steps": 10, "settled": True,
                       "metrics": {"fd": {"half_budget": 5.1, "full_budget": 5.0, "half_width": 0.2,
                                          "settled": True}}}
        latency = {"lookahead_s": 0.5, "first_frame_s": 0.01, "compute_per_audio_s": 0.2, "rtf": 0.1 + seed,
                   "measured_lookahead_s": 0.0333,
                   "lookahead_probe": {"probes": [{"subject": "S1", "sentence": "sentence00", "duration_s": 3.0,
                                                   "cut_s": 1.5, "changed_from_s": 1.4667, "lookahead_s": 0.0333,
                                                   "whole_utterance": False}],
                                       "whole_utterance": False, "generate_calls": 3, "wall_s": 0.1,
                                       "tolerance": 1e-6, "frame_s": 0.016667, "note": None}}
        return SeedRun(seed=seed, metrics=metrics, per_sentence=rows,
                       replicates={"fd": fd, "lve_rig": rng.normal(mean, 0.1, 300), "wind": np.array([np.nan])},
                       convergence=convergence, evaluation={"fd_floor_probe": 1.5}, n_clipped=seed, num_subjects=1,
                       num_sentences=6, timings={"train_s": 1.5, "load_s": None, "generate_s": 0.25}, latency=latency)

    spec = {"work": str(tmp_path), "row": "said", "method": "said", "samples": 5}
    inputs = SimpleNamespace(dataset=SimpleNamespace(manifest_hash="h" * 64, recipe_id="r" * 64))
    runs = [seed_run(k) for k in (0, 1, 2)]
    back = []
    for run in runs:
        path, _ = stages._seed_paths(spec, run.seed)
        write(path, stages._seed_result(spec, inputs, run, label="SAiD", reason="checked"))
        assert path.suffix == ".json" and not list(path.parent.glob("*.pkl"))
        result = read(path)
        assert result.label == "SAiD" and result.protocol.convergence_check == "checked"
        back.append(stages._seed_run(result))
    for run, again in zip(runs, back):
        assert again.seed == run.seed and again.per_sentence == run.per_sentence
        assert again.convergence == run.convergence and again.evaluation == run.evaluation
        assert (again.n_clipped, again.num_subjects, again.num_sentences) == (run.seed, 1, 6)
        assert again.metrics == run.metrics
        assert again.latency == run.latency  # issue 54: the row's result stores the first seed's
        for name in ("fd", "lve_rig", "wind"):  # wind: replicates that are not finite are none
            a, b = again.seed_replicates(name), run.seed_replicates(name)
            assert (a is None and b is None) or np.array_equal(a, b)
    expected, got = combined_seed_scores(runs, stream=7), combined_seed_scores(back, stream=7)
    assert got.metrics == expected.metrics and got.per_sentence == expected.per_sentence
    assert got.per_seed == expected.per_seed and got.convergence == expected.convergence


@pytest.mark.parametrize("flag, value, least", [("--expert-steps", "0", 1), ("--expert-steps", "-5", 1),
                                                ("--max-retries", "-1", 0), ("--cpus-per-task", "0", 1)])
def test_counts_below_their_least_are_refused_before_any_work(tmp_path, capsys, flag, value, least):
    """Issue 56: --expert-steps 0 or -5 trained forever; --max-retries -1 reached Ray."""
    from leaderboard.reproduce import main

    with pytest.raises(SystemExit) as info:
        main(["--work", str(tmp_path / "w"), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
              flag, value])
    err = capsys.readouterr().err
    assert info.value.code == 2 and f"{flag}: expected an integer >= {least}, got {value}" in err
    assert not (tmp_path / "w").exists()


@pytest.mark.slow
def test_a_trained_row_made_by_reproduce_stores_a_latency_record(tmp_path):
    """Issue 54: the multi-seed rows ``leaderboard.reproduce`` made stored no ``latency`` (the
    seeds' scores passed between stages without it), so their RTF cell was "-"."""
    import json

    from benchmark.protocol import default_data_root
    from benchmark.results import LATENCY_FIELDS, LOOKAHEAD_FIELDS
    from leaderboard.reproduce import reproduce

    paths = reproduce(tmp_path / "work", tmp_path / "results", tmp_path / "tables", data=default_data_root(),
                      only=["regression"], seeds=(0,), max_steps=5, expert_steps=5)
    result = json.loads(paths[0].read_text())
    assert result["seeds"] == [0]
    latency = result["latency"]
    assert set(latency) == set(LATENCY_FIELDS + LOOKAHEAD_FIELDS)
    assert latency["rtf"] > 0 and latency["measured_lookahead_s"] is not None
    assert latency["lookahead_probe"]["generate_calls"] == 1 + 2 * len(latency["lookahead_probe"]["probes"])
    row = next(line for line in (tmp_path / "tables" / "leaderboard.md").read_text().splitlines()
               if line.startswith("| regression"))
    assert not row.endswith("| - |")  # the RTF column is filled
