"""Live Link Face takes written in the app's format by the tests themselves.

``clock_take`` writes a take the way the app does: a 60 fps clock timecode with the
fraction of a frame (``HH:MM:SS:FF.fff``) on rows captured at another rate (59.94),
either header spelling, CRLF lines, 10 decimals. ``write_mov`` writes a tiny video
with (or without) a sound stream through PyAV. The motion is smooth and known in
closed form (:func:`weights_at`), so a build's 60 fps track can be checked against it.
"""

from __future__ import annotations

import fractions
import math
from pathlib import Path

import numpy as np

from blendvoca.io.audio import write_wav
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_HEADER, LIVELINK_SHAPE_COLUMNS

RATE = 16000
NTSC_60 = 60000 / 1001
_FREQ = np.linspace(0.3, 2.0, 52)
_PHASE = np.linspace(0.0, 2 * np.pi, 52, endpoint=False)
#: The largest error of linear interpolation of :func:`weights_at` between frames 1 / 59.94 s
#: apart (h^2 / 8 max|f''|), plus the 6 decimals of a build's CSV.
RESAMPLING_ERROR = (1 / NTSC_60) ** 2 / 8 * 0.4 * (2 * np.pi * _FREQ.max()) ** 2 + 1e-6


def weights_at(t) -> np.ndarray:
    """``(len(t), 52)`` ARKit-order weights at times ``t`` (seconds): slow sines in [0.1, 0.9]."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    return 0.5 + 0.4 * np.sin(2 * np.pi * _FREQ * t + _PHASE)


def pose_at(t) -> np.ndarray:
    """``(len(t), 9)`` head and eye rotations at times ``t``: slow sines in [-0.3, 0.3]."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    return 0.3 * np.sin(2 * np.pi * np.linspace(0.2, 0.6, 9) * t + 1.0)


def clock_timecode(seconds: float, rate: int = 60) -> str:
    """``HH:MM:SS:FF.fff`` of a clock time: ``FF`` frames of ``rate`` into the second, ``.fff`` the fraction."""
    whole = math.floor(seconds)
    frames = (seconds - whole) * rate
    ff = math.floor(frames)
    sub = int(round((frames - ff) * 1000))
    if sub == 1000:
        ff, sub = ff + 1, 0
        if ff == rate:
            whole, ff = whole + 1, 0
    h, rest = divmod(whole, 3600)
    m, s = divmod(rest, 60)
    return f"{h:02d}:{m:02d}:{s:02d}:{ff:02d}.{sub:03d}"


def clock_take(path: Path, seconds: float, *, fps: float = NTSC_60, start: float = 1929.1311,
               spelling: str = "BlendShapeCount", skip=(), header=None, timecodes=None) -> np.ndarray:
    """Write a take of ``seconds`` captured at ``fps`` as the app does; returns the capture times
    (seconds from the first row) of the rows written. ``skip`` leaves rows out (dropped
    frames); ``header`` and ``timecodes`` (one per row) replace the app's (for bad input)."""
    count = len(timecodes) if timecodes is not None else int(round(seconds * fps))
    times = np.arange(count) / fps
    keep = np.array([i for i in range(count) if i not in set(skip)], dtype=np.int64)
    weights = weights_at(times)[:, [ARKIT_FACE_ORDER.index(n[0].lower() + n[1:]) for n in LIVELINK_SHAPE_COLUMNS]]
    values = np.concatenate([weights, pose_at(times)], axis=1)
    cells = list(header) if header is not None else [c if c != "BlendShapeCount" else spelling for c in LIVELINK_HEADER]
    lines = [",".join(cells)]
    for i in keep:
        code = timecodes[i] if timecodes is not None else clock_timecode(start + times[i])
        lines.append(f"{code},{len(values[i])}," + ",".join("%.10f" % v for v in values[i]))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("utf-8"))
    return times[keep]


def speech(seconds: float, rate: int = RATE, seed: int = 0) -> np.ndarray:
    """``(N,)`` float32 speech-like sound: a buzz whose loudness follows a slow envelope."""
    t = np.arange(int(round(seconds * rate))) / rate
    noise = 0.01 * np.random.default_rng(seed).standard_normal(len(t))
    return (0.3 * np.sin(2 * np.pi * 180 * t) * (0.5 + 0.5 * np.sin(2 * np.pi * 1.7 * t)) + noise).astype(np.float32)


def write_sound(path: Path, seconds: float) -> None:
    """A WAV of ``seconds`` of :func:`speech` at 16 kHz."""
    write_wav(path, speech(seconds), RATE)


def write_mov(path: Path, seconds: float, *, sound: bool = True, rate: int = 48000, samples=None,
              sound_start: float = 0.0) -> None:
    """A tiny video (32 x 32, 30 fps) of ``seconds`` with ``samples`` (default: :func:`speech` of
    ``seconds``) at ``rate`` as AAC starting ``sound_start`` seconds into it (or no sound stream)."""
    import av

    with av.open(str(path), "w") as container:
        video = container.add_stream("mpeg4", rate=30)
        video.width, video.height, video.pix_fmt = 32, 32, "yuv420p"
        audio = None
        if sound:
            audio = container.add_stream("aac", rate=rate)
            audio.layout = "mono"
        for i in range(int(round(seconds * 30))):
            frame = av.VideoFrame.from_ndarray(np.full((32, 32, 3), (7 * i) % 255, np.uint8), format="rgb24")
            for packet in video.encode(frame):
                container.mux(packet)
        for packet in video.encode():
            container.mux(packet)
        if audio is not None:
            samples = speech(seconds, rate) if samples is None else np.asarray(samples, np.float32)
            offset = int(round(sound_start * rate))
            for k in range(0, len(samples), 1024):
                frame = av.AudioFrame.from_ndarray(samples[None, k:k + 1024], format="flt", layout="mono")
                frame.sample_rate, frame.pts, frame.time_base = rate, offset + k, fractions.Fraction(1, rate)
                for packet in audio.encode(frame):
                    container.mux(packet)
            for packet in audio.encode():
                container.mux(packet)
