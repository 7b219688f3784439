"""The head crop made chunk by chunk from the stored frames: the same fit, bit for bit."""

import numpy as np

from blendvoca.format.hashing import array_digest
from blendvoca.fit import fit_sequence
from blendvoca.fit.diagnostics import vertex_errors_of_checked
from blendvoca.fit.frame_crop import CHUNK_FRAMES, FrameCrop
from blendvoca.fit.normal_equations import check_rig_and_frames, normal_equations_of_checked

from .conftest import drive, make_rig, smooth_track


def _problem(rng, num_frames=2 * CHUNK_FRAMES + 7):
    neutral, deltas = make_rig(rng, 400, 6)
    frames = drive(neutral, deltas, smooth_track(rng, num_frames, 6)) + rng.normal(size=(num_frames, 400, 3)) * 1e-3
    return neutral, deltas, frames.astype(np.float32), np.sort(rng.choice(400, 250, replace=False))


def test_chunked_products_equal_the_whole_crop_bit_for_bit(rng):
    neutral, deltas, frames32, subset = _problem(rng)
    frames = frames32.astype(np.float64)
    eager = check_rig_and_frames(neutral, deltas, frames, subset)
    lazy = check_rig_and_frames(neutral, deltas, frames32, subset, lazy=True)
    assert isinstance(lazy[2], FrameCrop) and lazy[2].frames.dtype == np.float32 and lazy[2].shape == eager[2].shape
    assert np.array_equal(np.concatenate([crop for _, crop in lazy[2].chunks()]), eager[2])
    a, b = normal_equations_of_checked(*eager), normal_equations_of_checked(*lazy)
    assert np.array_equal(a.gram, b.gram) and np.array_equal(a.rhs, b.rhs) and np.array_equal(a.offset_sq, b.offset_sq)
    coeffs = rng.random((frames.shape[0], 6))
    for x, y in zip(vertex_errors_of_checked(*eager, coeffs), vertex_errors_of_checked(*lazy, coeffs)):
        assert np.array_equal(x, y)


def test_float32_frames_fit_as_their_float64_values(rng):
    neutral, deltas, frames32, subset = _problem(rng)
    a = fit_sequence(neutral, deltas, frames32.astype(np.float64), vertex_subset=subset, unposed=True)
    b = fit_sequence(neutral, deltas, frames32, vertex_subset=subset, unposed=True)
    assert np.array_equal(a.coeffs, b.coeffs) and a.objective == b.objective
    assert np.array_equal(a.rmse, b.rmse) and np.array_equal(a.max_error, b.max_error)


def test_digest_as_another_dtype_equals_the_converted_digest(rng):
    frames = rng.normal(size=(37, 11, 3)).astype(np.float32)
    assert array_digest(frames, dtype=np.float64) == array_digest(frames.astype(np.float64))
    assert array_digest(frames, dtype=np.float32) == array_digest(frames)
    assert array_digest(frames[:0], dtype=np.float64) == array_digest(frames[:0].astype(np.float64))
