"""blendvoca.runtime.threads: the one BLAS/OpenMP/torch thread limiter."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info

from blendvoca.runtime.threads import limit_threads, limited_threads


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


def test_limit_threads_none_changes_nothing_and_bad_counts_are_refused():
    before = _blas_threads()
    limit_threads(None)()
    assert _blas_threads() == before
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="expected a thread count >= 1 or None"):
            limit_threads(bad)
