"""Synthetic rigs and sequences with known coefficients for the fit tests."""

import numpy as np
import pytest


def make_rig(rng, num_vertices=300, num_shapes=8, scale=1e-2):
    """A random rig in metres-like units: neutral (V, 3), deltas (K, V, 3)."""
    neutral = rng.normal(size=(num_vertices, 3)) * 0.1
    deltas = rng.normal(size=(num_shapes, num_vertices, 3)) * scale
    return neutral, deltas


def smooth_track(rng, num_frames, num_shapes, max_rate=0.08):
    """Coefficients in [0.05, 0.95] whose per-frame change stays below max_rate."""
    t = np.arange(num_frames)[:, None]
    freq = rng.uniform(0.002, 0.01, size=num_shapes)
    phase = rng.uniform(0, 2 * np.pi, size=num_shapes)
    track = 0.5 + 0.45 * np.sin(2 * np.pi * freq * t + phase)
    assert np.abs(np.diff(track, axis=0)).max() < max_rate
    return track


def drive(neutral, deltas, coeffs):
    return neutral + np.einsum("tk,kvc->tvc", coeffs, deltas)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture
def active_problem(rng):
    """A sequence whose fit hits every constraint: fast, out-of-range targets plus noise."""
    neutral, deltas = make_rig(rng, num_vertices=200, num_shapes=8)
    num_frames = 50
    t = np.arange(num_frames)[:, None]
    target = 0.5 + 0.9 * np.sin(2 * np.pi * rng.uniform(0.02, 0.08, 8) * t + rng.uniform(0, 6, 8))
    frames = drive(neutral, deltas, target) + rng.normal(size=(num_frames, 200, 3)) * 1e-3
    return neutral, deltas, frames
