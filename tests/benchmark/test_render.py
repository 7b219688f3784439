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
    from benchmark.render.pyrender_backend import egl_renderer_name

    v, f = flame_head(assets_dir)
    soft = render_sequence(v[None], f, size=96, backend="software")[0]
    if egl_renderer_name() is None:
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
    # the video lasts as long as the audio (the 12-frame track's last frame is held)
    from blendvoca.io.audio import load_audio

    wav = load_audio(fake_dataset_dir / "audio" / "FakeC" / "sentence01.wav")
    assert fps == pytest.approx(25) and len(audio) > 0
    assert frames.shape[0] == round(len(wav) / 16000 * 25)

    rig = Rig.load(fake_dataset_dir / "rigs" / "FakeC.npz")
    np.save(tmp_path / "seq.npy", rig.evaluate(coeffs[:4]))
    write_mesh(tmp_path / "faces.obj", rig.neutral, rig.faces)
    main(["--meshes", str(tmp_path / "seq.npy"), "--faces", str(tmp_path / "faces.obj"),
          "--out", str(tmp_path / "mesh.mp4"), "--size", "64", "--backend", "software"])
    assert read_video(tmp_path / "mesh.mp4")[0].shape[0] == 4


# ------------------------------------------------------------------ renders to judge lip sync from


def _face_pixels_std(frames, size):
    """Standard deviation of the grey levels in the central half of the picture (the face)."""
    centre = frames[:, size // 4: 3 * size // 4, size // 4: 3 * size // 4].astype(float)
    return float(centre.mean(axis=-1).std())


def test_default_framing_puts_a_wide_mouth_on_screen(assets_dir):
    from benchmark.render import face_camera
    from benchmark.render.__main__ import DEFAULT_SIZE

    v, _ = flame_head(assets_dir)
    corners = np.loadtxt(assets_dir / "said" / "FLAME_landmarks.txt", dtype=np.int64)[[48, 54]]
    xy, depth = project(v[corners], face_camera(v), np.pi / 8, DEFAULT_SIZE, DEFAULT_SIZE)
    assert xy[1, 0] - xy[0, 0] >= 120 and np.all(depth > 0)
    assert np.all((xy > 0) & (xy < DEFAULT_SIZE))
    chin, brow = np.loadtxt(assets_dir / "said" / "FLAME_landmarks.txt", dtype=np.int64)[[8, 19]]
    xy, _ = project(v[[chin, brow]], face_camera(v), np.pi / 8, DEFAULT_SIZE, DEFAULT_SIZE)
    assert np.all((xy > 0) & (xy < DEFAULT_SIZE))  # brows to chin in the picture
    # the profile view sees the nose tip in the picture too
    xy, depth = project(v[[np.argmax(v[:, 2])]], face_camera(v, side=True), np.pi / 8, 128, 128)
    assert depth[0] > 0 and np.all((xy > 0) & (xy < 128))


def test_vertex_only_ply_folder_shows_the_face(tmp_path, assets_dir, capsys):
    from benchmark.render.__main__ import main
    from blendvoca.io.mesh import write_ply

    v, f = flame_head(assets_dir)
    frames_dir = tmp_path / "frames"
    for t in range(3):
        write_ply(frames_dir / f"frame{t:03d}.ply", v + [0, 0.002 * t, 0])  # vertices only, as the corpus writes
    out = tmp_path / "ply.mp4"
    assert main(["--meshes", str(frames_dir), "--out", str(out), "--size", "64", "--backend", "software"]) == 0
    assert "FLAME template" in capsys.readouterr().err
    frames = read_video(out)[0]
    assert len(frames) == 3 and _face_pixels_std(frames, 64) > 10
    assert (frames < 250).any(axis=-1).mean() > 0.3
    # the same with --faces given explicitly
    from blendvoca.io.mesh import write_mesh

    write_mesh(tmp_path / "template.obj", v, f)
    assert main(["--meshes", str(frames_dir), "--faces", str(tmp_path / "template.obj"), "--out", str(out),
                 "--size", "64", "--backend", "software"]) == 0
    capsys.readouterr()
    # a vertex-only sequence that is not FLAME and no --faces: one error line, exit 2
    other = tmp_path / "other"
    write_ply(other / "a.ply", np.random.default_rng(0).normal(size=(10, 3)))
    assert main(["--meshes", str(other), "--out", str(out), "--backend", "software"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "no faces" in err and "--faces" in err and len(err.splitlines()) == 1


def test_a_render_that_shows_nothing_fails(tmp_path, assets_dir, capsys):
    from benchmark.render import RenderError, check_visible
    from benchmark.render.__main__ import main
    from blendvoca.io.mesh import write_mesh

    with pytest.raises(RenderError, match="show no face"):
        check_visible(np.full((2, 8, 8, 3), 255, np.uint8), where="test")
    v, f = flame_head(assets_dir)
    flat = np.repeat(v[:1], len(v), axis=0)  # every triangle collapsed to a point: nothing drawn
    np.save(tmp_path / "flat.npy", flat[None].repeat(2, axis=0))
    write_mesh(tmp_path / "faces.obj", v, f)
    assert main(["--meshes", str(tmp_path / "flat.npy"), "--faces", str(tmp_path / "faces.obj"),
                 "--out", str(tmp_path / "x.mp4"), "--size", "32", "--backend", "software", "--framing", "head"]) == 2
    assert "the first frame shows no face" in capsys.readouterr().err  # stopped before encoding
    assert not (tmp_path / "x.mp4").exists() and list(tmp_path.glob(".render-*")) == []


def test_a_51_shape_rig_renders_a_32_column_track(tmp_path, assets_dir, capsys):
    from benchmark.render.__main__ import main
    from blendvoca.io.coeffs import write_coeffs_csv
    from blendvoca.names import ARKIT_NAMES, BLENDVOCA_NAMES
    from blendvoca.rig import Rig
    from tests.benchmark.fakes import fake_rig

    v, f = flame_head(assets_dir)
    small = fake_rig(v, f)
    deltas = np.zeros((len(ARKIT_NAMES), *v.shape))
    for k, name in enumerate(ARKIT_NAMES):
        if name in small.names:
            deltas[k] = small.deltas[small.names.index(name)]
    Rig(v, deltas, ARKIT_NAMES, f).save(tmp_path / "rig51.npz")
    coeffs = np.zeros((4, 32))
    coeffs[:, BLENDVOCA_NAMES.index("jawOpen")] = [0, 0.3, 0.6, 1.0]
    write_coeffs_csv(tmp_path / "t.csv", coeffs, BLENDVOCA_NAMES)
    out = tmp_path / "r.mp4"
    assert main(["--coeffs", str(tmp_path / "t.csv"), "--rig", str(tmp_path / "rig51.npz"), "--out", str(out),
                 "--size", "64", "--backend", "software"]) == 0
    err = capsys.readouterr().err
    assert "the rig has 51 shapes, the track lacks 19; they are 0" in err and "eyeBlinkLeft" in err
    frames = read_video(out)[0]
    assert len(frames) == 4 and np.abs(frames[3].astype(int) - frames[0].astype(int)).mean() > 0.5


def test_side_view_waveform_and_audio_length(tmp_path, fake_dataset_dir):
    from benchmark.render.__main__ import main
    from blendvoca.io.audio import load_audio

    subject = fake_dataset_dir / "blendshape_coeffs" / "FakeA" / "sentence01.csv"
    wav = fake_dataset_dir / "audio" / "FakeA" / "sentence01.wav"
    out = tmp_path / "side.mp4"
    assert main(["--coeffs", str(subject), "--rig", str(fake_dataset_dir / "rigs" / "FakeA.npz"), "--audio", str(wav),
                 "--out", str(out), "--size", "48", "--side", "--backend", "software", "--out-fps", "25"]) == 0
    frames, fps, audio = read_video(out)
    assert frames.shape[1:] == (48 + 16, 96, 3)  # front | side, waveform strip under them
    seconds = len(load_audio(wav)) / 16000
    assert abs(len(frames) / fps - seconds) <= 1 / fps
    assert abs(len(audio) / 16000 - seconds) < 0.1
    strip = frames[:, 48:]
    assert (strip[..., 2].astype(int) - strip[..., 0].astype(int) > 40).any()  # blue waveform drawn


def test_the_video_keeps_the_recordings_rate_and_channels(tmp_path, fake_dataset_dir):
    """Issue 57: a 44.1 kHz stereo recording was muxed as 16 kHz mono; the review video keeps it as recorded."""
    import av

    from benchmark.render.__main__ import main
    from blendvoca.io.audio import load_audio, read_audio, write_wav

    speech = load_audio(fake_dataset_dir / "audio" / "FakeA" / "sentence01.wav", rate=44100)
    left_right = np.stack([speech, 0.5 * speech], axis=1)  # the right channel at half the level
    wav = tmp_path / "stereo.wav"
    write_wav(wav, left_right, 44100)
    out = tmp_path / "stereo.mp4"
    assert main(["--coeffs", str(fake_dataset_dir / "blendshape_coeffs" / "FakeA" / "sentence01.csv"), "--rig",
                 str(fake_dataset_dir / "rigs" / "FakeA.npz"), "--audio", str(wav), "--out", str(out), "--size", "32",
                 "--backend", "software", "--out-fps", "25"]) == 0
    with av.open(str(out)) as container:
        (stream,) = container.streams.audio
        assert (stream.codec_context.name, stream.codec_context.sample_rate, stream.codec_context.channels) == \
            ("aac", 44100, 2)
    back, rate = read_audio(out)
    assert rate == 44100 and back.shape[1] == 2
    n = min(len(back), len(left_right)) - 4096  # AAC's priming delay shifts the start by about 1024 samples
    energy = (back[2048:n] ** 2).sum(axis=0)
    assert energy[1] / energy[0] == pytest.approx(0.25, rel=0.1)  # the channels kept apart


def test_waveform_strip_scrolls_with_time():
    from benchmark.render.compose import Waveform

    rate = 1000
    audio = np.r_[np.zeros(500), np.ones(1000), np.zeros(500)]  # sound from 0.5 s to 1.5 s
    wave = Waveform(audio, rate, 1.0, 200, 21, window=2.0)
    strips = np.stack([wave.frame(t) for t in range(3)])  # t = 0, 1, 2 s
    drawn = (strips[:, 0] != 255).any(axis=-1) & (strips[:, 0, :, 0] < 150)  # wave colour in the top row
    # at t = 0 the window is [-1, 1] s: the sound fills 0.5..1 s, the right quarter
    assert drawn[0, 160:].all() and not drawn[0, :140].any()
    assert drawn[1, 60:95].all() and drawn[1, 105:140].all() and not drawn[1, :40].any() and not drawn[1, 160:].any()
    assert drawn[2, :40].all() and not drawn[2, 60:].any()


def _stored_run(tmp_path, dataset, subject, sentence, generated):
    """A protocol-v2 result: R/run.json with tracks/<subject>/<sentence>-0.csv."""
    import json

    from blendvoca.io.coeffs import write_coeffs_csv
    from blendvoca.names import BLENDVOCA_NAMES

    from benchmark.results import build_result

    results = tmp_path / "R"
    write_coeffs_csv(results / "run-tracks" / subject / f"{sentence}-0.csv", generated, BLENDVOCA_NAMES)
    result = build_result(
        method={"name": "open-jaw", "label": "open-jaw", "class": "tests:OpenJaw", "stochastic": False,
                "reference": False, "config": {}, "output": "coefficients"},
        dataset={"manifest_hash": "0" * 64, "path": str(dataset), "split": "test", "num_subjects": 1,
                 "num_sentences": 1},
        protocol={"samples": 1, "seed": 0, "budget": {}, "clip": False, "n_clipped": 0, "checkpoint": None},
        metrics={"lve": {"mean": 1.0, "std": None, "higher_is_better": False, "unit": "mm"}}, timings={},
        tracks="run-tracks")
    (results / "run.json").write_text(json.dumps(result.to_json()))
    return results / "run.json"


def test_side_by_side_from_a_stored_run(tmp_path, fake_dataset_dir, capsys):
    from benchmark.render import render_coeffs
    from benchmark.render.__main__ import main
    from benchmark.render.camera import face_camera
    from blendvoca.io.coeffs import read_coeffs_csv
    from blendvoca.names import BLENDVOCA_NAMES
    from blendvoca.rig import Rig

    gt, _ = read_coeffs_csv(fake_dataset_dir / "blendshape_coeffs" / "FakeB" / "sentence02.csv", names=BLENDVOCA_NAMES)
    generated = gt.copy()
    generated[:, BLENDVOCA_NAMES.index("jawOpen")] = 1.0
    run = _stored_run(tmp_path, fake_dataset_dir, "FakeB", "sentence02", generated)
    out = tmp_path / "sbs.mp4"
    assert main(["--run", str(run), "--subject", "FakeB", "--sentence", "sentence02", "--out", str(out),
                 "--size", "64", "--backend", "software", "--no-waveform", "--fps", "60", "--out-fps", "10"]) == 0
    frames = read_video(out)[0].astype(int)
    assert frames.shape[1:] == (64, 128, 3)
    rig = Rig.load(fake_dataset_dir / "rigs" / "FakeB.npz")
    pose = face_camera(rig.neutral)
    direct = render_coeffs(gt, rig, fps=60, out_fps=10, size=64, backend="software", pose=pose).astype(int)
    count = min(len(direct), len(frames))
    below_label = slice(20, 64)
    left = frames[:count, below_label, :64]
    right = frames[:count, below_label, 64:]
    assert np.abs(left - direct[:count, below_label]).mean() < 4  # left: the ground truth
    assert np.abs(right - direct[:count, below_label]).mean() > 2 * np.abs(left - direct[:count, below_label]).mean()
    capsys.readouterr()
    # a sample the run does not have: one error line naming what it has
    assert main(["--run", str(run), "--subject", "FakeB", "--sentence", "sentence02", "--sample", "3",
                 "--out", str(out), "--backend", "software"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "sentence02-0.csv" in err
    assert main(["--run", str(run), "--subject", "FakeB", "--out", str(out)]) == 2
    assert "--run needs --subject and --sentence" in capsys.readouterr().err


def _one_error_line(capsys, *fragments):
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("note: ")]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    assert all(f in lines[0] for f in fragments), lines[0]
    return lines[0]


def test_an_unsupported_out_suffix_is_refused_before_rendering(fake_dataset_dir, tmp_path, capsys):
    from benchmark.render.__main__ import main

    track = fake_dataset_dir / "blendshape_coeffs" / "FakeC" / "sentence01.csv"
    for out in ("x.txt", "video"):
        assert main(["--coeffs", str(track), "--rig", str(fake_dataset_dir / "rigs" / "FakeC.npz"),
                     "--out", str(tmp_path / out), "--size", "32", "--backend", "software"]) == 2
        _one_error_line(capsys, f"--out {tmp_path / out}", "unsupported file type", "supported: .mp4")
        assert not (tmp_path / out).exists()


def test_nan_coefficients_are_named_as_nan_with_their_frame_and_column(fake_dataset_dir, tmp_path, capsys):
    from benchmark.render.__main__ import main
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv

    coeffs, names = read_coeffs_csv(fake_dataset_dir / "blendshape_coeffs" / "FakeC" / "sentence01.csv")
    track = tmp_path / "nan.csv"
    write_coeffs_csv(track, coeffs[:10], names)
    lines = track.read_text().splitlines()
    column = lines[0].split(",").index("jawOpen")
    for i in range(4, len(lines)):  # frames 3.. (line 1 is the header): what a diverged model writes
        row = lines[i].split(",")
        row[column] = "nan"
        lines[i] = ",".join(row)
    track.write_text("\n".join(lines) + "\n")
    assert main(["--coeffs", str(track), "--rig", str(fake_dataset_dir / "rigs" / "FakeC.npz"),
                 "--out", str(tmp_path / "x.mp4"), "--size", "32", "--backend", "software"]) == 2
    line = _one_error_line(capsys, str(track), "NaN", "frame 3", "'jawOpen'")
    assert "show no face" not in line
    assert not (tmp_path / "x.mp4").exists()


# ------------------------------------------------------------------ speed and constant memory (issue 39)

#: The fast rasteriser against the former one: at most this fraction of pixels may differ
#: (where two triangles tie on a shared edge and either colour is right); measured: none.
PIXEL_TOLERANCE = 1e-3


def _assert_like_the_former_rasteriser(v, f, pose, size):
    from benchmark.render.software import SoftwareRenderer
    from tests.benchmark.reference_rasterizer import reference_rasterize

    new = SoftwareRenderer(f, pose, np.pi / 8, size, size).render(v)
    old = reference_rasterize(v, f, pose, np.pi / 8, size, size)
    differ = (new != old).any(axis=-1)
    assert differ.mean() <= PIXEL_TOLERANCE, differ.mean()
    return new, old


def test_fast_rasteriser_draws_what_the_former_one_drew(assets_dir):
    from benchmark.render import face_camera
    from tests.benchmark.fakes import fake_rig

    v, f = flame_head(assets_dir)
    rig = fake_rig(v, f)
    jaw = np.zeros(len(rig.names))
    jaw[rig.names.index("jawOpen")] = 1.0  # an open mouth: the back of the head seen through it
    for frame in (v, rig.evaluate(jaw)):
        for pose, size in ((face_camera(v), 160), (face_camera(v, side=True), 96), (front_camera(v), 64)):
            new, old = _assert_like_the_former_rasteriser(frame, f, pose, size)
            assert (new < 250).any(axis=-1).mean() > 0.2
    # moved off-centre, partly out of the picture and partly behind the camera
    pose = face_camera(v)
    shifted = v + [0.05, 0.03, 0.0]
    _assert_like_the_former_rasteriser(shifted, f, pose, 64)
    behind = v.copy()
    behind[:, 2] += pose[2, 3] - v[:, 2].mean()  # the camera inside the head
    _assert_like_the_former_rasteriser(behind, f, pose, 64)


def test_fast_rasteriser_on_overlapping_random_triangles():
    """A soup of large, thin, overlapping and degenerate triangles in both windings."""
    rng = np.random.default_rng(3)
    v = rng.normal(size=(300, 3)) * [0.4, 0.4, 0.3]
    f = rng.integers(0, len(v), size=(400, 3))
    f[:5, 1] = f[:5, 0]  # degenerate
    pose = np.eye(4)
    pose[2, 3] = 3.0
    for size in (48, 101):
        new, old = _assert_like_the_former_rasteriser(v, f, pose, size)
        assert (new < 250).any(axis=-1).mean() > 0.3
    # one triangle larger than the picture, and a frame with nothing to draw
    big = np.array([[-20.0, -20.0, 0.0], [20.0, -20.0, 0.0], [0.0, 20.0, 0.0]])
    _assert_like_the_former_rasteriser(big, np.array([[0, 1, 2]]), pose, 32)
    from benchmark.render.software import SoftwareRenderer

    renderer = SoftwareRenderer(np.zeros((0, 3), int), pose, np.pi / 8, 16, 16, num_vertices=3)
    assert (renderer.render(big) == 255).all() and renderer.drawn_fraction == 0


def test_auto_backend_leaves_cpu_opengl_for_the_numpy_rasteriser(monkeypatch):
    import benchmark.render as render

    for name, command, sequence in (("llvmpipe (LLVM 15.0.6, 256 bits)", "software", "pyrender"),
                                    ("NVIDIA H200/PCIe/SSE2", "pyrender", "pyrender"), (None, "software", "software")):
        monkeypatch.setattr(render, "_egl_name", lambda name=name: name)
        assert render.choose_backend("auto", cpu_gl=False) == command  # python -m benchmark.render
        assert render.choose_backend("auto") == sequence  # render_sequence: the SyncNet frames do not change
    assert render.choose_backend("software") == "software"


def _clip(fake_dataset_dir, tmp_path, frames, audio_frames=None):
    """A track of ``frames`` at 60 fps and audio as long as ``audio_frames`` (default the same)."""
    from blendvoca.io.audio import load_audio, write_wav
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv

    coeffs, names = read_coeffs_csv(fake_dataset_dir / "blendshape_coeffs" / "FakeC" / "sentence01.csv")
    track = np.concatenate([coeffs] * (frames // len(coeffs) + 1))[:frames]
    samples = (audio_frames or frames) * 16000 // 60
    audio = load_audio(fake_dataset_dir / "audio" / "FakeC" / "sentence01.wav")
    audio = np.concatenate([audio] * (samples // len(audio) + 1))[:samples]
    csv, wav = tmp_path / f"t{frames}.csv", tmp_path / f"t{frames}.wav"
    write_coeffs_csv(csv, track, names)
    write_wav(wav, audio, 16000)
    return csv, wav


def test_render_memory_does_not_grow_with_the_clip(fake_dataset_dir, tmp_path, monkeypatch):
    """The frames are streamed to ffmpeg: the process's peak allocation (numpy reports its
    arrays to tracemalloc) for a clip 4 times as long stays within 1.2 times (both clips
    longer than the window of frames a source evaluates at once, made short here)."""
    import tracemalloc

    import benchmark.render.sources
    from benchmark.render.__main__ import main

    monkeypatch.setattr(benchmark.render.sources, "CHUNK", 16)
    peaks = {}
    for frames in (60, 240):
        csv, wav = _clip(fake_dataset_dir, tmp_path, frames)
        args = ["--coeffs", str(csv), "--rig", str(fake_dataset_dir / "rigs" / "FakeC.npz"), "--audio", str(wav),
                "--side", "--size", "64", "--backend", "software", "--jobs", "1", "--out", str(tmp_path / f"{frames}.mp4")]
        tracemalloc.start()
        try:
            assert main(args) == 0
            peaks[frames] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert len(read_video(tmp_path / f"{frames}.mp4")[0]) == frames
    # the former path held the clip: 240 frames of 2 views and the strip, 240 * 80 * 128 * 3 = 7 MB, and its vertices
    assert peaks[240] < 1.2 * peaks[60], peaks


def test_worker_processes_write_the_same_video(fake_dataset_dir, tmp_path):
    from benchmark.render.__main__ import main

    csv, wav = _clip(fake_dataset_dir, tmp_path, 30, audio_frames=40)  # the last 10 frames hold the last pose
    outs = []
    for jobs in ("1", "2"):
        outs.append(tmp_path / f"jobs{jobs}.mp4")
        assert main(["--coeffs", str(csv), "--rig", str(fake_dataset_dir / "rigs" / "FakeC.npz"), "--audio", str(wav),
                     "--side", "--size", "64", "--backend", "software", "--jobs", jobs, "--out", str(outs[-1])]) == 0
    a, b = read_video(outs[0])[0], read_video(outs[1])[0]
    assert a.shape == b.shape == (40, 64 + 16, 128, 3) and np.array_equal(a, b)


def test_streamed_render_equals_the_frames_rendered_at_once(fake_dataset_dir, tmp_path):
    """What the CLI streams is what render_coeffs renders into an array (up to the encoder)."""
    from benchmark.render import face_camera, render_coeffs
    from benchmark.render.__main__ import main
    from blendvoca.io.coeffs import read_coeffs_csv
    from blendvoca.rig import Rig

    track = fake_dataset_dir / "blendshape_coeffs" / "FakeA" / "sentence02.csv"
    rig = Rig.load(fake_dataset_dir / "rigs" / "FakeA.npz")
    out = tmp_path / "s.mp4"
    assert main(["--coeffs", str(track), "--rig", str(fake_dataset_dir / "rigs" / "FakeA.npz"), "--out", str(out),
                 "--size", "64", "--backend", "software", "--fps", "60", "--out-fps", "25", "--jobs", "1"]) == 0
    streamed = read_video(out)[0].astype(int)
    coeffs, _ = read_coeffs_csv(track, names=rig.names)
    direct = render_coeffs(coeffs, rig, fps=60, out_fps=25, size=64, backend="software",
                           pose=face_camera(rig.evaluate(coeffs[:1])[0])).astype(int)
    assert streamed.shape == direct.shape
    assert np.abs(streamed - direct).mean() < 2  # H.264 at CRF 10


def test_a_bad_frame_midway_leaves_no_file(tmp_path, assets_dir, capsys):
    from benchmark.render.__main__ import main
    from blendvoca.io.mesh import write_ply

    v, _ = flame_head(assets_dir)
    frames = tmp_path / "frames"
    for t in range(5):
        write_ply(frames / f"f{t}.ply", v + [0, 0.001 * t, 0])
    (frames / "f3.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 5023\n")  # truncated
    out = tmp_path / "x.mp4"
    assert main(["--meshes", str(frames), "--out", str(out), "--size", "32", "--backend", "software"]) == 2
    err = capsys.readouterr().err
    assert "frame 4 of 5" in err and "f3.ply" in err
    assert not out.exists() and list(tmp_path.glob(".render-*")) == []


def test_write_video_streams_an_iterator(tmp_path):
    from benchmark.render.video import write_video

    def frames():
        for t in range(5):
            yield np.full((16, 18, 3), 40 * t, np.uint8)

    audio = np.zeros(16000 * 8 // 25, np.float32)  # 8 frames at 25 fps: the last frame is held
    back, fps, _ = read_video(write_video(tmp_path / "it.mp4", frames(), 25, audio=audio))
    assert back.shape == (8, 16, 18, 3)
    assert abs(int(back[-1].mean()) - 160) <= 2 and abs(int(back[0].mean())) <= 2
