import numpy as np
import pytest

from blendvoca.fit import fit_coefficients, resample_sequence

from .conftest import drive, make_rig, smooth_track


def test_linear_motion_resampled_exactly():
    t_in = np.arange(30) / 30.0
    frames = np.stack([(1 + 2 * t) * np.ones((3, 3)) for t in t_in])  # (30, 3, 3) affine in time
    out = resample_sequence(frames, 30, 60)
    assert out.shape == (60, 3, 3)
    t_out = np.minimum(np.arange(60) / 60.0, t_in[-1])
    expected = np.stack([(1 + 2 * t) * np.ones((3, 3)) for t in t_out])
    np.testing.assert_allclose(out, expected, atol=1e-12)


def test_identity_and_round_trip():
    rng = np.random.default_rng(0)
    frames = rng.normal(size=(25, 4, 3))
    np.testing.assert_array_equal(resample_sequence(frames, 60, 60), frames)
    up = resample_sequence(frames, 30, 60)
    np.testing.assert_allclose(up[::2], frames)  # every other 60 fps frame is an input frame
    np.testing.assert_allclose(resample_sequence(up, 60, 30), frames)


def test_num_frames_and_errors():
    frames = np.zeros((10, 2))
    assert resample_sequence(frames, 25, 60).shape == (24, 2)
    assert resample_sequence(frames, 25, 60, num_frames=7).shape == (7, 2)
    with pytest.raises(ValueError, match="fps_in"):
        resample_sequence(frames, 0, 60)
    with pytest.raises(ValueError, match="frames"):
        resample_sequence(np.zeros((0, 3)), 30, 60)


def test_fit_at_other_frame_rate(rng):
    neutral, deltas = make_rig(rng, 100, 4)
    truth60 = smooth_track(rng, 60, 4)
    frames30 = drive(neutral, deltas, truth60[::2])
    coeffs = fit_coefficients(neutral, deltas, frames30, fps=30)
    assert coeffs.shape == (60, 4)
    # Linear interpolation of a smooth track: close to the 60 fps truth, exact at even frames.
    np.testing.assert_allclose(coeffs[:-1:2], truth60[:-1:2], atol=1e-6)
    assert np.abs(coeffs[:-1] - truth60[:-1]).max() < 1e-3
