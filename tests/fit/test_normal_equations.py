import numpy as np
import pytest

from blendvoca.fit import normal_equations

from .conftest import drive, make_rig


def test_objective_matches_direct_residuals(rng):
    neutral, deltas = make_rig(rng, 120, 5)
    frames = drive(neutral, deltas, rng.random((7, 5))) + rng.normal(size=(7, 120, 3)) * 1e-3
    coeffs = rng.random((7, 5))
    system = normal_equations(neutral, deltas, frames)
    direct = np.sum((drive(neutral, deltas, coeffs) - frames) ** 2)
    assert system.objective(coeffs) == pytest.approx(direct, rel=1e-10)
    assert system.gram.shape == (5, 5) and system.rhs.shape == (7, 5)
    np.testing.assert_allclose(system.gram, system.gram.T)


def test_vertex_subset_equals_cropped_arrays(rng):
    neutral, deltas = make_rig(rng, 100, 4)
    frames = drive(neutral, deltas, rng.random((3, 4)))
    subset = np.arange(10, 60)
    a = normal_equations(neutral, deltas, frames, vertex_subset=subset)
    b = normal_equations(neutral[subset], deltas[:, subset], frames[:, subset])
    np.testing.assert_allclose(a.gram, b.gram)
    np.testing.assert_allclose(a.rhs, b.rhs)
    assert a.num_vertices == 50


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(neutral=np.zeros((10, 2))), "neutral must be"),
        (dict(deltas=np.zeros((3, 9, 3))), "deltas must be"),
        (dict(frames=np.zeros((4, 11, 3))), "frames must be"),
        (dict(frames=np.full((4, 10, 3), np.nan)), "non-finite"),
    ],
)
def test_bad_shapes_raise(kwargs, match):
    args = dict(neutral=np.zeros((10, 3)), deltas=np.ones((3, 10, 3)), frames=np.zeros((4, 10, 3)))
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        normal_equations(args["neutral"], args["deltas"], args["frames"])


def test_bad_subset_raises(rng):
    neutral, deltas = make_rig(rng, 20, 2)
    with pytest.raises(ValueError, match="vertex_subset"):
        normal_equations(neutral, deltas, neutral[None], vertex_subset=np.array([0, 25]))
    with pytest.raises(TypeError, match="vertex_subset"):
        normal_equations(neutral, deltas, neutral[None], vertex_subset=np.array([0.5]))
    with pytest.raises(TypeError, match="numeric"):
        normal_equations(neutral, deltas, np.array([["a"]]))
