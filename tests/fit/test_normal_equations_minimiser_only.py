import numpy as np

from blendvoca.fit.normal_equations import check_rig_and_frames, normal_equations_of_checked


def test_minimiser_only_normal_equations_match_bit_for_bit():
    # offset_sq=False (what fit_coefficients asks for) skips ||p_t - n||^2 only:
    # the Gram matrix and right-hand sides are the same arrays, eager and chunked.
    rng = np.random.default_rng(0)
    neutral = rng.normal(size=(40, 3))
    deltas = rng.normal(size=(4, 40, 3)) * 0.1
    frames = neutral + rng.normal(size=(7, 40, 3)) * 0.05
    subset = np.arange(0, 40, 2)
    for lazy in (False, True):
        checked = check_rig_and_frames(neutral, deltas, frames, subset, lazy=lazy)
        full = normal_equations_of_checked(*checked)
        checked = check_rig_and_frames(neutral, deltas, frames, subset, lazy=lazy)
        lean = normal_equations_of_checked(*checked, offset_sq=False)
        np.testing.assert_array_equal(full.gram, lean.gram)
        np.testing.assert_array_equal(full.rhs, lean.rhs)
        assert lean.offset_sq is None and full.offset_sq.shape == (7,)
