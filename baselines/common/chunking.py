"""Chunked inference for long audio: overlapping chunks, a crossfade over each overlap, the seams measured.

A method whose generation grows with the utterance (SAiD's UNet over the whole track,
the autoregressive decoders of FaceFormer, CodeTalker and CDFace, whose positional
encodings also stop at a fixed length) animates a long utterance as a sequence of
chunks of ``chunk_frames`` frames at 60 fps, each overlapping the previous one by
``overlap_frames``. Every chunk is generated from its own slice of the 16 kHz audio
(so audio features are computed per chunk, never for the whole utterance), and the
overlap is a crossfade: a raised-cosine weight rising from the earlier chunk to the
later one. The later chunk starts afresh (no state carries over): its overlap frames
serve as its warm-up context and receive little weight at first.

The plan is fixed by the frame counts alone, so the same utterance always splits the
same way; an utterance no longer than ``chunk_frames`` is one chunk (the method's
unchunked generation, bit for bit). Peak memory is one chunk's work plus the output.

Seams are measured by :func:`seam_report`: the largest step between consecutive
frames in and around the overlaps, against the largest step elsewhere (inside a
chunk) and against the fit's rate bound (:data:`RATE_BOUND` per frame at 60 fps).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from benchmark.methods import AUDIO_RATE, FPS
from benchmark.methods.config import Option
from blendvoca.runtime.progress import bar

__all__ = [
    "FPS",
    "RATE_BOUND",
    "Chunk",
    "ChunkedDecoder",
    "ChunkPlan",
    "SeamReport",
    "chunk_options",
    "chunk_plan",
    "chunk_section",
    "chunk_setting",
    "crossfade_weights",
    "frame_sample",
    "generate_in_chunks",
    "generate_utterance_in_chunks",
    "seam_report",
]

#: The fit's rate bound: the largest change of a coefficient per frame at 60 fps.
RATE_BOUND = 0.1


def frame_sample(frame: int, *, fps: int = FPS, sample_rate: int = AUDIO_RATE) -> int:
    """The first audio sample of frame ``frame`` (``round(frame * sample_rate / fps)``)."""
    return int(round(int(frame) * sample_rate / fps))


@dataclass(frozen=True)
class Chunk:
    """One chunk of a plan: frames ``[start, stop)`` at 60 fps.

    Attributes
    ----------
    index : int
    start, stop : int
        Frames of the utterance the chunk animates.
    fade_in : int
        Frames at its start shared with the previous chunk (the crossfade), 0 for the first.
    """

    index: int
    start: int
    stop: int
    fade_in: int = 0

    @property
    def num_frames(self) -> int:
        return self.stop - self.start

    def samples(self, num_samples: int) -> tuple[int, int]:
        """The ``[first, last)`` audio samples of the chunk within an utterance of ``num_samples`` samples
        (the last chunk reaches the end of the audio)."""
        first = min(frame_sample(self.start), num_samples)
        return first, min(frame_sample(self.stop), num_samples)


@dataclass(frozen=True)
class ChunkPlan:
    """How an utterance of ``num_frames`` frames is cut (:func:`chunk_plan`).

    Attributes
    ----------
    num_frames, chunk_frames, overlap_frames : int
    chunks : tuple of Chunk
    """

    num_frames: int
    chunk_frames: int
    overlap_frames: int
    chunks: tuple

    @property
    def chunked(self) -> bool:
        """Whether the utterance is cut at all (more than one chunk)."""
        return len(self.chunks) > 1

    def seams(self) -> list[tuple[int, int]]:
        """The ``[start, stop)`` frames of each crossfade."""
        return [(c.start, c.start + c.fade_in) for c in self.chunks if c.fade_in]

    def lookahead_s(self, fps: int = FPS) -> float:
        """Seconds of audio after frame ``t`` needed to emit frame ``t``, at worst, when every chunk is
        generated as a whole from its own audio: a frame's output is final once every chunk that covers it
        is generated, and the first frame of a chunk waits for the audio up to that chunk's end."""
        worst = 0
        for chunk in self.chunks:
            worst = max(worst, chunk.stop - chunk.start)
        return worst / fps


def chunk_plan(num_frames: int, chunk_frames: int, overlap_frames: int) -> ChunkPlan:
    """Cut ``num_frames`` frames into chunks of ``chunk_frames`` overlapping by ``overlap_frames``.

    Chunks advance by ``chunk_frames - overlap_frames``; the last one ends at ``num_frames``
    and starts early enough to be a full chunk (its overlap with the one before is then
    longer; the crossfade covers all of it).

    Parameters
    ----------
    num_frames : int
        ``T >= 1``.
    chunk_frames : int
        Frames per chunk, ``>= 2``.
    overlap_frames : int
        ``0 <= overlap_frames < chunk_frames``.

    Returns
    -------
    ChunkPlan
    """
    num_frames, chunk_frames, overlap_frames = int(num_frames), int(chunk_frames), int(overlap_frames)
    if num_frames < 1:
        raise ValueError(f"chunk_plan: expected num_frames >= 1, got {num_frames}")
    if chunk_frames < 2:
        raise ValueError(f"chunk_plan: expected chunk_frames >= 2, got {chunk_frames}")
    if not 0 <= overlap_frames < chunk_frames:
        raise ValueError(f"chunk_plan: expected 0 <= overlap_frames < chunk_frames ({chunk_frames}), "
                         f"got {overlap_frames}")
    if num_frames <= chunk_frames:
        return ChunkPlan(num_frames, chunk_frames, overlap_frames, (Chunk(0, 0, num_frames),))
    stride = chunk_frames - overlap_frames
    chunks = [Chunk(0, 0, chunk_frames)]
    while chunks[-1].stop < num_frames:
        previous = chunks[-1]
        start = previous.start + stride
        stop = start + chunk_frames
        if stop > num_frames:  # the last chunk: a full one ending at the end
            stop = num_frames
            start = max(num_frames - chunk_frames, previous.start + 1)
        chunks.append(Chunk(len(chunks), start, stop, previous.stop - start))
    return ChunkPlan(num_frames, chunk_frames, overlap_frames, tuple(chunks))


def crossfade_weights(frames: int) -> np.ndarray:
    """The later chunk's weights ``(frames,)`` over a crossfade, strictly inside (0, 1), rising as a raised
    cosine: its largest step, ``pi / (2 (frames + 1))`` at most, bounds the step a disagreement between
    the two chunks adds to the blended track (a disagreement ``d`` adds at most ``d`` times it)."""
    i = np.arange(1, int(frames) + 1, dtype=np.float64)
    return 0.5 - 0.5 * np.cos(np.pi * i / (int(frames) + 1))


def chunk_section() -> dict:
    """The ``inference`` section of every chunking method's presets: ``chunk_frames`` and
    ``chunk_overlap``, None for the method's own default (``--config chunk_frames=N``)."""
    return {"chunk_frames": None, "chunk_overlap": None}


def chunk_options() -> tuple:
    """The two ``--config`` options of :func:`chunk_section`, typed (an integer or null)."""
    return (Option("chunk_frames", (int, type(None)), None,
                   "frames per chunk of a long utterance (null: the method's default)", minimum=2),
            Option("chunk_overlap", (int, type(None)), None,
                   "frames two consecutive chunks share, crossfaded (null: the method's default)", minimum=0,
                   below="chunk_frames"))


def chunk_setting(config: dict, key: str, default: int) -> int:
    """The integer ``key`` of any section of a method's nested ``config`` (``None`` or absent: ``default``).

    Chunking options (``chunk_frames``, ``chunk_overlap``) may be declared in whichever
    section a preset keeps them.
    """
    for section in (config or {}).values():
        if isinstance(section, dict) and section.get(key) is not None:
            value = section[key]
            if isinstance(value, bool) or int(value) != value:
                raise ValueError(f"{key}: expected an integer number of frames, got {value!r}")
            return int(value)
    return int(default)


def generate_in_chunks(generate_chunk: Callable[[np.ndarray, int, int], np.ndarray], audio: np.ndarray,
                       num_frames: int, plan: ChunkPlan, *, keep_chunks: list | None = None) -> np.ndarray:
    """Generate an utterance chunk by chunk and crossfade the overlaps.

    Parameters
    ----------
    generate_chunk : callable ``(audio (n,) ndarray, num_frames int, chunk_index int) -> (S, t, ...) ndarray``
        The method's generation of one chunk: frames along axis 1.
    audio : (N,) ndarray
        The utterance at 16 kHz.
    num_frames : int
        ``T``, the plan's ``num_frames``.
    plan : ChunkPlan
    keep_chunks : list, optional
        Receives each chunk's own output (for :func:`seam_report`); left empty
        otherwise, so that only the blended track is held.

    Returns
    -------
    (S, T, ...) float64 ndarray
        The chunks' outputs, each in its frames, crossfaded over the overlaps.
    """
    if int(num_frames) != plan.num_frames:
        raise ValueError(f"generate_in_chunks: the plan is for {plan.num_frames} frames, got {num_frames}")
    audio = np.asarray(audio)
    out = None
    # a counter of the chunks: a method's own bars (diffusion steps, ...) restart at each one
    for chunk in bar(plan.chunks, desc="chunks", unit="chunk", leave=False, disable=len(plan.chunks) < 2):
        first, last = chunk.samples(audio.shape[0])
        piece = audio[first:last]
        expected = frame_sample(chunk.stop) - frame_sample(chunk.start)
        if piece.shape[0] < expected:
            # audio that ends before the frames asked for: silence after its end, so that the
            # chunk's frames keep their times (a whole utterance would be stretched instead)
            piece = np.concatenate([piece, np.zeros(expected - piece.shape[0], dtype=piece.dtype)])
        part = np.asarray(generate_chunk(piece, chunk.num_frames, chunk.index), dtype=np.float64)
        if part.ndim < 2 or part.shape[1] != chunk.num_frames:
            raise ValueError(f"generate_in_chunks: chunk {chunk.index} gave shape {part.shape}, expected "
                             f"(S, {chunk.num_frames}, ...)")
        if keep_chunks is not None:
            keep_chunks.append(part)
        if out is None:
            out = np.empty((part.shape[0], plan.num_frames) + part.shape[2:], dtype=np.float64)
        if chunk.fade_in:
            w = crossfade_weights(chunk.fade_in).reshape((1, -1) + (1,) * (part.ndim - 2))
            seam = slice(chunk.start, chunk.start + chunk.fade_in)
            out[:, seam] = (1.0 - w) * out[:, seam] + w * part[:, :chunk.fade_in]
        out[:, chunk.start + chunk.fade_in:chunk.stop] = part[:, chunk.fade_in:]
    return out


def generate_utterance_in_chunks(generate: Callable, utterance, *, samples: int, seed: int, chunk_frames: int,
                                 overlap_frames: int, keep_chunks: list | None = None) -> np.ndarray:
    """A plug-in's ``generate(utterance, samples=, seed=)`` run chunk by chunk when the utterance is long.

    Each chunk is the same utterance (speaker, sentence) with its slice of the audio and
    its frame count, asked with the same ``samples`` and ``seed``, so that a method whose
    seed picks a style or a sample head keeps it across the chunks. An utterance of at
    most ``chunk_frames`` frames is one call of ``generate`` as it is.

    Returns
    -------
    (S, T, ...) ndarray
        ``generate``'s output for the whole utterance.
    """
    plan = chunk_plan(utterance.num_frames, chunk_frames, overlap_frames)
    if not plan.chunked:
        return generate(utterance, samples=samples, seed=seed)

    def one(audio, frames, _index):
        return generate(dataclasses.replace(utterance, audio=audio, num_frames=frames), samples=samples, seed=seed)

    return generate_in_chunks(one, utterance.audio, plan.num_frames, plan, keep_chunks=keep_chunks)


@dataclass(frozen=True)
class SeamReport:
    """The steps of a chunked track at its seams against those inside its chunks.

    Attributes
    ----------
    seam_step : float
        Largest ``|x[t + 1] - x[t]|`` (over every channel and sample) of a step that
        enters, crosses or leaves a crossfade; 0 for an unchunked track.
    inner_step : float
        Largest step of each chunk's own output over its frames (before blending).
    rate_bound : float
        The fit's bound per frame (:data:`RATE_BOUND`).
    """

    seam_step: float
    inner_step: float
    rate_bound: float = RATE_BOUND

    @property
    def ok(self) -> bool:
        """No seam step above both the rate bound and the largest step inside a chunk."""
        return self.seam_step <= max(self.rate_bound, self.inner_step) + 1e-12


def _steps(track: np.ndarray) -> np.ndarray:
    """``(T - 1,)``: the largest absolute change between frames ``t`` and ``t + 1`` of ``(S, T, ...)``."""
    diff = np.abs(np.diff(np.asarray(track, dtype=np.float64), axis=1))
    return diff.reshape(diff.shape[0], diff.shape[1], -1).max(axis=(0, 2)) if diff.size else np.zeros(0)


def seam_report(blended: np.ndarray, plan: ChunkPlan, chunks: list, *, rate_bound: float = RATE_BOUND) -> SeamReport:
    """Measure the seams of a chunked track (:func:`generate_in_chunks` with ``keep_chunks``).

    Parameters
    ----------
    blended : (S, T, ...) ndarray
        The crossfaded track.
    plan : ChunkPlan
    chunks : list of (S, t_i, ...) ndarrays
        Each chunk's own output.
    rate_bound : float, default :data:`RATE_BOUND`

    Returns
    -------
    SeamReport
    """
    if len(chunks) != len(plan.chunks):
        raise ValueError(f"seam_report: expected {len(plan.chunks)} chunk outputs, got {len(chunks)}")
    steps = _steps(blended)
    seam = 0.0
    for start, stop in plan.seams():
        # the step into the crossfade, those inside it and the step out of it
        window = steps[max(start - 1, 0):min(stop, steps.shape[0])]
        if window.size:
            seam = max(seam, float(window.max()))
    inner = max((float(_steps(part).max(initial=0.0)) for part in chunks), default=0.0)
    return SeamReport(seam_step=seam, inner_step=inner, rate_bound=float(rate_bound))


class ChunkedDecoder:
    """Chunked generation for an autoregressive vertex method (FaceFormer, CodeTalker): a mixin
    placed before its base class, reading ``chunk_frames`` and ``chunk_overlap`` from the
    method's resolved config (``self.settings``)."""

    @property
    def chunk_frames(self) -> int:
        """Frames per chunk of a long utterance (``chunk_frames`` of the config): default 600 (10 s), half
        the authors' ``max_seq_len`` of 600 frames at 30 fps and twice VOCASET's longest sentences."""
        return chunk_setting(self.settings, "chunk_frames", 600)

    @property
    def chunk_overlap(self) -> int:
        """Frames two chunks share (``chunk_overlap``): default one period of the positional encoding (1 s)."""
        return chunk_setting(self.settings, "chunk_overlap", 2 * int(self.settings["model"].get("period", 30)))

    @property
    def lookahead_s(self) -> float:
        """Audio after frame ``t`` that frame ``t`` needs, in seconds, at worst: one chunk. The decoder is
        causal, but the audio encoder sees the chunk's audio as a whole before the first frame is decoded."""
        return self.chunk_frames / FPS

    def generate(self, utterance, *, samples: int = 1, seed: int = 0):
        """``(S, T, V, 3)`` vertices (the base class's ``generate``); a long utterance chunk by chunk,
        each chunk restarting from the template with its overlap as context
        (:func:`generate_utterance_in_chunks`)."""
        return generate_utterance_in_chunks(super().generate, utterance, samples=int(samples), seed=int(seed),
                                            chunk_frames=self.chunk_frames, overlap_frames=self.chunk_overlap)
