"""blendvoca.runtime.threads: the one BLAS/OpenMP/torch thread limiter."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info

from blendvoca.runtime.threads import limit_threads, limited_threads, one_blas_thread


def _blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_limited_threads_limits_blas_and_restores_it():
    import numpy as np

    np.ones((2, 2)) @ np.ones((2, 2))  # BLAS loaded
    before = _blas_threads()
    with limited_threads(1):
        assert _blas_threads() and set(_blas_threads()) == {1}
    assert _blas_threads() == before


def test_limited_threads_sets_torch_only_when_imported_and_restores_it():
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    with limited_threads(1):
        assert torch.get_num_threads() == 1
    assert torch.get_num_threads() == before


def test_torch_only_leaves_blas_alone():
    torch = pytest.importorskip("torch")
    import numpy as np

    np.ones((2, 2)) @ np.ones((2, 2))  # BLAS loaded
    blas, before = _blas_threads(), torch.get_num_threads()
    with limited_threads(1, torch_only=True):
        assert torch.get_num_threads() == 1
        assert _blas_threads() == blas
    assert torch.get_num_threads() == before


def test_limit_threads_none_changes_nothing_and_bad_counts_are_refused():
    before = _blas_threads()
    limit_threads(None)()
    assert _blas_threads() == before
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="expected a thread count >= 1 or None"):
            limit_threads(bad)


def test_one_blas_thread_limits_blas_only_restores_it_and_is_cheap_to_enter_again():
    import time

    import numpy as np

    np.ones((2, 2)) @ np.ones((2, 2))  # BLAS loaded
    before = _blas_threads()
    openmp = [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "openmp"]
    with one_blas_thread():
        assert set(_blas_threads()) == {1}
        assert [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "openmp"] == openmp
    assert _blas_threads() == before
    start = time.perf_counter()
    for _ in range(20):
        with one_blas_thread():
            pass
    cached = time.perf_counter() - start
    start = time.perf_counter()
    for _ in range(20):
        with limited_threads(1, openmp=False):
            pass
    assert cached < time.perf_counter() - start  # the libraries are not looked up again
