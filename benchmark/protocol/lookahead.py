"""The look-ahead a method actually uses: a causality probe beside the declared one.

A method declares ``lookahead_s``, the seconds of audio after frame ``t`` that frame
``t`` needs; nothing in the declaration proves it (a "streaming" model may run its
audio encoder over the whole utterance). The probe measures it from the outputs:

1. Cut the utterance at frame ``m`` (time ``c = m / FPS``): the audio from sample
   ``round(c * AUDIO_RATE)`` on is replaced, same length, first with silence, then
   with Gaussian noise at the level of the audio before the cut (seed
   :data:`NOISE_SEED`).
2. Generate each with the seed of the unchanged run (a sampling method's random
   streams fixed: only the audio differs) and find the earliest frame ``f`` whose
   output differs from the unchanged one by more than the tolerance (float noise:
   :data:`FLOAT_TOLERANCE` of the output's scale, and twice the difference between two
   identical calls, which the probe makes once).
3. Frame ``f`` listened to audio at least ``c - f / FPS`` seconds after itself: that
   is the probe's look-ahead (0 when no frame changed). When the first frame changed,
   the output depends on audio as far as the probe can see: recorded as the whole
   utterance (its length; ``whole_utterance``), except for a cut the declaration
   itself covers, whose lower bound ``c`` is all it shows.

The measured look-ahead is the largest over the probes. By default each probed
sentence is cut once, at a fraction of its length (:data:`PROBE_FRACTIONS`) but never
before the declared look-ahead plus two frames where the sentence is that long, so that
a method keeping its declaration never changes its first frame; ``--lookahead-probes`` names the cut times
instead (seconds into each probed sentence; one outside a sentence is refused,
:func:`benchmark.protocol.spec.checked_probe_times`). A method exceeds its declaration when the measured
look-ahead is more than one frame (:data:`FRAME_S`, the probe's resolution) beyond it.

Cost: two ``generate`` calls per cut (one sample each) and one repeat of an unchanged
call; the unchanged outputs are those :func:`~benchmark.protocol.generation.measure_latency`
timed. With the defaults (three sentences, one cut each): seven calls, each a whole
sentence.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from benchmark.methods import AUDIO_RATE, FPS
from blendvoca.errors import MethodOutputError

__all__ = ["FLOAT_TOLERANCE", "FRAME_S", "NOISE_SEED", "PROBE_FRACTIONS",
           "earliest_changed_frame", "exceeds_declaration", "lookahead_probe", "probe_cut_frames"]

#: Relative tolerance of "the output changed": just above float32 noise on the output's scale.
FLOAT_TOLERANCE = 1e-6
#: Seed of the noise that replaces the audio after a cut.
NOISE_SEED = 0
#: Where the default probe cuts the ``i``-th probed sentence (fraction of its length, cycling).
PROBE_FRACTIONS = (0.5, 0.65, 0.8)
#: One frame in seconds: the probe's resolution, and how far a measured look-ahead may
#: exceed the declared one before the tables mark it.
FRAME_S = 1.0 / FPS
#: Two identical calls that differ by more than this share of the output's scale: the
#: method does not reproduce with a fixed seed and the probe cannot measure it.
UNREPRODUCIBLE = 1e-3


def probe_cut_frames(num_frames: int, declared_s: float | None, index: int, times=None) -> list:
    """The frames where the probe cuts a sentence of ``num_frames`` frames (its
    ``index``-th probed one): ``times`` (seconds) at their frame, else one cut at
    :data:`PROBE_FRACTIONS` ``[index]`` of its length, moved to at least the declared
    look-ahead plus two frames where the sentence is that long (where it is not, the
    declaration covers the whole sentence and the fraction stays)."""
    last = num_frames - 1
    if last < 1:
        return []
    if times is not None:
        return sorted({min(last, max(1, int(math.ceil(float(t) * FPS - 1e-9)))) for t in times})
    cut = int(round(PROBE_FRACTIONS[index % len(PROBE_FRACTIONS)] * num_frames))
    after = None if declared_s is None else int(math.ceil(float(declared_s) * FPS - 1e-9)) + 2
    if after is not None and after <= last:  # else the declaration covers the sentence: any cut is within it
        cut = max(cut, after)
    return [min(last, max(1, cut))]


def _frames_first(output) -> np.ndarray:
    """A ``generate`` output ``(S, T, ...)`` as ``(T, n)`` float64 (frames first)."""
    array = np.asarray(output, dtype=np.float64)
    if array.ndim < 2:
        raise MethodOutputError(f"expected an output of shape (S, T, ...), got shape {array.shape}")
    return np.moveaxis(array, 1, 0).reshape(array.shape[1], -1)


def earliest_changed_frame(reference, changed, tolerance: float) -> int | None:
    """The first frame where ``changed`` differs from ``reference`` (both ``(S, T, ...)``)
    by more than ``tolerance`` in some value; None when no frame does.

    Raises
    ------
    MethodOutputError
        The shapes differ.
    """
    a, b = _frames_first(reference), _frames_first(changed)
    if a.shape != b.shape:
        raise MethodOutputError(f"expected the probe's output in the shape of the unchanged one {a.shape}, "
                                f"got {b.shape}")
    moved = np.flatnonzero((~np.isclose(a, b, rtol=0.0, atol=tolerance, equal_nan=True)).any(axis=1))
    return int(moved[0]) if moved.size else None


def _replaced(audio: np.ndarray, start: int, kind: str) -> np.ndarray:
    """``audio`` with its samples from ``start`` on replaced (same length): zeros, or noise
    at the RMS of the samples before ``start`` (seed :data:`NOISE_SEED`)."""
    out = np.array(audio, dtype=np.float32, copy=True)
    if kind == "silence":
        out[start:] = 0.0
        return out
    head = out[:start].astype(np.float64)
    level = float(np.sqrt(np.mean(head ** 2))) if head.size else 0.0
    level = level if level > 1e-4 else 0.1
    noise = np.random.default_rng(NOISE_SEED).standard_normal(out.size - start) * level
    out[start:] = np.clip(noise, -1.0, 1.0).astype(np.float32)
    return out


def exceeds_declaration(measured_s: float | None, declared_s: float | None, frame_s: float = FRAME_S) -> bool:
    """Whether a measured look-ahead is more than one frame beyond the declared one
    (a method that declares none, i.e. the whole utterance, never is)."""
    if measured_s is None or declared_s is None:
        return False
    return float(measured_s) > float(declared_s) + float(frame_s) + 1e-9


def lookahead_probe(generate, utterances, references, seeds, *, declared_s: float | None, times=None) -> dict:
    """Measure how far ahead of its output a method listens (see the module docstring).

    Parameters
    ----------
    generate : callable
        ``generate(utterance, seed) -> (S, T, ...)`` output: the method asked for one
        sample (the caller wraps it as a plug-in call).
    utterances : sequence of Utterance
        The probed sentences.
    references : sequence of array
        Each sentence's unchanged output, from ``generate(utterance, seed)``.
    seeds : sequence of int
        Each sentence's seed (the run's, :func:`~benchmark.protocol.generation.sentence_seed`).
    declared_s : float or None
        The method's declared look-ahead (None: the whole utterance).
    times : sequence of float, optional
        Cut times in seconds (:func:`benchmark.protocol.spec.checked_probe_times`); None: the default cuts.

    Returns
    -------
    dict
        ``{"measured_lookahead_s", "lookahead_probe": {"probes": [{"subject", "sentence",
        "duration_s", "cut_s", "changed_from_s", "lookahead_s", "whole_utterance"}],
        "whole_utterance", "generate_calls", "tolerance", "frame_s", "note"}}``;
        ``measured_lookahead_s`` None (and ``note`` saying why) when the method does not
        reproduce its output with a fixed seed.
    """
    utterances, references, seeds = list(utterances), list(references), [int(s) for s in seeds]
    calls, probes, note = 0, [], None
    tolerance = None
    if utterances:
        first = _frames_first(references[0])
        again = _frames_first(generate(utterances[0], seeds[0]))
        calls += 1
        scale = max(1.0, float(np.nanmax(np.abs(first))) if first.size else 1.0)
        drift = float(np.nanmax(np.abs(first - again))) if first.shape == again.shape else math.inf
        if drift > UNREPRODUCIBLE * scale:
            note = (f"not measured: two calls with the same seed and audio differ by {drift:.3g} (the method does "
                    "not reproduce its output with a fixed seed)")
        tolerance = FLOAT_TOLERANCE * scale + 2.0 * drift
    for index, (utterance, reference, seed) in enumerate(zip(utterances, references, seeds)):
        if note is not None:
            break
        frames = int(utterance.num_frames)
        duration = frames / FPS
        for cut in probe_cut_frames(frames, declared_s, index, times):
            start = min(int(round(cut * AUDIO_RATE / FPS)), utterance.audio.shape[0])
            changed = []
            for kind in ("silence", "noise"):
                probe = dataclasses.replace(utterance, audio=_replaced(utterance.audio, start, kind))
                changed.append(earliest_changed_frame(reference, generate(probe, seed), tolerance))
                calls += 1
            changed = [f for f in changed if f is not None]
            earliest = min(changed) if changed else None
            cut_s = cut / FPS
            whole = False
            if earliest is None:
                seconds = 0.0
            elif earliest > 0:
                seconds = max(0.0, (cut - earliest) / FPS)
            elif declared_s is not None and cut_s <= declared_s + FRAME_S < duration:
                seconds = cut_s  # a cut the declaration covers: at least this far, which it allows
            else:
                seconds, whole = duration, True  # as far as the probe can see: the whole utterance
            probes.append({"subject": utterance.subject, "sentence": utterance.sentence,
                           "duration_s": round(duration, 4), "cut_s": round(cut_s, 4),
                           "changed_from_s": None if earliest is None else round(earliest / FPS, 4),
                           "lookahead_s": round(seconds, 4), "whole_utterance": bool(whole)})
    measured = None
    if note is None and probes:
        measured = max(p["lookahead_s"] for p in probes)
    elif note is None:
        note = "not measured: no sentence long enough to cut (two frames at least)"
    widest = [p for p in probes if measured is not None and p["lookahead_s"] == measured]
    return {"measured_lookahead_s": measured,
            "lookahead_probe": {"probes": probes, "whole_utterance": any(p["whole_utterance"] for p in widest),
                                "generate_calls": calls, "frame_s": round(FRAME_S, 6),
                                "tolerance": tolerance if tolerance is not None and math.isfinite(tolerance) else None,
                                "note": note}}
