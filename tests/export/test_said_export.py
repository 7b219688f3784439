"""``baselines.said.generate --export FMT`` writes the export formats directly."""

import numpy as np
import pytest


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    from baselines.said.pipeline import SAiD
    from blendvoca.names import BLENDVOCA_NAMES

    said = SAiD.from_preset(BLENDVOCA_NAMES, channels=16, cond_dim=16, heads=2, num_steps=4)
    return said.save(tmp_path_factory.mktemp("said") / "said.pt")


def test_generate_exports(tmp_path, checkpoint, small_rig, capsys):
    from baselines.said.generate import main
    from blendvoca.export import read_track
    from blendvoca.io.audio import write_wav

    wav = tmp_path / "x.wav"
    write_wav(wav, 0.3 * np.sin(2 * np.pi * 200 * np.arange(16000) / 16000), 16000)
    small_rig.save(tmp_path / "rig.npz")
    main(["--audio", str(wav), "--out", str(tmp_path / "y.csv"), "--checkpoint", str(checkpoint), "--seed", "1"])
    reference, names, _ = read_track(tmp_path / "y.csv")
    for fmt, out in (("livelink", "y-ll.csv"), ("a2f-json", "y.json"), ("glb", "y.glb")):
        main(["--audio", str(wav), "--out", str(tmp_path / out), "--checkpoint", str(checkpoint), "--seed", "1",
              "--export", fmt, "--rig", str(tmp_path / "rig.npz")])
        back, back_names, fps = read_track(tmp_path / out)
        assert fps == pytest.approx(60)
        np.testing.assert_allclose(back[:, [list(back_names).index(n) for n in names]], reference, atol=2e-6)
    capsys.readouterr()
    assert main(["--audio", str(wav), "--out", str(tmp_path / "y.usda"), "--checkpoint", str(checkpoint),
                 "--export", "usd"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "--export usd needs --rig" in err[0]
