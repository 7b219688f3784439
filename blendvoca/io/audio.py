"""Speech audio: any WAV (or the sound of a video) in, 16 kHz mono float32 out.

soundfile reads every PCM/float WAV flavour; soxr does the band-limited resampling
(both are small wheels with no system dependency). The sound of a ``.mov``/``.mp4``
(a Live Link Face take's video, say) is decoded by PyAV, FFmpeg's libraries as a
wheel (the ``capture`` extra: ``pip install blendvoca[capture]``), imported only then.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.io.atomic import atomic_write

SAMPLE_RATE = 16000
#: Suffixes read as a video container's audio stream (PyAV) rather than as a WAV.
MEDIA_SUFFIXES: frozenset[str] = frozenset({".mov", ".mp4", ".m4a", ".m4v"})


class AudioFormatError(DataError):
    """An audio file that does not decode; the message names the file and the problem."""


def resample_audio(samples: np.ndarray, rate_in: int, rate_out: int = SAMPLE_RATE) -> np.ndarray:
    """Resample mono ``(N,)`` audio from ``rate_in`` to ``rate_out`` Hz (float32)."""
    if isinstance(samples, np.ndarray) and samples.dtype == np.float32:
        # already what the resampler takes: no float64 detour (a 10-minute take is 38 MB in float32);
        # a copy, as for any other input, so the caller's array is never returned
        samples = np.array(samples, order="C", copy=True)
    else:
        samples = float_array(samples, where="resample_audio", name="samples", shape="(N,)").astype(np.float32)
    if samples.ndim != 1:
        raise UserError(f"resample_audio expects mono (N,) samples, got shape {samples.shape}")
    if int(rate_in) == int(rate_out):
        return samples
    import soxr

    return soxr.resample(samples, int(rate_in), int(rate_out), quality="HQ").astype(np.float32)


def to_mono(samples: np.ndarray) -> np.ndarray:
    """Average the channels of ``(N, C)`` audio; ``(N,)`` passes through."""
    samples = np.asarray(samples, dtype=np.float32)
    return samples.mean(axis=1) if samples.ndim == 2 else samples


def read_wav(path) -> tuple[np.ndarray, int]:
    """Samples ``(N,)`` or ``(N, C)`` float32 in [-1, 1] and the native rate.

    Raises
    ------
    FileNotFoundError
        No such file.
    AudioFormatError
        Anything libsndfile cannot decode (naming the file).
    """
    import soundfile

    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"audio file not found: {path}")
    try:
        samples, rate = soundfile.read(str(path), dtype="float32", always_2d=False)
    except (RuntimeError, ValueError, TypeError, EOFError, OverflowError) as error:  # LibsndfileError is a RuntimeError
        raise AudioFormatError(f"{path}: not a readable audio file: {error}") from None
    if rate <= 0:
        raise AudioFormatError(f"{path}: sample rate {rate} Hz; expected a positive rate")
    return samples, int(rate)


def read_media_audio(path) -> tuple[np.ndarray, int]:
    """The first audio stream of a video container (``.mov``, ``.mp4``): ``(N, C)`` float32
    samples in [-1, 1] and the stream's rate, decoded by PyAV.

    The samples start at the video's first frame (the container's start without a video):
    a sound that starts later is padded with silence, one that starts earlier is cut.

    Raises
    ------
    FileNotFoundError
        No such file.
    UserError
        PyAV is not installed (``pip install av``, or the ``capture`` extra).
    AudioFormatError
        A file FFmpeg cannot open or decode, or one with no audio stream (naming the file
        and the streams it has).
    """
    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"audio file not found: {path}")
    try:
        import av
    except ImportError:
        raise UserError(f"{path}: reading the sound of a video needs PyAV: pip install av "
                        "(or pip install 'blendvoca[capture]')") from None
    try:
        with av.open(str(path)) as container:
            streams = list(container.streams)
            audio = next((s for s in streams if s.type == "audio"), None)
            if audio is None:
                kinds = ", ".join(f"{s.type} ({s.codec_context.name if s.codec_context else 'unknown codec'})"
                                  for s in streams) or "none"
                raise AudioFormatError(f"{path}: no audio stream (streams: {kinds}); expected the take's speech")
            if audio.codec_context is None:
                raise AudioFormatError(f"{path}: an audio stream in a codec FFmpeg does not know; expected the take's "
                                       "speech in AAC, PCM or another common codec")
            rate = int(audio.codec_context.sample_rate or audio.rate or 0)
            if rate <= 0:
                raise AudioFormatError(f"{path}: audio stream with sample rate {rate} Hz; expected a positive rate")
            resampler = av.AudioResampler(format="flt", rate=rate)  # packed float, the stream's channels
            chunks, first = [], None
            for frame in container.decode(audio):
                if first is None and frame.pts is not None and frame.time_base is not None:
                    first = float(frame.pts * frame.time_base)
                for out in resampler.resample(frame):
                    chunks.append(out.to_ndarray().reshape(-1, out.layout.nb_channels))
            for out in resampler.resample(None):
                chunks.append(out.to_ndarray().reshape(-1, out.layout.nb_channels))
            video = next((s for s in streams if s.type == "video"), None)
            if video is not None and video.start_time is not None and video.time_base is not None:
                start = float(video.start_time * video.time_base)
            else:
                start = 0.0 if container.start_time is None else container.start_time / 1e6
    except AudioFormatError:
        raise
    except (av.FFmpegError, ValueError, OverflowError) as error:  # PyAV's errors on a damaged file
        raise AudioFormatError(f"{path}: not a readable video or audio file: {error}") from None
    width = chunks[0].shape[1] if chunks else 1
    samples = np.concatenate(chunks).astype(np.float32) if chunks else np.zeros((0, width), np.float32)
    lead = int(round(((first if first is not None else start) - start) * rate))
    if lead > 0:
        samples = np.concatenate([np.zeros((lead, width), np.float32), samples])
    elif lead < 0:
        samples = samples[-lead:]
    return samples, rate


def read_audio(path) -> tuple[np.ndarray, int]:
    """Any WAV file, or the sound of a video (:data:`MEDIA_SUFFIXES`), as it was recorded:
    ``(N,)`` or ``(N, C)`` float32 samples in [-1, 1] and the source rate (what a review video
    muxes, so that a 44.1 kHz stereo recording stays one).

    Raises
    ------
    FileNotFoundError
        No such file.
    AudioFormatError
        A file that does not decode, or holds no samples (naming the file).
    """
    media = Path(os.fspath(path)).suffix.lower() in MEDIA_SUFFIXES
    samples, native = read_media_audio(path) if media else read_wav(path)
    if samples.shape[0] == 0:
        raise AudioFormatError(f"{path}: the audio holds no samples (a zero-length recording); expected speech")
    return samples, native


def load_audio(path, rate: int = SAMPLE_RATE) -> np.ndarray:
    """Any WAV file, or the sound of a video (:data:`MEDIA_SUFFIXES`, :func:`read_media_audio`),
    as mono float32 at ``rate`` Hz (16 kHz by default), ``(N,)``.

    Raises
    ------
    FileNotFoundError
        No such file.
    AudioFormatError
        A file that does not decode, or holds no samples (naming the file): speech
        is what every caller needs, and an empty array would fail far from here.
    """
    samples, native = read_audio(path)
    return resample_audio(to_mono(samples), native, rate)


def write_wav(path, samples: np.ndarray, rate: int = SAMPLE_RATE) -> None:
    """Write mono or ``(N, C)`` float audio in [-1, 1] (any real dtype) as 16-bit PCM WAV, atomically."""
    import soundfile

    samples = float_array(samples, where=str(path), name="samples", shape="(N,) or (N, C)").astype(np.float32)
    if samples.ndim not in (1, 2):
        raise UserError(f"{path}: expected audio samples (N,) or (N, C), got shape {samples.shape}")
    if not np.all(np.isfinite(samples)):
        raise UserError(f"{path}: audio contains NaN or infinite samples")
    with atomic_write(path, "wb") as f:
        soundfile.write(f, np.clip(samples, -1.0, 1.0), int(rate), subtype="PCM_16", format="WAV")


def energy_db(samples, rate: int, fps: float, frames: int, window_s: float = 0.03) -> np.ndarray:
    """``(frames,)`` energy of mono audio around each motion frame's time ``t / fps``, in dB.

    The mean square of the samples under a Hann window of ``window_s`` seconds centred at
    the frame (``1e-12`` added before the log, so digital silence reads -120 dB).

    Raises
    ------
    DataError
        Samples that are not a non-empty (N,) array.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 1 or x.size == 0:
        raise DataError(f"energy_db: expected mono audio samples (N,), got shape {x.shape}")
    half = max(1, int(round(window_s * rate / 2)))
    taper = np.hanning(2 * half + 1)
    energy = np.convolve(x**2, taper / taper.sum(), mode="same")
    centres = np.clip(np.round(np.arange(frames) * rate / fps).astype(np.int64), 0, len(x) - 1)
    return 10.0 * np.log10(energy[centres] + 1e-12)
