"""A coefficient track of the bundled-default build (the test build of the synthetic
corpus) exported to every format and read back equal."""

import json

import numpy as np
import pytest

from blendvoca.export import export_track, read_track
from blendvoca.io.coeffs import read_coeffs_csv
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.rig import Rig
from tests.export.test_formats import _validator_prefix


@pytest.mark.slow
def test_a_built_track_in_every_format(built_dataset, tmp_path):
    subject = sorted(p.name for p in (built_dataset / "blendshape_coeffs").iterdir())[0]
    csv_path = sorted((built_dataset / "blendshape_coeffs" / subject).glob("*.csv"))[0]
    coeffs, names = read_coeffs_csv(csv_path)
    assert names == BLENDVOCA_NAMES
    rig = Rig.load(built_dataset / "rigs" / f"{subject}.npz")
    audio = built_dataset / "audio" / subject / (csv_path.stem + ".wav")
    T = len(coeffs)
    for fmt, out in (("glb", "a.glb"), ("usd", "a.usda"), ("livelink", "a.csv"), ("arkit-json", "a.json"),
                     ("a2f-json", "b.json")):
        export_track(tmp_path / out, coeffs, names, fmt, rig=rig, fps=60.0, audio=audio)
        back, back_names, fps = read_track(tmp_path / out)
        assert fps == pytest.approx(60.0) and back.shape[0] == T
        np.testing.assert_allclose(back[:, [list(back_names).index(n) for n in names]], coeffs, atol=1e-6)

    from blendvoca.export.glb import read_glb, validate_glb
    from blendvoca.export.usd import read_usd

    glb = read_glb(tmp_path / "a.glb")
    assert glb.names == BLENDVOCA_NAMES and len(glb.times) == T and glb.weights.shape == (T, 32)
    if _validator_prefix() is not None:
        assert validate_glb(tmp_path / "a.glb", _validator_prefix())["issues"]["numErrors"] == 0
    usd = read_usd(tmp_path / "a.usda")
    assert usd.names == BLENDVOCA_NAMES and usd.deltas.shape == (32, rig.num_vertices, 3)
    text = (tmp_path / "a.usda").read_text()
    assert text.count('def BlendShape "') == 32 and 'def SkelAnimation "Anim"' in text
    header = (tmp_path / "a.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["Timecode", "BlendShapeCount", "EyeBlinkLeft"] and len(header) == 63
    assert json.loads((tmp_path / "b.json").read_text())["trackPath"].endswith(".wav")
