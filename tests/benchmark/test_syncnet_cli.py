"""SyncNet from the command line: ``benchmark.run --syncnet-weights PATH`` with a
randomly initialised network saved in the authors' format (a plain state_dict)."""

import json

import pytest
import torch

from benchmark.lipsync.syncnet import SyncNet
from benchmark.run import main


@pytest.mark.slow
def test_run_scores_syncnet_with_weights_in_the_authors_format(built_dataset, tmp_path, capsys):
    torch.manual_seed(0)
    weights = tmp_path / "syncnet_v2.model"
    torch.save(SyncNet().state_dict(), weights)
    assert main(["--method", "ground-truth", "--data", str(built_dataset), "--results", str(tmp_path / "r"),
                 "--syncnet-weights", str(weights), "--quiet"]) == 0
    path = capsys.readouterr().out.strip().splitlines()[-1]
    result = json.loads(open(path).read())
    for name in ("av_offset_syncnet", "av_confidence_syncnet"):
        entry = result["metrics"][name]
        assert entry["n"] == len(result["per_sentence"]) and entry["ci95"][0] <= entry["mean"] <= entry["ci95"][1]
    assert result["protocol"]["lipsync_models"]["syncnet"]["path"] == str(weights.resolve())
    import hashlib

    assert result["protocol"]["lipsync_models"]["syncnet"]["sha256"] == hashlib.sha256(weights.read_bytes()).hexdigest()


def test_missing_syncnet_weights_is_one_error_line(tmp_path, capsys):
    assert main(["--method", "mean", "--data", str(tmp_path), "--results", str(tmp_path / "r"),
                 "--syncnet-weights", str(tmp_path / "none.model")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
