"""``blendvoca.io.audio.resample_audio``: float32 input takes no float64 detour and gives what any dtype gives."""

import numpy as np
import pytest

from blendvoca.errors import UserError
from blendvoca.io.audio import resample_audio


def test_float32_and_float64_input_give_the_same_float32_output():
    rng = np.random.default_rng(0)
    x64 = rng.uniform(-1, 1, 22000)
    x32 = x64.astype(np.float32)
    for rate in (22000, 16000):
        a = resample_audio(x32, 22000, 16000 if rate == 16000 else 22000)
        b = resample_audio(x32.astype(np.float64), 22000, 16000 if rate == 16000 else 22000)
        assert a.dtype == np.float32
        np.testing.assert_array_equal(a, b)


def test_the_callers_array_is_never_returned():
    x = np.zeros(100, dtype=np.float32)
    out = resample_audio(x, 16000, 16000)
    assert out is not x and not np.shares_memory(out, x)


def test_bad_input_is_a_user_error():
    with pytest.raises(UserError, match="mono"):
        resample_audio(np.zeros((10, 2), dtype=np.float32), 16000)
    with pytest.raises(UserError, match="real numbers"):
        resample_audio(np.array(["a"]), 16000)
