"""Every export format written and read back; GLB and USD checked against the rig."""

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from blendvoca.export import FORMATS, detect_format, export_track, read_track
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_HEADER


def _by_name(coeffs, names, wanted):
    return coeffs[:, [list(names).index(n) for n in wanted]]


@pytest.mark.parametrize("fmt,suffix", [("livelink", ".csv"), ("arkit-json", ".json"), ("a2f-json", ".json"),
                                        ("glb", ".glb"), ("usd", ".usda"), ("usd", ".usdc"), ("csv", ".csv")])
def test_round_trip(tmp_path, small_rig, track, fmt, suffix):
    coeffs, names = track
    out = tmp_path / f"take{suffix}"
    aligned = export_track(out, coeffs, names, fmt, rig=small_rig, fps=60.0)
    assert aligned.dropped == ()
    assert detect_format(out) == fmt
    back, back_names, fps = read_track(out)
    assert fps == pytest.approx(60.0)
    assert back.shape[0] == len(coeffs)
    np.testing.assert_allclose(_by_name(back, back_names, names), coeffs, atol=1e-6)
    others = [k for k, n in enumerate(back_names) if n not in names]
    assert np.all(back[:, others] == 0)  # shapes the track lacks are written as 0


def test_livelink_layout(tmp_path, track):
    coeffs, names = track
    out = tmp_path / "take.csv"
    export_track(out, coeffs, names, "livelink", fps=60.0)
    lines = out.read_text().splitlines()
    assert lines[0] == ",".join(LIVELINK_HEADER)
    assert len(lines[0].split(",")) == 63 and lines[0].startswith("Timecode,BlendShapeCount,EyeBlinkLeft,")
    rows = [line.split(",") for line in lines[1:]]
    assert all(len(r) == 63 for r in rows) and {r[1] for r in rows} == {"61"}
    # SMPTE-style HH:MM:SS:FF.fff at 60 fps: frame 61 is 1 s and 1 frame
    assert rows[0][0] == "00:00:00:00.000" and rows[59][0] == "00:00:00:59.000" and rows[61][0] == "00:00:01:01.000"
    assert rows[0][LIVELINK_HEADER.index("HeadYaw")] == "0.0000000000"
    t = LIVELINK_HEADER.index("JawOpen")
    assert float(rows[5][t]) == pytest.approx(coeffs[5, names.index("jawOpen")], abs=1e-9)
    assert LIVELINK_HEADER.index("JawRight") < LIVELINK_HEADER.index("JawLeft")  # the app's order


def test_livelink_timecode_at_other_rates():
    from blendvoca.export.livelink import livelink_timecode, parse_livelink_timecode

    assert livelink_timecode(3 * 3600 * 30 + 29, 30) == "03:00:00:29.000"
    assert livelink_timecode(1, 29.97) == "00:00:00:01.000"
    for fps in (24, 25, 29.97, 30, 60):
        for frame in (0, 7, 1000, 123457):
            assert parse_livelink_timecode(livelink_timecode(frame, fps), fps) == pytest.approx(frame / fps, abs=1e-3 / fps)
    with pytest.raises(ValueError, match="HH:MM:SS:FF"):
        parse_livelink_timecode("12.5", 60)


def test_livelink_round_trip_at_59_94_fps(tmp_path):
    """A track written at 59.94 fps with its timecodes reads back at 59.94 fps: resampled to 60 fps it
    holds the same values at the same times, within linear interpolation's error."""
    from blendvoca.fit.resample import resample_sequence

    fps, freq, names = 59.94, np.array([0.7, 1.3, 2.1]), ("jawOpen", "mouthClose", "mouthFunnel")

    def truth(t):
        return 0.5 + 0.4 * np.sin(2 * np.pi * freq * t[:, None] + np.array([0.0, 1.0, 2.0]))

    frames = int(20 * fps)
    out = tmp_path / "take.csv"
    export_track(out, truth(np.arange(frames) / fps), names, "livelink", fps=fps)
    back, back_names, rate = read_track(out)
    assert rate == pytest.approx(59.94, abs=1e-3) and back.shape == (frames, 52)
    at_60 = resample_sequence(_by_name(back, back_names, names), rate, 60.0)
    t = np.arange(len(at_60)) / 60.0
    inside = t <= (frames - 1) / fps  # past the last frame the resampler holds it
    bound = (1 / fps) ** 2 / 8 * 0.4 * (2 * np.pi * freq.max()) ** 2  # h^2 / 8 max|f''|
    assert np.abs(at_60[inside] - truth(t[inside])).max() <= bound
    # taken as 60 fps, the rows drift 1.2 frames behind over 20 s
    as_60 = _by_name(back, back_names, names)
    assert np.abs(as_60 - truth(np.arange(frames) / 60.0)).max() > 10 * bound


def test_json_layouts(tmp_path, track):
    coeffs, names = track
    export_track(tmp_path / "a.json", coeffs, names, "arkit-json", fps=30.0)
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["blendShapeNames"] == list(ARKIT_FACE_ORDER) and len(doc["blendShapeNames"]) == 52
    assert doc["frameRate"] == 30.0 and len(doc["weights"]) == len(coeffs) and len(doc["weights"][0]) == 52
    assert doc["timestamps"][3] == pytest.approx(0.1)
    export_track(tmp_path / "b.json", coeffs, names, "a2f-json", fps=60.0, audio=__file__)
    doc = json.loads((tmp_path / "b.json").read_text())
    assert sorted(doc) == ["exportFps", "facsNames", "numFrames", "numPoses", "trackPath", "weightMat"]
    assert doc["exportFps"] == 60 and doc["numPoses"] == 52 and doc["numFrames"] == len(coeffs)
    assert doc["trackPath"].endswith("test_formats.py")


def test_glb_structure_matches_the_rig(tmp_path, small_rig, track):
    from blendvoca.export.glb import read_glb

    coeffs, names = track
    export_track(tmp_path / "a.glb", coeffs, names, "glb", rig=small_rig)
    glb = read_glb(tmp_path / "a.glb")
    assert glb.names == small_rig.names and glb.deltas.shape == (32, small_rig.num_vertices, 3)
    assert glb.weights.shape == (len(coeffs), 32) and len(glb.times) == len(coeffs)
    np.testing.assert_allclose(glb.times, np.arange(len(coeffs)) / 60, atol=1e-6)
    np.testing.assert_allclose(glb.neutral, small_rig.neutral, atol=1e-7)
    np.testing.assert_allclose(glb.deltas, small_rig.deltas, atol=1e-7)
    np.testing.assert_array_equal(glb.faces, small_rig.faces)
    # trimesh, an independent glTF reader, sees the same mesh
    import trimesh

    scene = trimesh.load(tmp_path / "a.glb", process=False)
    mesh = next(iter(scene.geometry.values())) if hasattr(scene, "geometry") else scene
    assert len(mesh.vertices) == small_rig.num_vertices and len(mesh.faces) == len(small_rig.faces)


def _validator_prefix():
    import os
    from pathlib import Path

    prefix = Path(os.environ.get("BLENDVOCA_NPM_PREFIX", ".cache/npm"))
    return prefix if (prefix / "node_modules" / "gltf-validator").is_dir() and shutil.which("node") else None


@pytest.mark.skipif(_validator_prefix() is None, reason="npm gltf-validator not installed "
                    "(CI installs it into .cache/npm; set BLENDVOCA_NPM_PREFIX to its prefix)")
def test_glb_passes_the_khronos_validator(tmp_path, small_rig, track):
    from blendvoca.export.glb import validate_glb

    coeffs, names = track
    export_track(tmp_path / "a.glb", coeffs, names, "glb", rig=small_rig)
    report = validate_glb(tmp_path / "a.glb", _validator_prefix())
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"][:5]
    assert report["issues"]["numWarnings"] == 0
    assert report["info"]["animationCount"] == 1 and report["info"]["hasMorphTargets"]
    assert report["info"]["totalVertexCount"] == small_rig.num_vertices


def test_usd_skinning_reproduces_the_rig(tmp_path, small_rig, track):
    """UsdSkel's own blend-shape evaluation gives the rig's vertices at each frame."""
    from pxr import Usd, UsdSkel, Vt

    coeffs, names = track
    export_track(tmp_path / "a.usdc", coeffs, names, "usd", rig=small_rig, audio=__file__)
    stage = Usd.Stage.Open(str(tmp_path / "a.usdc"))
    assert stage.GetTimeCodesPerSecond() == 60 and stage.GetEndTimeCode() == len(coeffs) - 1
    cache = UsdSkel.Cache()
    root = UsdSkel.Root(stage.GetPrimAtPath("/Face"))
    cache.Populate(root, Usd.PrimDefaultPredicate)
    binding = cache.ComputeSkelBindings(root, Usd.PrimDefaultPredicate)[0]
    query = cache.GetSkelQuery(binding.GetSkeleton())
    skinning = binding.GetSkinningTargets()[0]
    shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(skinning.GetPrim()))
    mapper = skinning.GetBlendShapeMapper()
    assert len(skinning.GetBlendShapeOrder()) == 32
    sub = shapes.ComputeSubShapePointOffsets()
    point_indices = shapes.ComputeBlendShapePointIndices()
    neutral = skinning.GetPrim().GetAttribute("points").Get()
    for t in (0, 17, 119):
        weights = query.GetAnimQuery().ComputeBlendShapeWeights(Usd.TimeCode(t))
        mapped = mapper.Remap(weights) if mapper and not mapper.IsNull() else weights
        sub_w, shape_i, sub_i = shapes.ComputeSubShapeWeights(mapped)
        points = Vt.Vec3fArray(neutral)
        assert shapes.ComputeDeformedPoints(sub_w, shape_i, sub_i, point_indices, sub, points)
        expected = small_rig.evaluate(coeffs[t])
        np.testing.assert_allclose(np.asarray(points), expected, atol=1e-6)
    from blendvoca.export.usd import read_usd

    assert read_usd(tmp_path / "a.usdc").audio.endswith("test_formats.py")


def test_cli(tmp_path, small_rig, track, capsys):
    from blendvoca.export.__main__ import main
    from blendvoca.io.coeffs import write_coeffs_csv

    coeffs, names = track
    write_coeffs_csv(tmp_path / "t.csv", coeffs[:, :30], names[:30])
    small_rig.save(tmp_path / "rig.npz")
    assert main(["--coeffs", str(tmp_path / "t.csv"), "--format", "glb", "--rig", str(tmp_path / "rig.npz"),
                 "--out", str(tmp_path / "t.glb")]) == 0
    captured = capsys.readouterr()
    assert "2 shapes of the target; they are 0: noseSneerLeft, noseSneerRight" in captured.err
    assert main(["--coeffs", str(tmp_path / "t.csv"), "--format", "usd", "--out", str(tmp_path / "t.usda")]) == 2
    assert "error: --format usd needs --rig" in capsys.readouterr().err
    assert main(["--coeffs", str(tmp_path / "nope.csv"), "--format", "livelink", "--out", str(tmp_path / "x.csv")]) == 2
    assert "error: coefficient file not found" in capsys.readouterr().err
    out = subprocess.run([__import__("sys").executable, "-m", "blendvoca.export", "--coeffs", str(tmp_path / "t.csv"),
                          "--format", "a2f-json", "--out", str(tmp_path / "t.json")], capture_output=True, text=True)
    assert out.returncode == 0 and "wrote" in out.stdout


def test_bad_tracks(tmp_path, small_rig):
    with pytest.raises(ValueError, match="unknown blendshape names \\['smile'\\]"):
        export_track(tmp_path / "a.json", np.zeros((3, 1)), ["smile"], "arkit-json")
    with pytest.raises(ValueError, match="NaN/inf at frame 1, column 'jawOpen'"):
        export_track(tmp_path / "a.json", np.array([[0.0], [np.nan]]), ["jawOpen"], "arkit-json")
    with pytest.raises(ValueError, match="needs a rig"):
        export_track(tmp_path / "a.glb", np.zeros((3, 1)), ["jawOpen"], "glb")
    assert set(FORMATS) >= {"livelink", "arkit-json", "a2f-json", "glb", "usd"}


def test_usd_and_a2f_reference_the_audio_relatively_and_move_with_it(tmp_path, track, small_rig):
    """Issue 57: the USD and Audio2Face exports wrote absolute audio paths (the file broke when moved)."""
    from pxr import Sdf, Usd, UsdMedia

    from blendvoca.export.__main__ import main
    from blendvoca.io.audio import write_wav

    coeffs, names = track
    wav = tmp_path / "speech" / "take 1.wav"
    wav.parent.mkdir()
    write_wav(wav, np.zeros(1600, np.float32), 16000)
    export_track(tmp_path / "out" / "a.usda", coeffs, names, "usd", rig=small_rig, audio=wav)
    export_track(tmp_path / "out" / "a.json", coeffs, names, "a2f-json", audio=wav)
    assert json.loads((tmp_path / "out" / "a.json").read_text())["trackPath"] == "../speech/take 1.wav"
    # with the copy, the export and its sound move together to another place
    export_track(tmp_path / "out" / "b.usda", coeffs, names, "usd", rig=small_rig, audio=wav, copy_audio=True)
    export_track(tmp_path / "out" / "b.json", coeffs, names, "a2f-json", audio=wav, copy_audio=True)
    assert (tmp_path / "out" / "take 1.wav").read_bytes() == wav.read_bytes()
    moved = tmp_path / "elsewhere"
    (tmp_path / "out").rename(moved)
    assert json.loads((moved / "b.json").read_text())["trackPath"] == "take 1.wav"
    stage = Usd.Stage.Open(str(moved / "b.usda"))
    (sound,) = [UsdMedia.SpatialAudio(p) for p in stage.Traverse() if p.IsA(UsdMedia.SpatialAudio)]
    asset = sound.GetFilePathAttr().Get()
    assert asset.path == "take 1.wav"
    resolved = stage.GetRootLayer().ComputeAbsolutePath(asset.path)
    assert Path(resolved) == moved / "take 1.wav" and Path(resolved).is_file()
    assert isinstance(asset, Sdf.AssetPath)
    # a different file of the sound's name beside the export is never replaced
    (moved / "take 1.wav").write_bytes(b"mine")
    assert main(["--coeffs", str(_csv(tmp_path, coeffs, names)), "--format", "a2f-json", "--out",
                 str(moved / "c.json"), "--audio", str(wav), "--copy-audio"]) == 2
    assert (moved / "take 1.wav").read_bytes() == b"mine" and not (moved / "c.json").exists()


def _csv(tmp_path, coeffs, names):
    from blendvoca.io.coeffs import write_coeffs_csv

    path = tmp_path / "track.csv"
    write_coeffs_csv(path, coeffs, names)
    return path
