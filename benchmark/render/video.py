"""Write frames (and audio) to an MP4 with the ffmpeg that imageio-ffmpeg ships."""

from __future__ import annotations

import subprocess
import tempfile
from os import PathLike
from pathlib import Path

import numpy as np


def write_video(path: str | PathLike, frames, fps: float, audio=None, rate: int = 16000) -> Path:
    """Encode RGB frames to H.264 MP4, muxing mono audio when given.

    With audio, the video lasts as long as the audio: frames past its end are left
    out and, when the frames end first, the last one is held.

    Parameters
    ----------
    path : path-like
    frames : (T, H, W, 3) uint8 array_like
    fps : float
    audio : (N,) float array_like in [-1, 1], optional
    rate : int

    Returns
    -------
    Path
    """
    import imageio_ffmpeg

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        raise ValueError(f"write_video: expected uint8 frames (T, H, W, 3), got {frames.dtype} {frames.shape}")
    if audio is not None:
        frames = match_audio_length(frames, fps, len(np.asarray(audio)), rate)
    if frames.shape[1] % 2 or frames.shape[2] % 2:  # H.264 4:2:0 needs even sides: pad with white
        frames = np.pad(frames, ((0, 0), (0, frames.shape[1] % 2), (0, frames.shape[2] % 2), (0, 0)),
                        constant_values=255)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    height, width = frames.shape[1:3]
    with tempfile.TemporaryDirectory() as tmp:
        silent = Path(tmp) / "video.mp4"
        writer = imageio_ffmpeg.write_frames(str(silent), (width, height), fps=fps, codec="libx264",
                                             pix_fmt_out="yuv420p", macro_block_size=2, quality=8,
                                             ffmpeg_log_level="error")
        writer.send(None)
        for frame in frames:
            writer.send(np.ascontiguousarray(frame))
        writer.close()
        if audio is None:
            silent.replace(path)
            return path
        from blendvoca.io.audio import write_wav

        wav = Path(tmp) / "audio.wav"
        write_wav(wav, np.asarray(audio, dtype=np.float32), rate)
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i", str(silent), "-i", str(wav),
               "-c:v", "copy", "-c:a", "aac", str(path)]
        subprocess.run(cmd, check=True)
    return path


def match_audio_length(frames, fps: float, num_samples: int, rate: int) -> np.ndarray:
    """Frames cut or extended (holding the last) to ``round(num_samples / rate * fps)``."""
    frames = np.asarray(frames)
    count = max(int(round(num_samples / rate * fps)), 1)
    if len(frames) >= count:
        return frames[:count]
    return np.concatenate([frames, np.repeat(frames[-1:], count - len(frames), axis=0)])


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
