"""``--dataset biwi`` and ``--dataset multiface`` build the BlendVOCA layout through the VOCASET build."""

import json
import shutil

import pytest

from blendvoca.builder.__main__ import main as build_main

from .vertex_fixtures import posed_source, write_landmarks, write_multiface


@pytest.fixture()
def assets_with_landmarks(tmp_path, assets_dir, monkeypatch):
    """The asset directory plus a user-supplied Multiface landmark file."""
    mirror = tmp_path / "assets"
    shutil.copytree(assets_dir, mirror)
    (mirror / "multiface").mkdir()
    write_landmarks(mirror / "multiface" / "landmarks68.txt")
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(mirror))
    return mirror


@pytest.mark.slow
def test_multiface_builds_the_layout_with_its_head_pose(tmp_path, assets_with_landmarks, capsys):
    root = write_multiface(tmp_path / "multiface", posed_source(tmp_path / "src"))
    assert build_main(["--dataset", "multiface", "--root", str(root), "--out", str(tmp_path / "out"),
                       "--workers", "1", "--quiet"]) == 0
    out = tmp_path / "out"
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["parameters"] == {"shapes": "speech", "delta": 0.1, "pose_fit": "joint",
                                      "reader": "blendvoca.datasets.multiface:open_multiface"}
    assert len(list((out / "blendshape_coeffs").glob("*/sentence01.csv"))) == 3
    assert json.loads((out / "splits.json").read_text())["train"] == ["m--20180227--0000--6795937--GHS"]
    # rerun: everything up to date
    assert build_main(["--dataset", "multiface", "--root", str(root), "--out", str(out), "--workers", "1",
                       "--quiet"]) == 0
    assert "sentences built 0, up to date 3" in capsys.readouterr().out


def test_missing_landmarks_stop_the_build_before_any_work(tmp_path, assets_dir, monkeypatch, capsys):
    root = write_multiface(tmp_path / "multiface", posed_source(tmp_path / "src"), captures=(
        "m--a--GHS", "m--b--GHS", "m--c--GHS"))
    mirror = tmp_path / "assets"
    shutil.copytree(assets_dir, mirror)
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(mirror))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    assert build_main(["--dataset", "multiface", "--root", str(root), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "68 whitespace-separated" in err and "multiface/landmarks68.txt" in err
    assert not (tmp_path / "out").exists()


def test_pose_fit_is_refused_for_a_corpus_that_is_not_posed(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        build_main(["--vocaset", str(tmp_path), "--out", str(tmp_path / "out"), "--pose-fit", "remove"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--pose-fit" in err and "biwi" in err and "multiface" in err
    assert not (tmp_path / "out").exists()
