"""The one progress switch: whether long jobs draw progress bars.

A CLI sets it once from ``--quiet`` (:func:`set_progress`); library code never takes a
``progress`` parameter, it draws its bars with :func:`bar` (a ``tqdm`` that is
disabled while the switch is off) or asks :func:`show_progress`. A caller that wants
quiet for one block only (a runner around a plug-in's training) uses
:func:`progress_bars`. The switch is a :class:`contextvars.ContextVar`, so a thread or
task that sets it does not change it for another.
"""

from __future__ import annotations

import contextlib
import contextvars

__all__ = ["bar", "progress_bars", "set_progress", "show_progress"]

_SHOW_PROGRESS = contextvars.ContextVar("blendvoca_show_progress", default=True)


def show_progress() -> bool:
    """Whether progress bars are drawn now (True unless a CLI ran with ``--quiet`` or
    the caller is inside ``progress_bars(False)``)."""
    return _SHOW_PROGRESS.get()


def set_progress(enabled: bool) -> None:
    """Turn progress bars on or off for the rest of this context (a CLI, once)."""
    _SHOW_PROGRESS.set(bool(enabled))


@contextlib.contextmanager
def progress_bars(enabled: bool):
    """Within the block, :func:`show_progress` returns ``enabled``."""
    token = _SHOW_PROGRESS.set(bool(enabled))
    try:
        yield
    finally:
        _SHOW_PROGRESS.reset(token)


def bar(iterable=None, **kwargs):
    """A ``tqdm`` progress bar over ``iterable`` (keywords as tqdm's), disabled while
    :func:`show_progress` is False. ``disable=True`` disables it in any case."""
    from tqdm.auto import tqdm

    kwargs["disable"] = bool(kwargs.get("disable", False)) or not show_progress()
    return tqdm(iterable, **kwargs)
