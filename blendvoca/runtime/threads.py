"""The one thread limiter: how many threads BLAS, OpenMP and torch may use.

Small matrix products run faster on one thread, and a worker process of a pool must
not start one BLAS thread per core on a machine whose cores the other workers use:
:func:`limited_threads` (a block) and :func:`limit_threads` (the rest of a process,
a worker's set-up) are the only places that set these counts. torch's count is set
only when torch is already imported (the limiter never imports it).
:func:`one_blas_thread` is the cheap form for a hot path (a solver called per frame or
per sentence): BLAS only, the loaded libraries looked up once per process.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable

from threadpoolctl import ThreadpoolController, threadpool_limits

__all__ = ["limit_threads", "limited_threads", "one_blas_thread"]

#: The BLAS libraries :func:`one_blas_thread` limits, looked up on its first call.
_CONTROLLER: ThreadpoolController | None = None


def limit_threads(n: int | None = 1, *, openmp: bool = True, torch_only: bool = False) -> Callable[[], None]:
    """At most ``n`` threads for BLAS (and OpenMP unless ``openmp=False``) and, when torch
    is imported, for torch; returns the function that restores the previous counts.

    The libraries loaded now are limited (one loaded later is not). ``torch_only=True``
    sets torch's count alone (a trainer's ``num_threads``: numpy's BLAS keeps its count,
    so the data a trainer prepares does not depend on it). ``n=None`` changes nothing.
    Raises ``ValueError`` for ``n < 1``.
    """
    if n is None:
        return lambda: None
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"limit_threads: expected a thread count >= 1 or None, got {n!r}")
    n = int(n)
    limiter = None if torch_only else threadpool_limits(limits=n, user_api=None if openmp else "blas")
    torch = sys.modules.get("torch")
    before = torch.get_num_threads() if torch is not None else None
    if before is not None and before != n:
        torch.set_num_threads(n)

    def restore() -> None:
        if limiter is not None:
            limiter.restore_original_limits()
        if before is not None and before != n:
            torch.set_num_threads(before)

    return restore


@contextlib.contextmanager
def limited_threads(n: int | None = 1, *, openmp: bool = True, torch_only: bool = False):
    """Within the block, :func:`limit_threads` ``(n, openmp=openmp, torch_only=torch_only)``;
    the counts are restored after it."""
    restore = limit_threads(n, openmp=openmp, torch_only=torch_only)
    try:
        yield
    finally:
        restore()


def one_blas_thread():
    """A context limiting BLAS (only: not OpenMP, not torch) to one thread, cheap to enter.

    The BLAS libraries are looked up on the first call in a process (threadpoolctl's
    scan of the loaded libraries is the costly part of :func:`limited_threads`), so a
    library loaded after that first call is not limited. Small banded factorizations
    run several times slower with two threads than with one (DESIGN.md).
    """
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")
