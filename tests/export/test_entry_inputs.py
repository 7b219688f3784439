"""``export_track``, ``read_track`` and ``load_rig`` take ``str`` or any ``os.PathLike``
path and tracks of any real dtype, and say what they need when they cannot convert."""

import numpy as np
import pytest

from blendvoca.errors import DataError, UserError
from blendvoca.export import FORMATS, detect_format, export_track, load_rig, read_track
from tests.fixtures.paths import FsPath


SUFFIX = {"livelink": ".csv", "arkit-json": ".json", "a2f-json": ".json", "glb": ".glb", "usd": ".usda", "fbx": ".fbx",
          "csv": ".csv"}


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_format_through_a_pathlike_with_a_float32_track(fmt, track, small_rig, tmp_path, monkeypatch):
    if fmt == "fbx":  # written and read by Blender: needs bpy (skipped with its install command where absent)
        from tests.export.test_blender import bpy_python

        monkeypatch.setenv("BLENDVOCA_BPY_PYTHON", bpy_python())
    coeffs, names = track
    out = FsPath(tmp_path / f"t{SUFFIX[fmt]}")
    aligned = export_track(out, coeffs.astype(np.float32), names, fmt, rig=small_rig, fps=60.0)
    assert detect_format(out) == fmt
    back, back_names, _ = read_track(out, fmt)
    columns = [back_names.index(n) for n in aligned.names]
    np.testing.assert_allclose(back[:, columns], aligned.coeffs, atol=1e-6)
    np.testing.assert_allclose(aligned.coeffs[:, list(aligned.names).index(names[2])],
                               coeffs[:, 2].astype(np.float32), rtol=0)


def test_load_rig_through_any_path(small_rig, tmp_path):
    small_rig.save(tmp_path / "rig.npz")
    small_rig.save_said_folder(tmp_path / "said")
    assert load_rig(FsPath(tmp_path / "rig.npz")) == small_rig
    assert sorted(load_rig(str(tmp_path / "said")).names) == sorted(small_rig.names)  # SAiD folder: ARKit order


def test_a_track_that_is_not_numbers_says_what_is_needed(track, tmp_path):
    _, names = track
    with pytest.raises(UserError, match=r"coeffs as a \(T, 32\) array of real numbers"):
        export_track(tmp_path / "t.json", [["x"] * 32], names, "arkit-json")
    with pytest.raises(UserError, match="unknown format"):
        export_track(tmp_path / "t.json", np.zeros((2, 32)), names, "maya")


def test_a_json_that_does_not_parse_names_the_file(tmp_path):
    (tmp_path / "t.json").write_text("{ not json")
    with pytest.raises(DataError, match=r"t\.json: not a JSON file \(line 1"):
        read_track(FsPath(tmp_path / "t.json"))
    with pytest.raises(UserError, match="unknown suffix '.max'"):
        detect_format(FsPath(tmp_path / "t.max"))
