"""Frame pacing (blendvoca.live.sender) on a simulated clock: deadlines from the start, no drift,
nothing skipped; --loop stops at Ctrl-C with what was sent; --play-audio without sounddevice."""

from __future__ import annotations

import sys

import numpy as np
import pytest

pytestmark = pytest.mark.timeout(30)

from blendvoca.errors import UserError
from blendvoca.live import sender


class FakeClock:
    """A monotonic clock that ``sleep``, injected stalls and each reading (1 us, as polling) move."""

    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        self.now += 1e-6
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += max(seconds, 0.0) + 1e-5  # a sleep overshoots a little


class FakeSocket:
    def __init__(self, clock, stall_at=None, stall=0.0):
        self.clock, self.sent, self.stall_at, self.stall = clock, [], stall_at, stall

    def send(self, data: bytes) -> int:
        if len(self.sent) == self.stall_at:
            self.clock.now += self.stall  # the process was not scheduled
        self.sent.append((self.clock.now, data))
        return len(data)


def test_each_frame_leaves_at_its_deadline_from_the_start_and_a_stall_does_not_shift_the_rest(monkeypatch):
    clock = FakeClock()
    monkeypatch.setattr(sender.time, "sleep", clock.sleep)
    sock = FakeSocket(clock, stall_at=3, stall=0.1)  # 100 ms: six frames at 60 fps
    report = sender.send_frames(sock, lambda k: bytes([k]), 20, 60.0, clock=clock)
    assert [d for _, d in sock.sent] == [bytes([k]) for k in range(20)]  # none skipped, in order
    np.testing.assert_allclose(report.due, np.arange(20) / 60)
    late = report.lateness
    assert late[3] >= 0.1 and np.all(late[4:9] > 0)  # frames owed after the stall leave at once
    # after the catch-up every frame is back on the grid from the start: no drift
    assert np.all(late[10:] < sender.SPIN_SECONDS) and np.all(late >= 0)
    assert report.frames == 20 and "sent 20 frames at 60 fps" in report.summary()


def test_a_loop_stops_at_ctrl_c_with_the_frames_sent(monkeypatch):
    clock = FakeClock()
    monkeypatch.setattr(sender.time, "sleep", clock.sleep)

    def datagram(k: int) -> bytes:
        if k == 250:
            raise KeyboardInterrupt
        return b"frame"

    report = sender.send_frames(FakeSocket(clock), datagram, None, 60.0, clock=clock)
    assert report.frames == 250
    np.testing.assert_allclose(report.due, np.arange(250) / 60)


def test_a_counted_send_passes_ctrl_c_on(monkeypatch):
    clock = FakeClock()
    monkeypatch.setattr(sender.time, "sleep", clock.sleep)

    def datagram(k: int) -> bytes:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sender.send_frames(FakeSocket(clock), datagram, 10, 60.0, clock=clock)


def test_play_audio_without_sounddevice_names_the_install(monkeypatch, tmp_path):
    from blendvoca.live.playback import playback_starter

    monkeypatch.setitem(sys.modules, "sounddevice", None)  # import raises ImportError
    with pytest.raises(UserError, match="pip install sounddevice"):
        playback_starter(tmp_path / "speech.wav")
