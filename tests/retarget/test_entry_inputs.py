"""``retarget_rig`` takes arrays of any real dtype and ``retarget_files`` any path type;
both say what they need when they cannot convert."""

import json

import numpy as np
import pytest
import trimesh

from blendvoca.errors import UserError
from blendvoca.io.mesh import write_obj
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.retarget import retarget_rig
from blendvoca.retarget.cli import retarget_files
from blendvoca.rig import Rig
from tests.fixtures.paths import FsPath


@pytest.fixture(scope="module")
def small():
    m = trimesh.creation.icosphere(subdivisions=2)
    V, F = np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)
    deltas = np.stack([0.05 * np.sin((k + 1) * V) for k in range(len(BLENDVOCA_NAMES))])
    rig = Rig(V, deltas, BLENDVOCA_NAMES, F)
    landmarks = np.arange(0, 68 * 2, 2)
    return rig, V, F, landmarks


@pytest.mark.parametrize("dtype", [np.float16, np.float32])
def test_retarget_rig_takes_any_float_dtype(small, dtype):
    rig, V, F, lm = small
    target = (2.0 * V).astype(dtype)
    got = retarget_rig(rig, target, F.astype(np.int32), lm.tolist(), lm.astype(np.int32), shapes=["jawOpen"])
    expected = retarget_rig(rig, target.astype(np.float64), F, lm, lm, shapes=["jawOpen"])
    assert got.neutral.dtype == np.float64
    np.testing.assert_array_equal(got.neutral, target.astype(np.float64))
    np.testing.assert_allclose(got.deltas, expected.deltas, rtol=0, atol=1e-12)


def test_retarget_rig_says_what_it_needs(small):
    rig, V, F, lm = small
    with pytest.raises(UserError, match=r"target_vertices as a \(V, 3\) array of real numbers"):
        retarget_rig(rig, np.full(V.shape, "x"), F, lm, lm, shapes=["jawOpen"])
    with pytest.raises(UserError, match="got complex values"):
        retarget_rig(rig, V.astype(complex), F, lm, lm, shapes=["jawOpen"])
    with pytest.raises(TypeError, match="integer target_faces"):
        retarget_rig(rig, V, F + 0.5, lm, lm, shapes=["jawOpen"])


def test_retarget_files_through_any_path(small, tmp_path):
    rig, V, F, lm = small
    rig.save_said_folder(tmp_path / "source")
    np.savetxt(tmp_path / "landmarks.txt", lm, fmt="%d")
    write_obj(tmp_path / "target.obj", 1.5 * V, F)
    report = retarget_files(FsPath(tmp_path / "target.obj"), str(tmp_path / "landmarks.txt"), FsPath(tmp_path / "out"),
                            source_rig=FsPath(tmp_path / "source"), source_landmarks=FsPath(tmp_path / "landmarks.txt"),
                            sheet=False)
    assert report["summary"]["shapes"] == len(BLENDVOCA_NAMES)
    assert json.loads((tmp_path / "out" / "report.json").read_text())["summary"] == report["summary"]
    out = Rig.load(tmp_path / "out" / "rig.npz")
    np.testing.assert_allclose(out.neutral, 1.5 * V, rtol=1e-8)  # the OBJ keeps 9 significant digits
    assert "target.obj" in (tmp_path / "out" / "report.md").read_text()
