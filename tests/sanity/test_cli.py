"""``python -m benchmark.sanity``: the bundled default passes, a broken declaration exits 4,
a build without a test split exits 2."""

import json
import shutil

import numpy as np
import pytest

from benchmark.sanity.__main__ import main
from benchmark.sanity.expectations import EXPECTATIONS, Expectation


@pytest.mark.slow  # the whole suite on the bundled default (about 40 evaluations; 2-3 minutes on 2 cores)
def test_bundled_default_passes_every_declaration(tmp_path, assets_dir, capsys):
    from benchmark.protocol import default_data_root

    data = default_data_root()
    rc = main(["--data", str(data), "--out", str(tmp_path), "--levels", "small", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0, out
    table = json.loads((tmp_path / "sanity.json").read_text())
    assert (tmp_path / "sanity.png").stat().st_size > 10_000
    meta = json.loads((tmp_path / "sanity_meta.json").read_text())
    assert meta["failed"] == [] and meta["levels"] == "small"
    for metric, row in table.items():
        for kind, entry in row.items():
            assert {"levels", "values", "rho", "expected", "ok"} <= set(entry), (metric, kind)
            assert entry["ok"], (metric, kind, entry)
            if entry["status"] != "not scored":
                assert len(entry["values"]) == len(entry["levels"]) >= 5
    # the acceptance check of protocol v3 and the two metric fixes, where the names are scored
    if "av_lag_bias_geometric" in table:
        shift = table["av_lag_bias_geometric"]["time_shift"]
        assert np.allclose(shift["values"], shift["levels"], atol=0.5) and shift["values"][0] == 0
    damped = table["av_confidence_geometric"]["damping"]
    assert damped["rho"] == pytest.approx(-1.0) and damped["values"][-1] < 0.5 * damped["values"][0]
    # issue 54: damping scales every dynamics ratio by 1 - level, and the reference rows' claims hold
    ratio = table["motion_ratio_lips"]["damping"]
    assert np.allclose(ratio["values"], [1 - level for level in ratio["levels"]], rtol=1e-9)
    references = json.loads((tmp_path / "sanity_references.json").read_text())
    for region in ("lips", "jaw", "upper"):
        closeness = references[f"motion_closeness_{region}"]
        assert closeness["static"]["mean"] == 0 and closeness["ground_truth"]["mean"] == 1
        assert closeness["oracle_sample"]["status"] == "not scored"  # the bundled default has no oracle samples
    assert meta["references"]["failed"] == 0 and meta["references"]["held"] >= 14


def test_a_broken_declaration_exits_4_after_writing(tmp_path, built_dataset, monkeypatch, capsys):
    """A deliberately wrong declaration (LVE in rig space *falls* with damping) fails the check."""
    wrong = Expectation("lve_rig", "damping", "falls", "deliberately wrong (test)")
    monkeypatch.setitem(EXPECTATIONS, ("lve_rig", "damping"), wrong)
    monkeypatch.setitem(EXPECTATIONS, ("lve", "damping"), Expectation("lve", "damping", "falls", "old name (test)"))
    rc = main(["--data", str(built_dataset), "--out", str(tmp_path / "out"), "--disturbances", "damping", "--quiet"])
    captured = capsys.readouterr()
    assert rc == 4
    assert "FAILED lve" in captured.out and "under damping" in captured.out
    assert captured.err.strip().startswith("error:") and len(captured.err.strip().splitlines()) == 1
    table = json.loads((tmp_path / "out" / "sanity.json").read_text())  # written before the exit
    name = "lve_rig" if "lve_rig" in table else "lve"
    entry = table[name]["damping"]
    assert entry["ok"] is False and entry["expected"] == "falls" and entry["rho"] == pytest.approx(1.0)
    assert (tmp_path / "out" / "sanity.png").is_file()


def test_a_broken_reference_claim_exits_4_after_writing(tmp_path, built_dataset, monkeypatch, capsys):
    """A deliberately wrong claim (the ground truth's lip closeness is 0) fails the run."""
    from benchmark.sanity.expectations import REFERENCE_CLAIMS, ReferenceClaim

    wrong = ReferenceClaim("motion_closeness_lips", "ground_truth", "equals", 0.0, "deliberately wrong (test)")
    monkeypatch.setitem(REFERENCE_CLAIMS, ("motion_closeness_lips", "ground_truth"), wrong)
    rc = main(["--data", str(built_dataset), "--out", str(tmp_path / "out"), "--disturbances", "constant_offset",
               "--quiet"])
    captured = capsys.readouterr()
    assert rc == 4
    assert "FAILED motion_closeness_lips on the reference row ground_truth" in captured.out
    references = json.loads((tmp_path / "out" / "sanity_references.json").read_text())
    entry = references["motion_closeness_lips"]["ground_truth"]
    assert entry["status"] == "failed" and entry["mean"] == 1.0 and "declared 0" in entry["why"]
    assert references["motion_closeness_lips"]["static"]["status"] == "held"


@pytest.mark.parametrize("splits", [{"train": ["A"]}, {"train": ["A"], "test": []}])
def test_a_build_without_a_test_split_exits_2(tmp_path, built_dataset, capsys, splits):
    from blendvoca import format as fmt

    build = tmp_path / "build"
    shutil.copytree(built_dataset, build)
    (build / fmt.SPLITS_FILE).write_text(json.dumps(splits))
    rc = main(["--data", str(build), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert err.startswith("error:") and len(err.splitlines()) == 1 and "test" in err
    assert not (tmp_path / "out").exists()  # nothing written


def test_usage_errors_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--out", str(tmp_path), "--levels", "huge"])
    assert exc.value.code == 2
    assert main(["--out", str(tmp_path), "--disturbances", "wobble"]) == 2
    assert "error: --disturbances" in capsys.readouterr().err
