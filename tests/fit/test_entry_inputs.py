"""``fit_coefficients`` / ``fit_rig`` take arrays of any real dtype (float32 meshes as
VOCASET stores them) and say what they need when the input is not numbers."""

import numpy as np
import pytest

from blendvoca.errors import UserError
from blendvoca.fit import fit_coefficients, fit_rig, fit_sequence
from blendvoca.rig import Rig

from .conftest import drive, make_rig, smooth_track


@pytest.fixture
def problem(rng):
    neutral, deltas = make_rig(rng, num_vertices=120, num_shapes=4)
    coeffs = smooth_track(rng, 40, 4)
    return neutral, deltas, drive(neutral, deltas, coeffs), coeffs


@pytest.mark.parametrize("dtype", [np.float16, np.float32])
def test_any_float_dtype_fits_as_its_float64_values(problem, dtype):
    neutral, deltas, frames, _ = problem
    low = [a.astype(dtype) for a in (neutral, deltas, frames)]
    got = fit_coefficients(*low, unposed=True)
    expected = fit_coefficients(*(a.astype(np.float64) for a in low), unposed=True)
    assert got.dtype == np.float64 and got.shape == (40, 4)
    np.testing.assert_allclose(got, expected, atol=1e-9)


def test_float32_recovers_the_driving_coefficients(problem):
    neutral, deltas, frames, coeffs = problem
    got = fit_coefficients(neutral.astype(np.float32), deltas.astype(np.float32), frames.astype(np.float32),
                           unposed=True)
    np.testing.assert_allclose(got, coeffs, atol=1e-3)  # float32 rounding of metre-scale positions
    rig = Rig(neutral.astype(np.float32), deltas.astype(np.float32), ("jawOpen", "jawLeft", "jawRight", "mouthClose"),
              np.zeros((0, 3), np.int64))
    np.testing.assert_allclose(fit_rig(rig, frames.astype(np.float32), unposed=True), got, atol=1e-12)
    assert fit_sequence(neutral, deltas, frames.astype(np.float32), unposed=True).coeffs.shape == (40, 4)


def test_input_that_is_not_numbers_says_what_is_needed(problem):
    neutral, deltas, frames, _ = problem
    with pytest.raises(TypeError, match="frames must be a numeric array"):
        fit_coefficients(neutral, deltas, np.full(frames.shape, "x"), unposed=True)
    with pytest.raises(UserError, match="frames must have 3 dimensions"):
        fit_coefficients(neutral, deltas, frames[0], unposed=True)
    with pytest.raises(UserError, match="rate_bound must be a positive finite number"):
        fit_coefficients(neutral, deltas, frames, rate_bound=-1.0, unposed=True)
    with pytest.raises(UserError, match="solver must be one of"):
        fit_coefficients(neutral, deltas, frames, solver="newton", unposed=True)


def test_fit_coefficients_takes_fit_sequences_keywords_and_defaults(problem):
    neutral, deltas, frames, _ = problem
    options = dict(unposed=True, rate_bound=0.05, vertex_subset=np.arange(0, 120, 2))
    expected = fit_sequence(neutral, deltas, frames, **options).coeffs
    np.testing.assert_array_equal(fit_coefficients(neutral, deltas, frames, **options), expected)
    with pytest.warns(DeprecationWarning, match="delta= is removed after"):
        old = fit_coefficients(neutral, deltas, frames, unposed=True, delta=0.05,
                               vertex_subset=options["vertex_subset"])
    np.testing.assert_array_equal(old, expected)
    with pytest.raises(TypeError, match=r"fit_coefficients\(\) got unexpected keyword arguments \['rate_bnd'\]"):
        fit_coefficients(neutral, deltas, frames, rate_bnd=0.1)


def test_the_qp_solvers_refuse_a_gram_of_another_size(problem):
    from blendvoca.fit import framewise_coefficients, least_squares_coefficients, solve_banded_qp

    for solve in (framewise_coefficients, least_squares_coefficients, solve_banded_qp):
        with pytest.raises(UserError, match=r"gram must be \(4, 4\) to match rhs \(3, 4\), got \(3, 3\)"):
            solve(np.eye(3), np.zeros((3, 4)))
