import numpy as np
import pytest

from benchmark.render import front_camera, project, rasterize, read_video, render_sequence, resample_frames, write_video
from tests.benchmark.fakes import flame_head


def test_resample_frames_linear():
    x = np.arange(61, dtype=float)[:, None]  # 1 s at 60 fps
    y = resample_frames(x, 60, 25)
    assert y.shape == (26, 1)
    np.testing.assert_allclose(y[:, 0], np.arange(26) * 60 / 25)
    assert resample_frames(x, 60, 60).shape == x.shape


def test_camera_frames_the_mesh():
    v = np.array([[-1, -1, 0], [1, 1, 0], [0, 0, 0.5]], dtype=float)
    pose = front_camera(v, yfov=np.pi / 4, margin=1.0)
    xy, depth = project(v, pose, np.pi / 4, 100, 100)
    assert np.all(depth > 0)
    np.testing.assert_allclose(xy[2], [50, 50], atol=1e-9)
    assert np.all((xy >= -1e-6) & (xy <= 100 + 1e-6))


def test_software_rasteriser_triangle_coverage():
    # a triangle covering the lower-left half of the view: half the pixels lit
    v = np.array([[-1, -1, 0], [1, -1, 0], [-1, 1, 0]], dtype=float)
    pose = np.eye(4)
    pose[2, 3] = 1.0 / np.tan(np.pi / 8)  # the square [-1, 1]^2 exactly fills a 45 degree view
    img = rasterize(v, np.array([[0, 1, 2]]), pose, np.pi / 4, 64, 64)
    lit = (img < 255).any(axis=2)
    assert abs(lit.mean() - 0.5) < 0.03
    assert lit[-1, 0] and not lit[0, -1]


def test_software_and_pyrender_agree_on_silhouette(assets_dir):
    from benchmark.render.pyrender_backend import egl_available

    v, f = flame_head(assets_dir)
    soft = render_sequence(v[None], f, size=96, backend="software")[0]
    if not egl_available():
        pytest.skip("no EGL here: the software renderer is the one in use")
    gl = render_sequence(v[None], f, size=96, backend="pyrender")[0]
    a, b = (soft < 250).any(axis=2), (gl < 250).any(axis=2)
    iou = (a & b).sum() / (a | b).sum()
    assert iou > 0.95


def test_video_round_trip_with_audio(tmp_path, assets_dir):
    v, f = flame_head(assets_dir)
    seq = np.stack([v, v + [0, 0.01, 0], v + [0, 0.02, 0]] * 4)
    frames = render_sequence(seq, f, size=64, backend="software")
    audio = (0.1 * np.sin(2 * np.pi * 440 * np.arange(int(16000 * 12 / 25)) / 16000)).astype(np.float32)
    path = write_video(tmp_path / "out.mp4", frames, 25, audio=audio)
    back, fps, back_audio = read_video(path)
    assert back.shape == frames.shape and fps == pytest.approx(25)
    assert np.abs(back.astype(int) - frames.astype(int)).mean() < 6
    assert abs(len(back_audio) - len(audio)) < 0.1 * 16000


def test_bad_input():
    with pytest.raises(ValueError, match="backend"):
        render_sequence(np.zeros((1, 3, 3)), np.array([[0, 1, 2]]), backend="opengl")
    with pytest.raises(ValueError, match="out of range"):
        render_sequence(np.zeros((1, 3, 3)), np.array([[0, 1, 5]]))


def test_cli_coeffs_and_meshes(fake_dataset_dir, tmp_path):
    from benchmark.render.__main__ import main
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
    from blendvoca.io.mesh import write_mesh
    from blendvoca.rig import Rig

    subject = fake_dataset_dir / "blendshape_coeffs" / "FakeC"
    coeffs, names = read_coeffs_csv(subject / "sentence01.csv")
    short = tmp_path / "short.csv"
    write_coeffs_csv(short, coeffs[:12], names)
    out = tmp_path / "coeffs.mp4"
    main(["--coeffs", str(short), "--rig", str(fake_dataset_dir / "rigs" / "FakeC.npz"),
          "--audio", str(fake_dataset_dir / "audio" / "FakeC" / "sentence01.wav"),
          "--out", str(out), "--size", "64", "--backend", "software", "--out-fps", "25"])
    frames, fps, audio = read_video(out)
    assert frames.shape[0] == 5 and fps == pytest.approx(25) and len(audio) > 0

    rig = Rig.load(fake_dataset_dir / "rigs" / "FakeC.npz")
    np.save(tmp_path / "seq.npy", rig.evaluate(coeffs[:4]))
    write_mesh(tmp_path / "faces.obj", rig.neutral, rig.faces)
    main(["--meshes", str(tmp_path / "seq.npy"), "--faces", str(tmp_path / "faces.obj"),
          "--out", str(tmp_path / "mesh.mp4"), "--size", "64", "--backend", "software"])
    assert read_video(tmp_path / "mesh.mp4")[0].shape[0] == 4
