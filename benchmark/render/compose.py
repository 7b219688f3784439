"""Composing rendered views into one video frame: panels side by side, labels, and a
scrolling waveform strip under them with the current instant marked."""

from __future__ import annotations

import numpy as np

WAVE_COLOUR = np.array([70, 90, 140], dtype=np.uint8)
CURSOR_COLOUR = np.array([200, 40, 40], dtype=np.uint8)


class Waveform:
    """The waveform strip of one clip, drawn one video frame at a time (constant memory):
    ``window`` seconds of audio centred on the frame's instant, a red cursor at the centre
    (what is heard now), the speech to come on the right.

    Parameters
    ----------
    audio : (N,) float array_like in [-1, 1]
    rate : int, samples per second
    fps : float
    width, height : int, the strip's size in pixels
    window : float, seconds shown
    """

    def __init__(self, audio, rate: int, fps: float, width: int, height: int, window: float = 2.0):
        audio = np.asarray(audio, dtype=np.float64).reshape(-1)
        peak = float(np.abs(audio).max()) if audio.size else 0.0
        scale = 1.0 / peak if peak > 0 else 1.0
        per_column = window * rate / width
        # min/max envelope on a fixed grid of columns over the whole clip, padded by half a window
        pad = int(np.ceil(window * rate / 2))
        padded = np.concatenate([np.zeros(pad), audio * scale, np.zeros(pad + int(per_column) + 2)])
        edges = np.floor(np.arange(int(np.ceil((len(audio) + pad) / per_column)) + width + 2) * per_column).astype(np.int64)
        edges = np.clip(edges, 0, len(padded) - 1)
        self._lo = np.minimum.reduceat(padded, edges[:-1]) if len(edges) > 1 else np.zeros(1)
        self._hi = np.maximum.reduceat(padded, edges[:-1]) if len(edges) > 1 else np.zeros(1)
        self.rate, self.fps, self.width, self.height = rate, fps, width, height
        self._per_column = per_column
        self._half = (height - 1) / 2.0
        self._rows = np.arange(height)[:, None]

    def frame(self, t: int, out: np.ndarray | None = None) -> np.ndarray:
        """The strip of video frame ``t``, ``(height, width, 3)`` uint8 (drawn into ``out``)."""
        width, half = self.width, self._half
        strip = out if out is not None else np.empty((self.height, width, 3), dtype=np.uint8)
        strip.fill(255)
        start = int(round(t / self.fps * self.rate / self._per_column))
        column_lo = self._lo[start:start + width]
        column_hi = self._hi[start:start + width]
        n = len(column_lo)
        top = np.round(half - column_hi * half)
        bottom = np.round(half - column_lo * half)
        mask = (self._rows >= top[None]) & (self._rows <= bottom[None])
        strip[:, :n][mask] = WAVE_COLOUR
        strip[:, width // 2] = CURSOR_COLOUR
        strip[int(half)] = np.minimum(strip[int(half)], 200)
        return strip


def label_mask(text: str, scale: int = 2) -> np.ndarray:
    """Pixels of ``text`` in PIL's built-in font, ``scale`` times enlarged: ``(h, w)`` bool."""
    from PIL import Image, ImageDraw

    stamp = Image.new("L", (8 * len(text) + 8, 14), 255)
    ImageDraw.Draw(stamp).text((2, 1), text, fill=0)
    return np.asarray(stamp.resize((stamp.width * scale, stamp.height * scale), Image.NEAREST)) < 128


def draw_label(frame, mask: np.ndarray) -> None:
    """Write a :func:`label_mask` in black at the top left of one frame ``(H, W, 3)``, in place."""
    h = min(mask.shape[0], frame.shape[0] - 4)
    w = min(mask.shape[1], frame.shape[1] - 4)
    region = frame[4:4 + h, 4:4 + w]
    region[mask[:h, :w]] = 0


def label(frames, text: str, scale: int = 2) -> np.ndarray:
    """Frames with ``text`` written in black at the top left (PIL's built-in font)."""
    frames = np.asarray(frames)
    stamp = label_mask(text, scale)
    h = min(stamp.shape[0], frames.shape[1] - 4)
    w = min(stamp.shape[1], frames.shape[2] - 4)
    out = frames.copy()
    region = out[:, 4:4 + h, 4:4 + w]
    region[:, stamp[:h, :w]] = 0
    return out
