"""``leaderboard.reproduce --corpus facegood``: the real board's plan, its refusals, and
(slow) two cheap rows made from the asset files."""

import json

import pytest

from leaderboard.reproduce import CORPORA, FACEGOOD, FACEGOOD_PLAN, PLAN, SYNTHETIC, plan_tasks


def test_the_real_board_plans_every_trainable_method_and_the_reference_rows_with_the_synthetic_budgets(tmp_path):
    assert set(CORPORA) == {"synthetic", "facegood"} and CORPORA["synthetic"].plan is PLAN
    rows = [e.row for e in FACEGOOD_PLAN]
    assert rows == ["ground-truth", "mean", "static", "random", "regression", "said", "faceformer", "codetalker",
                    "cdface", "cdface-lips"]
    synthetic = {e.row: e for e in PLAN}
    for entry in FACEGOOD_PLAN:  # a budget per row: the synthetic board's, until the settled rule picks its own
        assert (entry.max_steps, entry.config, entry.shared_training) == (
            synthetic[entry.row].max_steps, synthetic[entry.row].config, synthetic[entry.row].shared_training)
    tasks = plan_tasks(tmp_path / "w", tmp_path / "r", corpus="facegood")
    by_key = {t.key: t for t in tasks}
    vae = str((tmp_path / "w" / "vae" / f"{FACEGOOD.build_name}.pth").resolve())
    assert by_key["data"].spec["vae"] == vae and by_key["data"].spec["vae_steps"] == FACEGOOD.vae_steps
    for row in ("regression", "said", "faceformer", "codetalker", "cdface", "cdface-lips"):
        assert [by_key[f"score/{row}/seed{k}"].spec["seed"] for k in (0, 1, 2)] == [0, 1, 2]
        assert by_key[f"store/{row}"].spec["seeds"] == [0, 1, 2]
    for row in ("ground-truth", "mean", "static", "random"):
        assert f"row/{row}" in by_key and f"store/{row}" not in by_key
    # every row is scored with the VAE trained on the build, after the data and expert tasks
    rows_tasks = [t for t in tasks if t.stage in ("single", "score", "store", "train")]
    assert rows_tasks and all(t.spec["vae"] == vae and t.deps[0] == "data" for t in rows_tasks)
    assert not any("oracle" in t.key or "corpus-meshes" in t.key for t in tasks)
    # the synthetic board's tasks carry no VAE (the published one scores them, as before)
    assert all("vae" not in t.spec for t in plan_tasks(tmp_path / "w", tmp_path / "r"))
    assert SYNTHETIC.vae_steps is None and SYNTHETIC.asset_ids() == ()


def _main(tmp_path, *args):
    from leaderboard.reproduce import main

    return main(["--work", str(tmp_path / "w"), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
                 "--quiet", *args])


def _nothing_stored(tmp_path):
    return not any((tmp_path / name).exists() for name in ("w", "r", "t"))


def test_a_corpus_without_its_files_is_one_error_line_naming_the_asset_ids(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "empty"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    assert _main(tmp_path, "--corpus", "facegood") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --corpus facegood: its files are not found"), err
    for asset_id in FACEGOOD.asset_ids():  # every missing file by its id, and both ways to provide them
        assert asset_id in err[0]
    assert "facegood-names" in err[0] and "BLENDVOCA_ASSETS" in err[0] and "data_manifest.yaml" in err[0]
    assert "python -m blendvoca.assets fetch facegood-names" in err[0]
    assert _nothing_stored(tmp_path)


def test_a_build_of_another_corpus_is_refused_before_any_work(tmp_path, capsys):
    from benchmark.protocol import default_data_root

    synthetic_build = default_data_root()  # the bundled synthetic build: a VOCASET-layout build
    assert _main(tmp_path, "--corpus", "facegood", "--data", str(synthetic_build)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a build of the vocaset corpus, but --corpus facegood plans rows of FACEGOOD" in err[0]
    assert _nothing_stored(tmp_path)


def test_a_missing_vae_file_and_a_bad_vae_step_count_are_refused(tmp_path, capsys):
    assert _main(tmp_path, "--corpus", "facegood", "--vae", str(tmp_path / "none.pth")) == 2
    assert "error: --vae" in capsys.readouterr().err and _nothing_stored(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        _main(tmp_path, "--corpus", "facegood", "--vae-steps", "0")
    assert exit_.value.code == 2 and "--vae-steps: expected an integer >= 1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _main(tmp_path, "--corpus", "biwi")  # not a board
    assert "invalid choice: 'biwi'" in capsys.readouterr().err and _nothing_stored(tmp_path)


def _stored(folder, label, *, recipe, name=None, vae=None, expert="e" * 64):
    """A result file on dataset ``recipe`` whose latent and expert columns were scored by
    ``vae`` (a sha256; None: the published VAE) and an expert of weights digest ``expert``."""
    from benchmark.results import build_result, result_filename, write

    protocol = {"samples": 1, "seed": 0,
                "lipsync_models": {"sync_expert": {"path": "/x.pt", "sha256": "1" * 64, "weights_sha256": expert}}}
    if vae is not None:
        protocol["vae"] = {"path": "/v.pth", "sha256": vae}
    dataset = {"recipe_id": recipe, "manifest_hash": recipe, "split": "test", "num_sentences": 20,
               **({"name": name, "title": name.upper()} if name else {})}
    metrics = {"fd": {"mean": 1.0, "std": 0.1, "higher_is_better": False, "unit": "latent^2"},
               "av_confidence_expert": {"mean": 0.3, "std": 0.1, "higher_is_better": True, "unit": "correlation"}}
    result = build_result(method={"name": label, "label": label, "config": {}}, dataset=dataset, protocol=protocol,
                          metrics=metrics, timings={}, provenance={"git_commit": "x"})
    path = folder / result_filename(label, recipe, 1, 0, None)
    write(path, result)
    return path


def test_the_table_build_refuses_a_table_of_rows_scored_by_different_vaes_or_corpora(tmp_path):
    from blendvoca.errors import DataError
    from leaderboard.collect import load_results, tables_by_manifest
    from leaderboard.site.data import load_site_runs

    folder = tmp_path / "results"
    folder.mkdir()
    _stored(folder, "alpha", recipe="f" * 64, name="facegood", vae="a" * 64)
    _stored(folder, "beta", recipe="f" * 64, name="facegood", vae="a" * 64)
    _stored(folder, "alpha", recipe="s" * 64)  # the synthetic corpus, published VAE: its own table
    tables = tables_by_manifest(load_results(folder))
    assert [(t.name, [r.label for r in t.rows]) for t in tables] == [("FACEGOOD", ["alpha", "beta"]), ("", ["alpha"])]
    assert [t.vae for t in tables] == ["a" * 64, ""]  # the FACEGOOD table names its VAE; the other is the published
    # ... in the Markdown, under the LaTeX tables that show latent metrics, and on the site
    from leaderboard.build import rendered_tables
    from leaderboard.site.data import leaderboard_data

    rendered = rendered_tables(load_results(folder))
    assert rendered["leaderboard.md"].count(f"scored by the VAE of sha256 {'a' * 12}") == 1
    captions = [line for line in rendered["leaderboard.tex"].splitlines() if line.startswith(r"\caption")]
    named = [c for c in captions if f"VAE of sha256 {'a' * 12}" in c]
    assert named and all("FACEGOOD" in c and "Lip" not in c.split(" metrics,")[0] for c in named)
    assert not [c for c in captions if "Lip" in c.split(" metrics,")[0] and "VAE" in c]  # no latent column there
    assert [t["vae"] for t in leaderboard_data(load_site_runs(folder))["tables"]] == ["a" * 64, ""]
    # a row of the FACEGOOD table scored by the published VAE: its FD is of another latent space
    other = _stored(folder, "gamma", recipe="f" * 64, name="facegood")
    for load in (load_results, load_site_runs):
        with pytest.raises(DataError, match="scored by different VAEs cannot share a table") as error:
            load(folder)
        assert str(other) in str(error.value) and "the published VAE" in str(error.value)
    other.unlink()
    # the same dataset identity claimed by another corpus (a clash): refused, naming both
    clash = _stored(folder, "gamma", recipe="f" * 64, name="beat", vae="a" * 64)
    for load in (load_results, load_site_runs):
        with pytest.raises(DataError, match="results of different corpora cannot share a table") as error:
            load(folder)
        assert f"beat: {clash}" in str(error.value) and "facegood:" in str(error.value)


def test_the_real_board_refuses_results_folders_whose_table_its_rows_would_mix(tmp_path):
    from types import SimpleNamespace

    from benchmark.lipsync.default_expert import REAL_SPEECH_DIGEST, REAL_SPEECH_EXPERT
    from blendvoca.format.hashing import content_digest
    from leaderboard.executors.capture_stages import table_conflicts

    vae = tmp_path / "vae.pth"
    vae.write_bytes(b"a VAE's bytes")
    digest = content_digest(vae)
    build = SimpleNamespace(manifest_hash="m" * 64, recipe_id="f" * 64)
    folder = tmp_path / "results"
    folder.mkdir()
    same = _stored(folder, "alpha", recipe="f" * 64, name="facegood", vae=digest, expert=REAL_SPEECH_DIGEST)
    _stored(folder, "alpha", recipe="s" * 64, vae="b" * 64)  # another table: not read

    def conflicts(**kw):
        return table_conflicts(folder, build, vae=vae, expert=REAL_SPEECH_EXPERT, corpus="facegood", **kw)

    assert conflicts() == []
    published = _stored(folder, "beta", recipe="f" * 64, name="facegood", expert=REAL_SPEECH_DIGEST)
    synthetic_expert = _stored(folder, "gamma", recipe="f" * 64, name="facegood", vae=digest)
    found = conflicts()
    assert found == [f"{published.name}: VAE the published one, not {digest[:12]}",
                     f"{synthetic_expert.name}: lip-sync expert eeeeeeeeeeee, not {REAL_SPEECH_DIGEST[:12]}"]
    # rows the plan writes again (--force) do not count
    assert conflicts(replaced=[published, synthetic_expert]) == [] and same.is_file()


@pytest.mark.slow
def test_the_real_board_builds_from_the_asset_files_and_scores_two_rows(tmp_path, realdata_resolver, capsys):
    """``--corpus facegood --only ground-truth,mean`` with a short VAE training: the build,
    the VAE, the real-speech expert and the two rows' result files, their own table
    titled FACEGOOD; run again, everything is kept."""
    from benchmark.lipsync.default_expert import REAL_SPEECH_DIGEST
    from benchmark.results import read
    from blendvoca.format.hashing import content_digest

    assert _main(tmp_path, "--corpus", "facegood", "--only", "ground-truth,mean", "--vae-steps", "20") == 0
    paths = sorted((tmp_path / "r").glob("*.json"))
    assert [p.name.split("__")[0] for p in paths] == ["ground-truth", "mean"]
    vae = tmp_path / "w" / "vae" / f"{FACEGOOD.build_name}.pth"
    card = json.loads((vae.parent / (vae.name + ".json")).read_text())
    results = {p.name.split("__")[0]: read(p) for p in paths}
    truth = results["ground-truth"]
    assert card["data"] == {"recipe_id": truth.dataset.recipe_id, "dataset": "facegood"} and card["steps"] == 20
    assert len(card["names"]) == 32 and card["names"][3] == "jawOpen"
    for name in ("lve_rig", "lve_squared_rig", "mve_rig", "fdd_rig", "energy_rig"):
        assert truth.metrics[name].mean == 0.0, name  # the ground truth against itself, in rig space
    assert results["mean"].metrics["lve_rig"].mean > 0
    for result in results.values():
        assert result.dataset.name == "facegood" and result.dataset.split == "test"
        assert result.dataset.num_sentences == 20  # the two test takes 3_15 and 3_16, cut at their pauses
        assert not result.dataset.latent_out_of_domain and "fd" in result.metrics
        # the latent metrics name their VAE, the lip-sync columns the real-speech expert
        assert result.protocol.get("vae") == {"path": str(vae.resolve()), "sha256": content_digest(vae)}
        expert = result.protocol.lipsync_models["sync_expert"]
        assert expert["weights_sha256"] == REAL_SPEECH_DIGEST and expert["project_expert"] == "real-speech-v1"
        assert "av_offset_expert" in result.metrics
    table = (tmp_path / "t" / "leaderboard.md").read_text()
    assert f"## FACEGOOD: dataset `{truth.dataset.recipe_id[:12]}`" in table
    assert "out of domain" not in table and f"scored by the VAE of sha256 {content_digest(vae)[:12]}" in table
    # the site gets the FACEGOOD section, the runs' pages and the test takes' rigs
    from leaderboard.site.data import load_site_runs, write_site_data

    counts = write_site_data(load_site_runs(tmp_path / "r"), tmp_path / "site")
    board = json.loads((tmp_path / "site" / "leaderboard.json").read_text())
    assert [(t["name"], t["manifest_hash"]) for t in board["tables"]] == [("FACEGOOD", truth.dataset.recipe_id)]
    assert counts["runs"] == 2 and counts["sentences"] == 20 and counts["rigs"] >= 1
    # resumable: a second run keeps the build, the VAE and both rows
    stamps = {p: p.stat().st_mtime_ns for p in [*paths, vae]}
    capsys.readouterr()
    assert _main(tmp_path, "--corpus", "facegood", "--only", "ground-truth,mean", "--vae-steps", "20") == 0
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    assert "exists, kept" in capsys.readouterr().err


def test_a_vae_in_the_work_folder_is_kept_only_for_its_own_build_and_budget():
    from types import SimpleNamespace

    from leaderboard.executors.capture_stages import _trained_as_planned

    build = SimpleNamespace(manifest_hash="m" * 64, recipe_id="f" * 64)
    card = {"names": ["jawOpen"], "data": {"recipe_id": "f" * 64, "dataset": "facegood"}, "steps": 3000, "seed": 0}
    assert _trained_as_planned(card, build, 3000)
    assert not _trained_as_planned(card, build, 20)  # --vae-steps 20: another budget
    assert not _trained_as_planned({**card, "data": {"recipe_id": "g" * 64}}, build, 3000)  # another build
    assert not _trained_as_planned(None, build, 3000)  # no card: not the board's
