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
