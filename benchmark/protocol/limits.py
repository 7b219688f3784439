"""Wall-clock limits the runner enforces on a method's ``train`` and ``generate``."""

from __future__ import annotations

import os
import signal
import sys
import threading
from dataclasses import dataclass

from blendvoca.errors import MethodTimeout

__all__ = ["DEFAULT_GENERATE_LIMIT", "GenerateLimit", "TimeLimit", "generate_limit", "watchdog_grace"]


def watchdog_grace(seconds: float) -> float:
    """Seconds past a limit after which the watchdog ends a call that the alarm did not
    stop: a tenth of the limit, at least 2 s, at most 60 s."""
    return min(60.0, max(2.0, 0.1 * float(seconds)))


@dataclass(frozen=True)
class GenerateLimit:
    """How long one ``generate`` call may take: ``base_s + per_audio_second_s`` times the
    seconds of audio it is given.

    Parameters
    ----------
    base_s : float
        Seconds every call may take (model warm-up, first CUDA kernels).
    per_audio_second_s : float
        Further seconds per second of audio; 0 for a fixed limit per call.
    """

    base_s: float
    per_audio_second_s: float = 0.0

    def seconds(self, audio_seconds: float) -> float:
        """The limit of a call given ``audio_seconds`` seconds of audio."""
        return float(self.base_s) + float(self.per_audio_second_s) * float(audio_seconds)

    def describe(self) -> str:
        """``"120 s + 60 s per second of audio"`` (or ``"5 s"`` for a fixed limit)."""
        if not self.per_audio_second_s:
            return f"{self.base_s:g} s"
        return f"{self.base_s:g} s + {self.per_audio_second_s:g} s per second of audio"

    def to_dict(self) -> dict:
        """What a result records of the limit."""
        return {"base_s": float(self.base_s), "per_audio_second_s": float(self.per_audio_second_s)}


#: The limit of a run that sets none: generous (a CPU-bound diffusion sampler takes a few
#: seconds per second of audio), so that it stops only a method that never returns.
DEFAULT_GENERATE_LIMIT = GenerateLimit(base_s=120.0, per_audio_second_s=60.0)


def generate_limit(value) -> GenerateLimit | None:
    """The :class:`GenerateLimit` a run's ``generate_time_limit`` stands for.

    Parameters
    ----------
    value : None, float or GenerateLimit
        None: :data:`DEFAULT_GENERATE_LIMIT` (read when called, so that it can be
        changed); a number > 0: that many seconds per call; 0: no limit.

    Returns
    -------
    GenerateLimit or None
        None when there is no limit.
    """
    if value is None:
        return DEFAULT_GENERATE_LIMIT
    if isinstance(value, GenerateLimit):
        return value
    return GenerateLimit(base_s=float(value)) if float(value) > 0 else None


class TimeLimit:
    """Raise :class:`~blendvoca.errors.MethodTimeout` in the main thread once ``seconds``
    have passed.

    It runs on SIGALRM, so it is a no-op where signals are unavailable (off the main
    thread, or on Windows) and for ``seconds`` of None or <= 0. A watchdog thread, which
    no signal setting of the limited code can mask, ends the process with exit status 3
    and the limit's message when the call is still running :func:`watchdog_grace`
    seconds past the limit (code that ignores or replaces SIGALRM, or blocks it in C).

    Parameters
    ----------
    seconds : float or None
    what : str
        What is limited, for the message (``"method 'x': train"``).
    how : str, optional
        How the limit was set, for the message (``"120 s + 60 s per second of audio"``).
    """

    def __init__(self, seconds: float | None, what: str, how: str | None = None):
        self.seconds, self.what, self.how = seconds, what, how
        self._armed = False

    def _fire(self, signum, frame):
        how = f" ({self.how})" if self.how else ""
        raise MethodTimeout(f"{self.what}: exceeded the limit of {self.seconds:g} s{how}")

    def __enter__(self):
        if (self.seconds is not None and self.seconds > 0 and hasattr(signal, "setitimer")
                and threading.current_thread() is threading.main_thread()):
            self._previous = signal.signal(signal.SIGALRM, self._fire)
            signal.setitimer(signal.ITIMER_REAL, float(self.seconds))
            self._armed = True
            self._done = threading.Event()
            self._watchdog = threading.Thread(target=self._watch, name="blendvoca-time-limit", daemon=True)
            self._watchdog.start()
        return self

    def _watch(self) -> None:
        """The watchdog: the call is still running well past its limit, the alarm was
        ignored: say so as the CLI would (exit 3) and end the process."""
        grace = watchdog_grace(self.seconds)
        if self._done.wait(float(self.seconds) + grace):
            return
        how = f" ({self.how})" if self.how else ""
        try:
            sys.stderr.write(f"error: the method misbehaved, nothing written: {self.what}: exceeded the limit of "
                             f"{self.seconds:g} s{how} and did not stop when alarmed (it ignores or replaces "
                             f"SIGALRM); the run was ended {grace:g} s later\n")
            sys.stderr.flush()
        finally:
            os._exit(3)

    def __exit__(self, *exc):
        if self._armed:
            self._done.set()
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self._previous)
        return False
