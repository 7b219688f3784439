import numpy as np
import pytest

from tests.benchmark.fakes import fake_rig, flame_head


@pytest.fixture(scope="session")
def small_rig(assets_dir):
    """The 32-shape fake rig on the FLAME sample head (5023 vertices)."""
    v, f = flame_head(assets_dir)
    return fake_rig(v, f)


@pytest.fixture
def track(small_rig):
    """A 2 s, 32-column track at 60 fps with values across [0, 1]."""
    rng = np.random.default_rng(3)
    t = np.arange(120)[:, None] / 60.0
    coeffs = 0.5 + 0.5 * np.sin(2 * np.pi * (rng.uniform(0.5, 3, 32) * t + rng.uniform(0, 1, 32)))
    coeffs[0] = 0.0
    coeffs[1] = 1.0
    return coeffs, small_rig.names
