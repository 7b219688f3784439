import numpy as np
import pytest

from benchmark.methods import MethodOutputError, validated_tracks

KW = {"method": "m", "subject": "FaceTalk_x", "sentence": "sentence07", "num_frames": 10, "samples": 2}


def test_valid_output_passes_as_float64():
    out, n = validated_tracks(np.full((2, 10, 32), 0.5, dtype=np.float32), **KW)
    assert out.dtype == np.float64 and out.shape == (2, 10, 32) and n == 0


@pytest.mark.parametrize(
    "output, pattern",
    [
        (np.zeros((10, 32)), "2-d shape"),
        (np.zeros((3, 10, 32)), "expected 2 sample"),
        (np.zeros((2, 9, 32)), "wrong frame count: expected 10 frames"),
        (np.zeros((2, 10, 31)), "expected 32 blendshape coefficients"),
        (None, "returned None"),
        (np.array([["a"]]), "real-valued"),
    ],
)
def test_shape_errors_name_method_subject_sentence(output, pattern):
    with pytest.raises(MethodOutputError, match=pattern) as info:
        validated_tracks(output, **KW)
    msg = str(info.value)
    assert "'m'" in msg and "FaceTalk_x" in msg and "sentence07" in msg


def test_nan_reported_with_position():
    out = np.zeros((2, 10, 32))
    out[1, 4, 3] = np.nan
    with pytest.raises(MethodOutputError, match=r"non-finite.*sample 1, frame 4, coefficient 3"):
        validated_tracks(out, **KW)


def test_out_of_range_refused_unless_clip():
    out = np.zeros((2, 10, 32))
    out[0, 2, 5] = 1.0 + 1e-9
    with pytest.raises(MethodOutputError, match=r"outside \[0, 1\].*frame 2, coefficient 5"):
        validated_tracks(out, **KW)
    clipped, n = validated_tracks(out, clip=True, **KW)
    assert n == 1 and clipped.max() == 1.0


def test_torch_tensor_accepted():
    torch = pytest.importorskip("torch")
    out, _ = validated_tracks(torch.full((2, 10, 32), 0.25, requires_grad=True), **KW)
    assert np.allclose(out, 0.25)
