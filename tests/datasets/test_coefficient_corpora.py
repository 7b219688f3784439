"""The coefficient-corpus adapters (BEAT, UniTalker, 3D-ETF): each builds a small corpus
written in its layout into a BlendVOCA folder the benchmark reads, with the weights
moved by name to ARKit's columns and resampled to 60 fps."""

from __future__ import annotations

import json

import numpy as np
import pytest

from blendvoca import format as fmt
from blendvoca.builder.__main__ import main as build_main
from blendvoca.datasets import DATASETS, adapter
from blendvoca.datasets.coefficients import COEFFICIENT_FORMAT
from blendvoca.errors import OutputDirError, UserError
from blendvoca.names import ARKIT_FACE_ORDER, BLENDVOCA_NAMES, convention_names, remap
from tests.datasets.corpora import write_beat, write_unitalker_layout


def _build(name, root, out):
    return adapter(name)(root, out)


def _csv(out, subject, sentence):
    header, *rows = (fmt.coeffs_path(out, subject, sentence)).read_text().splitlines()
    return header.split(","), np.array([[float(v) for v in row.split(",")] for row in rows])


def test_the_registry_names_every_adapter_lazily():
    assert {"vocaset", "beat", "unitalker", "3d-etf"} <= set(DATASETS)
    assert all(":" in target for target in DATASETS.values())
    with pytest.raises(UserError, match="unknown dataset 'beats'.*did you mean 'beat'"):
        adapter("beats")


def test_beat_takes_are_mapped_by_name_and_keep_every_shape(tmp_path):
    written = write_beat(tmp_path / "beat")
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    assert summary.ok and summary.built == {"speakers": 3, "sentences": 6}
    from benchmark.data import open_blendvoca

    data = open_blendvoca(tmp_path / "out")
    assert data.subjects == ["1_wayne", "2_scott", "3_solomon"]
    assert data.sentences("1_wayne") == ["sentence01", "sentence02"]
    # the JSON's Live Link column order is undone: ARKit's 52 in the file, the 32 in the benchmark
    header, values = _csv(tmp_path / "out", "2_scott", "sentence02")
    assert tuple(header) == ARKIT_FACE_ORDER
    truth = written[("2_scott", "2_scott_0_2_2")]
    np.testing.assert_allclose(values, truth, atol=5e-7)
    np.testing.assert_allclose(data.coeffs("2_scott", "sentence02"), remap(truth, "arkit52", "said32"), atol=5e-7)
    audio, rate = data.audio("2_scott", "sentence02")
    assert rate == 16000 and abs(len(audio) / rate - len(truth) / 60) < 1 / 60
    rig = data.rig("3_solomon")
    assert len(rig.names) == 51 and "tongueOut" not in rig.names
    manifest = fmt.read_manifest(tmp_path / "out")
    assert manifest["dataset"]["name"] == "beat" and manifest["dataset"]["title"] == "BEAT"
    assert manifest["dataset"]["meshes"] is False
    assert manifest["dataset"]["sources"]["1_wayne/sentence01"] == "1/1_wayne_0_1_1.json"
    assert fmt.read_splits(tmp_path / "out") == {"train": ["1_wayne"], "val": ["2_scott"], "test": ["3_solomon"]}


def test_unitalker_weights_are_resampled_from_30_to_60_fps_in_arkit_order(tmp_path):
    written = write_unitalker_layout(tmp_path / "d6", annot_type="inhouse_blendshape_weight",
                                     convention="unitalker51", npy_audio=True)
    summary = _build("unitalker", tmp_path / "d6", tmp_path / "out")
    assert summary.ok and summary.built == {"speakers": 4, "sentences": 8}
    header, values = _csv(tmp_path / "out", "spk_b", "sentence02")
    assert tuple(header) == tuple(n for n in ARKIT_FACE_ORDER if n != "tongueOut")  # 51: tongueOut not invented
    truth = remap(written[("spk_b", "annot/spk_b_001")], "unitalker51", header)
    assert len(values) == 2 * len(truth)
    np.testing.assert_allclose(values[::2], truth, atol=5e-7)  # every other 60 fps frame is a 30 fps one
    np.testing.assert_allclose(values[1:-1:2], (truth[:-1] + truth[1:]) / 2, atol=1e-6)
    # the corpus's own split is by speaker here, and is kept
    assert fmt.read_splits(tmp_path / "out") == {"train": ["spk_a", "spk_b"], "val": ["spk_c"], "test": ["spk_d"]}


def test_3d_etf_keeps_tongue_out_and_a_split_by_sentence_becomes_one_by_speaker(tmp_path):
    written = write_unitalker_layout(tmp_path / "d3", annot_type="3DETF_blendshape_weight", convention="etf52",
                                     speakers=("a", "b", "c", "d", "e", "f"), takes=3, split_by_speaker=False)
    summary = _build("3d-etf", tmp_path / "d3", tmp_path / "out")
    assert summary.ok and summary.built == {"speakers": 6, "sentences": 18}
    header, values = _csv(tmp_path / "out", "c", "sentence03")
    assert tuple(header) == ARKIT_FACE_ORDER
    np.testing.assert_allclose(values[::2], remap(written[("c", "annot/c_002")], "etf52", "arkit52"), atol=5e-7)
    assert fmt.read_splits(tmp_path / "out") == {"train": ["a", "b", "c", "d"], "val": ["e"], "test": ["f"]}
    assert any("splits by sentence" in w["message"] for w in summary.warnings)


def test_a_take_that_cannot_be_read_fails_alone_and_a_rebuild_rewrites_the_folder(tmp_path):
    write_beat(tmp_path / "beat", takes=2)
    (tmp_path / "beat" / "1" / "1_wayne_0_2_2.json").write_text('{"frames": []}')
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    (failure,) = summary.failures
    assert failure["subject"] == "1_wayne" and "'names'" in failure["reason"]
    assert summary.built["sentences"] == 5
    listed = fmt.listed_files(tmp_path / "out")
    assert fmt.coeffs_relpath("1_wayne", "sentence02") not in listed
    (tmp_path / "beat" / "3" / "3_solomon_0_2_2.json").unlink()
    again = _build("beat", tmp_path / "beat", tmp_path / "out")  # a previous build's folder is accepted
    assert again.built["sentences"] == 4
    assert fmt.coeffs_relpath("3_solomon", "sentence02") not in fmt.listed_files(tmp_path / "out")
    assert not fmt.coeffs_path(tmp_path / "out", "3_solomon", "sentence02").exists()


def test_an_output_folder_of_other_files_or_inside_the_corpus_is_refused(tmp_path):
    write_beat(tmp_path / "beat")
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    with pytest.raises(OutputDirError, match="not empty"):
        _build("beat", tmp_path / "beat", tmp_path / "busy")
    with pytest.raises(OutputDirError, match="inside the input corpus"):
        _build("beat", tmp_path / "beat", tmp_path / "beat" / "out")


def test_command_line_forms_and_one_error_line_for_a_wrong_name_or_layout(tmp_path, capsys):
    write_unitalker_layout(tmp_path / "d6", annot_type="inhouse_blendshape_weight", convention="unitalker51")
    assert build_main(["--dataset", "unitalker", "--root", str(tmp_path / "d6"), "--out", str(tmp_path / "o"),
                       "--quiet"]) == 0
    assert "sentences built 8" in capsys.readouterr().out
    cases = [
        (["--dataset", "beat", "--root", str(tmp_path / "d6"), "--out", str(tmp_path / "x")],
         "no BEAT take found; expected <root>/<speaker id>/<speaker id>_<name>"),
        (["--dataset", "3d-etf", "--root", str(tmp_path / "d6"), "--out", str(tmp_path / "x")],
         "no item of annot_type '3DETF_blendshape_weight'"),
        (["--dataset", "biwii", "--root", str(tmp_path), "--out", str(tmp_path / "x")], "unknown dataset 'biwii'"),
        (["--vocaset", str(tmp_path), "--dataset", "vocaset", "--out", str(tmp_path / "x")], "give one form"),
        (["--dataset", "beat", "--out", str(tmp_path / "x")], "needs --root"),
        (["--root", str(tmp_path / "d6"), "--out", str(tmp_path / "x")], "--root needs --dataset"),
    ]
    for argv, message in cases:
        try:
            code = build_main(argv)
        except SystemExit as exit_info:  # argparse's own usage errors
            code = exit_info.code
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2, argv
        assert err[-1].startswith("error:") and message in err[-1], (argv, err)
        assert not (tmp_path / "x").exists()


def test_unitalker_columns_are_the_registrys_order(tmp_path):
    # the npy's column 19 is jawOpen in UniTalker's order: it must land in the jawOpen column
    root = tmp_path / "d7"
    write_unitalker_layout(root, annot_type="inhouse_blendshape_weight", convention="unitalker51", fps=60.0)
    weights = np.zeros((150, 51), dtype=np.float32)
    weights[:, convention_names("unitalker51").index("jawOpen")] = 0.75
    np.save(root / "annot" / "spk_a_000.npy", weights)
    _build("unitalker", root, tmp_path / "out")
    from benchmark.data import open_blendvoca

    coeffs = open_blendvoca(tmp_path / "out").coeffs("spk_a", "sentence01")
    assert np.allclose(coeffs[:, BLENDVOCA_NAMES.index("jawOpen")], 0.75)
    assert np.allclose(np.delete(coeffs, BLENDVOCA_NAMES.index("jawOpen"), axis=1), 0.0)


def test_vertex_metrics_are_rig_space_only_without_source_meshes(tmp_path, monkeypatch):
    from benchmark.data import open_blendvoca
    from benchmark.evaluation import EvaluationSettings, evaluate_split

    monkeypatch.delenv("BLENDVOCA_VOCASET", raising=False)
    write_beat(tmp_path / "beat", seconds=1.0)
    _build("beat", tmp_path / "beat", tmp_path / "out")
    data = open_blendvoca(tmp_path / "out")
    keys = [(s, t) for s in data.split("test") for t in data.sentences(s)]
    truth = {k: data.coeffs(*k)[None] for k in keys}
    with pytest.warns(UserWarning, match="source meshes cannot be read.*mesh-space metrics"):
        scores = evaluate_split(truth, data, "test", EvaluationSettings(lipsync=False, workers=1),
                                metrics=("lve_rig", "lve_mesh"))
    assert set(scores) == {"lve_rig"} and scores["lve_rig"]["mean"] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.slow  # trains the regression baseline and scores every metric with the VAE: ~50 s each
@pytest.mark.parametrize("name", ["beat", "unitalker", "3d-etf"])
def test_the_benchmark_scores_a_built_corpus_in_rig_space(name, tmp_path, assets_dir, monkeypatch, capsys):
    from benchmark.run import main as run_main

    monkeypatch.setenv("BLENDVOCA_ASSETS", str(assets_dir))
    monkeypatch.delenv("BLENDVOCA_VOCASET", raising=False)
    if name == "beat":
        write_beat(tmp_path / "corpus", seconds=2.5)
    else:
        annot_type, convention = (("inhouse_blendshape_weight", "unitalker51") if name == "unitalker"
                                  else ("3DETF_blendshape_weight", "etf52"))
        write_unitalker_layout(tmp_path / "corpus", seconds=2.5, annot_type=annot_type, convention=convention)
    _build(name, tmp_path / "corpus", tmp_path / "out")
    with pytest.warns(UserWarning, match="source meshes cannot be read"):
        rc = run_main(["--method", "regression", "--max-steps", "5", "--data", str(tmp_path / "out"),
                       "--results", str(tmp_path / "results"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    (path,) = (tmp_path / "results").glob("*.json")
    result = json.loads(path.read_text())
    assert {"lve_rig", "mve_rig", "fdd_rig"} <= set(result["metrics"])
    assert not any(metric.endswith("_mesh") for metric in result["metrics"])


def test_a_coefficient_build_is_named_by_its_recipe(tmp_path):
    import shutil

    write_beat(tmp_path / "beat")
    _build("beat", tmp_path / "beat", tmp_path / "a")
    shutil.copytree(tmp_path / "beat", tmp_path / "moved")
    _build("beat", tmp_path / "moved", tmp_path / "b")
    recipe = fmt.read_manifest(tmp_path / "a")["recipe"]
    assert recipe["format_version"] == COEFFICIENT_FORMAT == "coeffs2" and recipe["parameters"] == {"dataset": "beat", "fps": 60}
    # the corpus's place does not count; its files do
    assert fmt.dataset_id(tmp_path / "a") == fmt.dataset_id(tmp_path / "b") == recipe["id"]
    assert fmt.read_manifest(tmp_path / "a")["tolerances"]
    first = sorted((tmp_path / "moved").rglob("*.json"))[0]
    first.write_text(first.read_text().replace("1", "2", 1))
    _build("beat", tmp_path / "moved", tmp_path / "c")
    assert fmt.dataset_id(tmp_path / "c") != recipe["id"]


def test_long_takes_of_any_coefficient_corpus_become_utterances_numbered_on_per_speaker(tmp_path):
    """BEAT takes of 25 s (speech without pauses): each is cut into utterances of 2-10 s (forced cuts),
    numbered on from the speaker's previous take; the manifest maps each back to its take and seconds."""
    written = write_beat(tmp_path / "beat", takes=2, seconds=25.0)
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    assert not summary.failures and summary.built["sentences"] >= 18
    utterances = fmt.read_utterances(tmp_path / "out")
    for (subject, take), weights in written.items():
        spans = sorted((r["start_frame"], r["end_frame"], key) for key, r in utterances.items() if r["take"] == take)
        assert spans[0][0] == 0 and spans[-1][1] == len(weights)
        assert all(a[1] == b[0] and 2 * 60 <= a[1] - a[0] <= 10 * 60 for a, b in zip(spans, spans[1:]))
        assert {key.split("/")[0] for *_, key in spans} == {subject}
        for start, end, key in spans:
            coeffs, names = fmt.read_coeffs(tmp_path / "out", *key.split("/"))
            assert np.allclose(coeffs, weights[start:end][:, [ARKIT_FACE_ORDER.index(n) for n in names]], atol=1e-6)
    numbers = sorted(int(k.split("sentence")[1]) for k in utterances if k.startswith("1_wayne/"))
    assert numbers == list(range(1, len(numbers) + 1))
    assert "## Utterances" in (tmp_path / "out" / "report" / "README.md").read_text()


def test_beat_build_reports_its_split_rule_and_every_frame_it_cuts(tmp_path):
    import soundfile

    written = write_beat(tmp_path / "beat")
    # one take's audio ends a frame and a half before its motion (within the 5 % tolerance)
    wav = tmp_path / "beat" / "2" / "2_scott_0_1_1.wav"
    audio, rate = soundfile.read(str(wav), dtype="float32")
    soundfile.write(str(wav), audio[: len(audio) - int(1.5 * rate / 60)], rate)
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    messages = [w["message"] for w in summary.warnings]
    rule = "split: the corpus has no split of its own: its speakers are split in VOCASET's proportions"
    assert any(m.startswith(rule) for m in messages), messages
    report = (tmp_path / "out" / "report" / "README.md").read_text()
    assert rule in report
    frames = len(written[("2_scott", "2_scott_0_1_1")])
    cut = [w for w in summary.warnings if "motion frame(s) after the audio's end" in w["message"]]
    assert [w["subject"] for w in cut] == ["2_scott"]
    assert "take 2_scott_0_1_1: 2 motion frame(s) after the audio's end" in cut[0]["message"]
    assert f"({frames} -> {frames - 2} frames)" in cut[0]["message"] and cut[0]["message"] in report
    header, values = _csv(tmp_path / "out", "2_scott", "sentence01")
    assert len(values) == frames - 2
    # the takes whose audio covers the motion lose nothing
    assert len(_csv(tmp_path / "out", "2_scott", "sentence02")[1]) == len(written[("2_scott", "2_scott_0_2_2")])


