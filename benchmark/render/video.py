"""Write frames (and audio) to an MP4 with the ffmpeg that imageio-ffmpeg ships.

:class:`VideoWriter` streams: each frame goes to ffmpeg's stdin as it is written and
the audio is muxed by the same ffmpeg process, so a clip of any length is encoded in
constant memory. The file appears under its name only when the encoder finished; a
failed or interrupted write leaves nothing behind.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
from collections.abc import Iterable, Iterator
from fractions import Fraction
from os import PathLike
from pathlib import Path

import numpy as np

#: x264 constant rate factor: what ``imageio_ffmpeg.write_frames(quality=8)`` chose before.
CRF = 10


#: AAC bit rate: transparent for speech at 44.1/48 kHz stereo (ffmpeg's default, 128k, is shared by the channels).
AAC_BITRATE = "192k"


class VideoError(RuntimeError):
    """ffmpeg failed to encode (its message is included)."""


class VideoWriter:
    """Stream RGB frames to an H.264 MP4 (with AAC audio at its own rate and channels when given).

    Use as a context manager: on a clean exit the file is finished and moved to ``path``;
    on an exception the encoder is stopped and the partial file removed.

    Parameters
    ----------
    path : path-like
    width, height : int
        Frame size; odd sides are padded with one white row or column (H.264 4:2:0).
    fps : float
    audio : (N,) or (N, C) float array_like in [-1, 1], optional
        Encoded as AAC at ``rate`` with its C channels (a 44.1 kHz stereo recording stays one).
    rate : int
        Audio sample rate.

    Notes
    -----
    The caller decides the number of frames (:func:`frame_count` gives the audio's).
    """

    def __init__(self, path: str | PathLike, width: int, height: int, fps: float, audio=None, rate: int = 16000):
        import imageio_ffmpeg

        self.path = Path(path)
        self.width, self.height = int(width), int(height)
        self.padded = (self.height + self.height % 2, self.width + self.width % 2)
        self.count = 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = tempfile.TemporaryDirectory(prefix=".render-", dir=self.path.parent)
        self._partial = Path(self._tmp.name) / "video.mp4"
        self._log = open(Path(self._tmp.name) / "ffmpeg.log", "w+b")  # noqa: SIM115 - closed in close()
        rate_arg = str(Fraction(fps).limit_denominator())
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "rawvideo", "-vcodec", "rawvideo",
               "-s", f"{self.padded[1]}x{self.padded[0]}", "-pix_fmt", "rgb24", "-r", rate_arg, "-i", "-"]
        if audio is not None:
            from blendvoca.io.audio import write_wav

            wav = Path(self._tmp.name) / "audio.wav"
            write_wav(wav, np.asarray(audio, dtype=np.float32), rate)
            cmd += ["-i", str(wav), "-map", "0:v:0", "-map", "1:a:0", "-c:a", "aac", "-b:a", AAC_BITRATE]
        cmd += ["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", str(CRF), "-f", "mp4", str(self._partial)]
        self._pad = None
        if self.padded != (self.height, self.width):
            self._pad = np.full((*self.padded, 3), 255, dtype=np.uint8)
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._log)

    @property
    def pid(self) -> int:
        """The encoder's process id."""
        return self._proc.pid

    def write(self, frame) -> None:
        """Send one ``(height, width, 3)`` uint8 frame to the encoder."""
        frame = np.asarray(frame)
        if frame.shape != (self.height, self.width, 3) or frame.dtype != np.uint8:
            raise ValueError(f"VideoWriter: expected a uint8 frame {(self.height, self.width, 3)}, "
                             f"got {frame.dtype} {frame.shape}")
        if self._pad is not None:
            self._pad[:self.height, :self.width] = frame
            frame = self._pad
        try:
            self._proc.stdin.write(memoryview(np.ascontiguousarray(frame)).cast("B"))
        except (BrokenPipeError, OSError):
            self._proc.wait()
            raise VideoError(f"ffmpeg stopped after {self.count} frames: {self._message()}") from None
        self.count += 1

    def _message(self) -> str:
        self._log.flush()
        self._log.seek(0)
        text = self._log.read().decode(errors="replace").strip()
        return text.splitlines()[-1] if text else f"exit status {self._proc.returncode}"

    def close(self) -> Path:
        """Finish the file and move it to ``path``."""
        try:
            if self.count == 0:
                raise VideoError(f"{self.path}: no frames written")
            self._proc.stdin.close()
            if self._proc.wait() != 0:
                raise VideoError(f"ffmpeg could not write {self.path}: {self._message()}")
            os.replace(self._partial, self.path)
        finally:
            self._cleanup()
        return self.path

    def abort(self) -> None:
        """Stop the encoder and remove what it wrote."""
        if self._proc.poll() is None:
            self._proc.kill()
        self._proc.wait()
        self._cleanup()

    def _cleanup(self) -> None:
        if self._proc.stdin and not self._proc.stdin.closed:
            try:
                self._proc.stdin.close()
            except OSError:
                pass
        if self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        self._log.close()
        self._tmp.cleanup()

    def __enter__(self):
        return self

    def __exit__(self, kind, value, traceback):
        if kind is None:
            self.close()
        else:
            self.abort()


def frame_count(fps: float, num_samples: int, rate: int) -> int:
    """Frames of a video as long as ``num_samples`` of audio: ``max(round(N / rate * fps), 1)``."""
    return max(int(round(num_samples / rate * fps)), 1)


def hold_to_length(frames: Iterable, count: int) -> Iterator:
    """The first ``count`` frames, the last one repeated when there are fewer."""
    last = None
    n = 0
    for frame in frames:
        if n == count:
            return
        last = frame
        n += 1
        yield frame
    if last is None:
        raise ValueError("hold_to_length: no frames")
    for _ in range(count - n):
        yield last


def write_video(path: str | PathLike, frames, fps: float, audio=None, rate: int = 16000) -> Path:
    """Encode RGB frames to H.264 MP4, muxing the audio (AAC at its rate and channels) when given.

    With audio, the video lasts as long as the audio: frames past its end are left
    out and, when the frames end first, the last one is held.

    Parameters
    ----------
    path : path-like
    frames : (T, H, W, 3) uint8 array_like, or an iterable of (H, W, 3) uint8 frames
        (streamed to the encoder one by one: nothing is held)
    fps : float
    audio : (N,) or (N, C) float array_like in [-1, 1], optional
    rate : int

    Returns
    -------
    Path
    """
    if isinstance(frames, np.ndarray) or not isinstance(frames, Iterable) or isinstance(frames, (list, tuple)):
        frames = np.asarray(frames)
        if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
            raise ValueError(f"write_video: expected uint8 frames (T, H, W, 3), got {frames.dtype} {frames.shape}")
    iterator = iter(frames)
    first = next(iterator, None)
    if first is None:
        raise ValueError("write_video: no frames")
    first = np.asarray(first)
    if first.ndim != 3 or first.shape[2] != 3 or first.dtype != np.uint8:
        raise ValueError(f"write_video: expected uint8 frames (H, W, 3), got {first.dtype} {first.shape}")

    def everything():
        yield first
        yield from iterator

    stream = everything()
    if audio is not None:
        audio = np.asarray(audio)
        stream = hold_to_length(stream, frame_count(fps, len(audio), rate))
    with VideoWriter(path, first.shape[1], first.shape[0], fps, audio=audio, rate=rate) as writer:
        for frame in stream:
            writer.write(frame)
    return Path(path)


def read_video(path: str | PathLike, rate: int = 16000):
    """Frames and mono audio of a video file.

    Returns
    -------
    frames : (T, H, W, 3) uint8 ndarray
    fps : float
    audio : (N,) float32 ndarray at ``rate`` (empty when the file has none)
    """
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = reader.__next__()
    width, height = meta["size"]
    frames = np.stack([np.frombuffer(buf, dtype=np.uint8).reshape(height, width, 3) for buf in reader])
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-i", str(path), "-vn", "-ac", "1",
           "-ar", str(rate), "-f", "s16le", "-"]
    out = subprocess.run(cmd, capture_output=True, check=False)
    audio = np.frombuffer(out.stdout, dtype="<i2").astype(np.float32) / 32768.0 if out.returncode == 0 else np.zeros(0, np.float32)
    return frames, float(meta["fps"]), audio
