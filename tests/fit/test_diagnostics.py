import numpy as np

from blendvoca.fit import constraint_activity, vertex_errors


def test_vertex_errors_closed_form():
    neutral = np.zeros((4, 3))
    deltas = np.zeros((1, 4, 3))
    deltas[0, :, 0] = 1.0
    frames = np.zeros((2, 4, 3))
    frames[0, 2] = [0.0, 3.0, 4.0]  # one vertex 5 away
    rmse, max_error = vertex_errors(neutral, deltas, frames, np.zeros((2, 1)))
    np.testing.assert_allclose(max_error, [5.0, 0.0])
    np.testing.assert_allclose(rmse, [np.sqrt(25 / 4), 0.0])
    rmse, max_error = vertex_errors(neutral, deltas, frames, np.ones((2, 1)))
    np.testing.assert_allclose(max_error, [np.sqrt(26), 1.0])


def test_constraint_activity_counts():
    coeffs = np.array([[0.0, 1.0], [0.1, 1.0], [0.15, 0.5]])
    act = constraint_activity(coeffs, rate_bound=0.1)
    np.testing.assert_allclose(act["lower"], [1 / 3, 0])
    np.testing.assert_allclose(act["upper"], [0, 2 / 3])
    np.testing.assert_allclose(act["rate"], [0.5, 0.5])
    assert np.all(constraint_activity(coeffs, rate_bound=None)["rate"] == 0)
