"""Adding model-based lip-sync metrics to a stored run equals scoring the run with them."""

import json

import numpy as np
import pytest

from benchmark.lipsync.expert import build_expert, save_expert
from benchmark.rescore import main as rescore_main
from benchmark.protocol import RunSpec, run
from blendvoca.names import BLENDVOCA_NAMES


def test_rescoring_a_stored_run_with_an_expert_equals_scoring_with_it(built_dataset, tmp_path):
    import torch

    torch.manual_seed(0)
    expert_path = tmp_path / "expert.pt"
    save_expert(build_expert({}, np.zeros(32), np.ones(32), BLENDVOCA_NAMES, {"data": "test"}), expert_path)
    scored = run(RunSpec("random", data_root=built_dataset, samples=2, results_dir=tmp_path / "a",
                         sync_expert=expert_path))
    plain = run(RunSpec("random", data_root=built_dataset, samples=2, results_dir=tmp_path / "b"))
    assert "av_confidence_expert" not in json.loads(plain.read_text())["metrics"]
    assert rescore_main([str(plain), "--sync-expert", str(expert_path), "--quiet"]) == 0
    a, b = json.loads(scored.read_text()), json.loads(plain.read_text())
    # the stored CSVs keep 1e-6 of each coefficient: the rescored values agree to that resolution
    for name in ("av_offset_expert", "av_confidence_expert"):
        for key in ("mean", "std", "sample_std"):
            assert b["metrics"][name][key] == pytest.approx(a["metrics"][name][key], rel=1e-5, abs=1e-9)
        assert b["metrics"][name]["ci95"] == pytest.approx(a["metrics"][name]["ci95"], rel=1e-5, abs=1e-9)
    assert list(a["metrics"]) == list(b["metrics"])  # registry order
    for row_a, row_b in zip(a["per_sentence"], b["per_sentence"]):
        assert (row_b["subject"], row_b["sentence"]) == (row_a["subject"], row_a["sentence"])
        numbers = {k: v for k, v in row_a.items() if k not in ("subject", "sentence")}
        assert {k: row_b[k] for k in numbers} == pytest.approx(numbers, rel=1e-5, abs=1e-9)
    assert a["protocol"]["lipsync_models"] == b["protocol"]["lipsync_models"]
    assert a["protocol"]["lipsync_models"]["sync_expert"]["trained_on"] == {"data": "test"}
    # a result combining several training seeds is refused (one line, exit 2), not half-rescored
    plain.write_text(json.dumps({**b, "seeds": [0, 1]}))
    assert rescore_main([str(plain), "--sync-expert", str(expert_path), "--quiet"]) == 2


def test_rescore_needs_a_model(tmp_path, capsys):
    assert rescore_main([str(tmp_path / "x.json")]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_rescoring_a_build_edited_since_is_refused_unless_no_verify(built_dataset, tmp_path, capsys):
    """The rescored speakers' files are checked against the build's manifest, as benchmark.run checks them."""
    import shutil

    from blendvoca import format as fmt
    from tests.faults.conftest import assert_one_error_line

    build = tmp_path / "B"
    shutil.copytree(built_dataset, build)
    expert_path = tmp_path / "expert.pt"
    save_expert(build_expert({}, np.zeros(32), np.ones(32), BLENDVOCA_NAMES, {"data": "test"}), expert_path)
    path = run(RunSpec("random", data_root=build, samples=1, results_dir=tmp_path / "r"))
    assert json.loads(path.read_text())["protocol"]["verified"] is True
    # a speaker the run did not score is not read, so not checked
    other = fmt.read_splits(build)["val"][0]
    fmt.audio_path(build, other, "sentence01").write_bytes(b"edited")
    assert rescore_main([str(path), "--sync-expert", str(expert_path), "--quiet"]) == 0, capsys.readouterr().err
    capsys.readouterr()
    before = path.read_bytes()
    subject, sentence = next((row["subject"], row["sentence"]) for row in json.loads(before)["per_sentence"])
    audio = fmt.audio_path(build, subject, sentence)
    data = bytearray(audio.read_bytes())
    data[-1] ^= 1
    audio.write_bytes(bytes(data))
    assert rescore_main([str(path), "--sync-expert", str(expert_path), "--quiet"]) == 4
    assert_one_error_line(capsys.readouterr().err, str(audio), "manifest.json", "--no-verify")
    assert path.read_bytes() == before  # nothing rewritten
    assert rescore_main([str(path), "--sync-expert", str(expert_path), "--quiet", "--no-verify"]) == 0
    rescored = json.loads(path.read_text())
    assert rescored["protocol"]["verified"] is False and "av_confidence_expert" in rescored["metrics"]
