"""Wall-clock limits the runner enforces on a method's ``train`` and ``generate``."""

from __future__ import annotations

import signal
import threading

from blendvoca.errors import MethodTimeout

__all__ = ["TimeLimit"]


class TimeLimit:
    """Raise :class:`~blendvoca.errors.MethodTimeout` in the main thread once ``seconds``
    have passed.

    It runs on SIGALRM, so it is a no-op where signals are unavailable (off the main
    thread, or on Windows) and for ``seconds`` of None or <= 0.

    Parameters
    ----------
    seconds : float or None
    what : str
        What is limited, for the message (``"method 'x': train"``).
    """

    def __init__(self, seconds: float | None, what: str):
        self.seconds, self.what = seconds, what
        self._armed = False

    def _fire(self, signum, frame):
        raise MethodTimeout(f"{self.what}: exceeded the limit of {self.seconds:g} s")

    def __enter__(self):
        if (self.seconds is not None and self.seconds > 0 and hasattr(signal, "setitimer")
                and threading.current_thread() is threading.main_thread()):
            self._previous = signal.signal(signal.SIGALRM, self._fire)
            signal.setitimer(signal.ITIMER_REAL, float(self.seconds))
            self._armed = True
        return self

    def __exit__(self, *exc):
        if self._armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self._previous)
        return False
