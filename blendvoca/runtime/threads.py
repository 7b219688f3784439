"""The one thread limiter: how many threads BLAS, OpenMP and torch may use.

Small matrix products run faster on one thread, and a worker process of a pool must
not start one BLAS thread per core on a machine whose cores the other workers use:
:func:`limited_threads` (a block) and :func:`limit_threads` (the rest of a process,
a worker's set-up) are the only places that set these counts. torch's count is set
only when torch is already imported (the limiter never imports it).
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable

from threadpoolctl import threadpool_limits

__all__ = ["limit_threads", "limited_threads"]


def limit_threads(n: int | None = 1, *, openmp: bool = True) -> Callable[[], None]:
    """At most ``n`` threads for BLAS (and OpenMP unless ``openmp=False``) and, when torch
    is imported, for torch; returns the function that restores the previous counts.

    The libraries loaded now are limited (one loaded later is not). ``n=None`` changes
    nothing. Raises ``ValueError`` for ``n < 1``.
    """
    if n is None:
        return lambda: None
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"limit_threads: expected a thread count >= 1 or None, got {n!r}")
    n = int(n)
    limiter = threadpool_limits(limits=n, user_api=None if openmp else "blas")
    torch = sys.modules.get("torch")
    before = torch.get_num_threads() if torch is not None else None
    if before is not None and before != n:
        torch.set_num_threads(n)

    def restore() -> None:
        limiter.restore_original_limits()
        if before is not None and before != n:
            torch.set_num_threads(before)

    return restore


@contextlib.contextmanager
def limited_threads(n: int | None = 1, *, openmp: bool = True):
    """Within the block, :func:`limit_threads` ``(n, openmp=openmp)``; the counts are restored after it."""
    restore = limit_threads(n, openmp=openmp)
    try:
        yield
    finally:
        restore()
