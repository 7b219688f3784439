"""The command line writes SAiD's folder layout, a contact sheet and the report."""

import json

import matplotlib.image
import numpy as np

from blendvoca.io.mesh import read_mesh, write_obj
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.retarget.cli import main
from blendvoca.rig import Rig, load_arkit_reference


def test_cli_retargets_onto_a_moved_copy(assets_dir, tmp_path):
    source = load_arkit_reference("speech")
    target = 1.1 * source.neutral[:, [0, 1, 2]] + [0.0, 0.5, 0.0]
    write_obj(tmp_path / "target.obj", target, source.faces)
    out = tmp_path / "out"
    assert main(["--target", str(tmp_path / "target.obj"),
                 "--target-landmarks", str(assets_dir / "said" / "ARKit_landmarks.txt"),
                 "--out", str(out)]) == 0
    V, _F = read_mesh(out / "Neutral.obj")
    np.testing.assert_allclose(V, target, atol=1e-6)
    for name in BLENDVOCA_NAMES:
        assert (out / f"{name}.obj").is_file()
    rig = Rig.load(out / "rig.npz")
    assert rig.names == BLENDVOCA_NAMES
    # a scaled copy gets the scaled shapes back
    rel = np.linalg.norm(rig.deltas - 1.1 * source.deltas, axis=2).max() / np.linalg.norm(1.1 * source.deltas, axis=2).max()
    assert rel < 1e-3
    report = json.loads((out / "report.json").read_text())
    assert report["summary"]["all_finite"] and report["alignment"]["scale"] == __import__("pytest").approx(1.1)
    assert "jawOpen" in (out / "report.md").read_text()
    image = matplotlib.image.imread(out / "contact_sheet.png")
    assert image.ndim == 3 and image.shape[0] > 200 and image.std() > 0.05


def test_flame_target_gets_the_head_crop_without_crop(assets_dir, monkeypatch):
    from blendvoca.io.mesh import read_ply
    from blendvoca.retarget.crop import default_crop, is_flame_topology

    V, F = read_ply(assets_dir / "voca" / "FLAME_sample.ply")
    assert is_flame_topology(F[:, ::-1][np.random.default_rng(0).permutation(len(F))], len(V))
    keep, note = default_crop(F, len(V))
    expected = np.loadtxt(assets_dir / "said" / "FLAME_head_idx.txt", dtype=np.int64)
    np.testing.assert_array_equal(np.sort(keep), np.sort(expected))
    assert "FLAME head crop" in note and "--crop" in note
    assert not is_flame_topology(F[:-1], len(V)) and default_crop(F[:-1], len(V)) == (None, None)
    # without the crop asset: a warning that says how to pass it
    import blendvoca.assets

    def unavailable(asset_id, **kwargs):
        raise blendvoca.assets.AssetError(f"asset {asset_id!r} is not present locally")

    monkeypatch.setattr(blendvoca.assets, "load_index_list", unavailable)
    keep, note = default_crop(F, len(V))
    assert keep is None and "drag the neck" in note and "--crop" in note


def test_cli_passes_the_flame_crop(assets_dir, tmp_path, monkeypatch, capsys):
    import blendvoca.retarget.cli as retarget_cli
    from blendvoca.errors import UserError

    seen = {}

    class Stop(UserError):
        """Ends the command after the plan's arguments are seen (the command layer reports it: exit 2)."""

    def plan(*args, crop=None, **kwargs):
        seen["crop"] = crop
        raise Stop("stopped after planning")

    monkeypatch.setattr(retarget_cli, "plan_retarget", plan)
    assert main(["--target", str(assets_dir / "voca" / "FLAME_sample.ply"),
                 "--target-landmarks", str(assets_dir / "said" / "FLAME_landmarks.txt"),
                 "--out", str(tmp_path / "o")]) == 2
    assert len(seen["crop"]) == len(np.loadtxt(assets_dir / "said" / "FLAME_head_idx.txt"))
    captured = capsys.readouterr()
    assert "using the FLAME head crop" in captured.out and "error: stopped after planning" in captured.err
