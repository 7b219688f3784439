"""Long takes cut into utterances: pauses found in the speech, cuts where sound and motion are quiet.

A coefficient corpus may hold takes of a minute or two (FACEGOOD's are 48-113 s); a
BlendVOCA sentence is an utterance of a few seconds. :func:`take_spans` cuts a take
(its 60 fps track and its audio) into consecutive spans that cover it without gap:

1. **Speech activity** (:func:`speech_activity`): a frame speaks when the energy of the
   audio around it (a 30 ms Hann window) is within :data:`SPEECH_RANGE_DB` of the take's
   loud level (its 95th percentile); gaps shorter than :data:`MIN_GAP_S` (stop closures)
   are filled, bursts shorter than :data:`MIN_BURST_S` (clicks) dropped.
2. **Pauses** (:func:`pauses`): the silent runs of at least :data:`MIN_PAUSE_S`. In each,
   the candidate cut is the still frame (:func:`motion_speed`, the frame-to-frame change
   of all shapes smoothed over 50 ms, at most :data:`STILL` of the take's median, or the
   pause's slowest frame) nearest the pause's middle, so a cut falls where sound and
   motion are both quiet. Its score is the pause's length (capped at 1 s),
   scaled down when the motion there is faster than the take's median.
3. **Choice** (:func:`choose_cuts`): dynamic programming over the candidates picks the
   cuts that keep every utterance within ``[min_s, max_s]`` (2-10 s) and maximise the
   pause scores less ``((length - target_s) / 4 s)^2`` per utterance (utterances near
   :data:`TARGET_S`, at the longest, stillest pauses). Where no pause allows it (speech
   of over 10 s without one), a frame with no pause is cut, at a heavy cost, where the
   sound is quietest: such a cut is recorded as ``forced``.

A take no longer than ``max_s`` is one utterance; one shorter than ``min_s`` cannot
make one (:class:`ShortTakeError`, the take's failure). A user's cut list
(:func:`read_cut_list`, ``--cuts FILE``) replaces the automatic cuts of the takes it names.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.audio import energy_db

#: Utterance lengths (seconds) the automatic cutting keeps to, and the length it prefers.
MIN_S, MAX_S, TARGET_S = 2.0, 10.0, 6.0
#: A frame speaks when its energy is within this many dB of the take's loud level (95th percentile).
SPEECH_RANGE_DB = 30.0
#: Silences shorter than this inside speech are not pauses (stop closures, between syllables).
MIN_GAP_S = 0.15
#: Sound bursts shorter than this are not speech (clicks, breaths).
MIN_BURST_S = 0.05
#: A silence is a pause a take may be cut at when at least this long.
MIN_PAUSE_S = 0.25
#: Within a pause, frames moving at most this share of the take's median speed count as still.
STILL = 0.1
#: The score of a cut where there is no pause (only where every other choice breaks the length limits).
FORCED_SCORE = -20.0
#: How a span's end was decided: at a pause, forced (no pause in reach), by the user's list, the take's end.
CUT_KINDS = ("pause", "forced", "user", "end")


class ShortTakeError(DataError):
    """A take shorter than the shortest utterance (nothing to build from it)."""


class CutListError(UserError):
    """A user's cut list that cannot be used (not JSON of take -> increasing seconds, an unknown take)."""


@dataclass(frozen=True)
class Span:
    """One utterance of a take: frames ``[start, end)`` at the track's rate.

    ``cut`` says how its end was decided (:data:`CUT_KINDS`).
    """

    start: int
    end: int
    cut: str


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, end)`` of every run of True in a boolean vector."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def speech_activity(samples, rate: int, fps: float, frames: int) -> np.ndarray:
    """``(frames,)`` bool: whether each frame of the take speaks (module docstring, step 1)."""
    db = energy_db(samples, rate, fps, frames)
    active = db > np.percentile(db, 95) - SPEECH_RANGE_DB
    for start, end in _runs(~active):  # short silences inside speech are not pauses
        if start > 0 and end < frames and end - start < MIN_GAP_S * fps:
            active[start:end] = True
    for start, end in _runs(active):
        if end - start < MIN_BURST_S * fps:
            active[start:end] = False
    return active


def pauses(active: np.ndarray, fps: float, min_pause_s: float = MIN_PAUSE_S) -> list[tuple[int, int]]:
    """``[start, end)`` frames of the silent runs of at least ``min_pause_s``, in order."""
    return [(s, e) for s, e in _runs(~np.asarray(active, dtype=bool)) if e - s >= min_pause_s * fps]


def motion_speed(track, fps: float) -> np.ndarray:
    """``(T,)`` how fast the face moves at each frame: the norm of the frame-to-frame change of all
    shapes, smoothed over 50 ms (the first frame gets the second's value)."""
    track = np.asarray(track, dtype=np.float64)
    step = np.linalg.norm(np.diff(track, axis=0), axis=1) if len(track) > 1 else np.zeros(0)
    speed = np.concatenate([step[:1], step]) if len(step) else np.zeros(len(track))
    width = max(1, int(round(0.05 * fps)))
    return np.convolve(speed, np.ones(width) / width, mode="same")


def cut_candidates(active: np.ndarray, speed: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """One candidate cut per pause (its stillest frame) and its score (module docstring, step 2).

    Returns
    -------
    frames : (C,) int64, increasing
    scores : (C,) float64
    """
    reference = float(np.median(speed)) if len(speed) else 0.0
    frames, scores = [], []
    for start, end in pauses(active, fps):
        if start == 0 or end == len(active):  # leading or trailing silence: nothing to cut from
            continue
        inside = speed[start:end]
        still = np.flatnonzero(inside <= max(float(inside.min()), STILL * reference))
        at = start + int(still[np.argmin(np.abs(still - (end - start - 1) / 2))])  # the still frame nearest the middle
        stillness = 1.0 if speed[at] <= reference or speed[at] == 0 else reference / speed[at]
        frames.append(at)
        scores.append(min((end - start) / fps, 1.0) * stillness)
    return np.asarray(frames, dtype=np.int64), np.asarray(scores, dtype=np.float64)


def choose_cuts(frames: int, candidates, scores, fps: float, *, min_s: float = MIN_S, max_s: float = MAX_S,
                target_s: float = TARGET_S, fallback=None) -> list[tuple[int, str]]:
    """The cuts of a take of ``frames`` frames (module docstring, step 3).

    Parameters
    ----------
    candidates, scores : (C,) the pause cuts and their scores (:func:`cut_candidates`)
    fallback : (frames,) float, optional
        The cost of a forced cut at each frame (e.g. the audio energy, lower where quieter);
        forced cuts are only made where the pauses cannot keep the lengths within limits.

    Returns
    -------
    list of (frame, kind)
        Increasing frames strictly inside the take, ``kind`` ``"pause"`` or ``"forced"``.
    """
    lo, hi = int(math.ceil(min_s * fps - 1e-9)), int(math.floor(max_s * fps + 1e-9))
    points = {0: (0.0, "start"), frames: (0.0, "end")}
    if fallback is not None:
        cost = np.asarray(fallback, dtype=np.float64)
        span = float(np.ptp(cost)) or 1.0
        for f in range(1, frames):
            points[f] = (FORCED_SCORE - (cost[f] - cost.min()) / span, "forced")
    for f, s in zip(np.asarray(candidates).tolist(), np.asarray(scores).tolist()):
        if 0 < f < frames:
            points[f] = (float(s), "pause")
    at = np.array(sorted(points), dtype=np.int64)
    gain = np.array([points[f][0] for f in at.tolist()])
    best = np.full(len(at), -np.inf)
    back = np.full(len(at), -1, dtype=np.int64)
    best[0] = 0.0
    for j in range(1, len(at)):
        first = np.searchsorted(at, at[j] - hi, side="left")
        last = np.searchsorted(at, at[j] - lo, side="right")
        if last <= first:
            continue
        lengths = (at[j] - at[first:last]) / fps
        total = best[first:last] - ((lengths - target_s) / 4.0) ** 2
        k = int(np.argmax(total))
        if np.isfinite(total[k]):
            best[j], back[j] = total[k] + gain[j], first + k
    if not np.isfinite(best[-1]):
        return []
    cuts, j = [], back[-1]
    while j > 0:
        cuts.append((int(at[j]), points[int(at[j])][1]))
        j = back[j]
    return cuts[::-1]


def take_spans(track, samples, rate: int, fps: float, *, where: str, cuts_s=None, long_take: bool = True,
               min_s: float = MIN_S, max_s: float = MAX_S) -> list[Span]:
    """A take cut into utterances (the module docstring), or by the user's cuts ``cuts_s`` (seconds).

    Parameters
    ----------
    track : (T, K) the take's weights at ``fps``
    samples : (N,) its audio at ``rate`` (as long as the track)
    where : str
        The take, for messages.
    cuts_s : sequence of float, optional
        The user's cut times in seconds, increasing, inside the take.
    long_take : bool
        The take comes from a corpus of long takes: shorter than ``min_s``, it fails (otherwise
        it is kept whole, as a corpus of sentences has them).

    Returns
    -------
    list of Span
        Consecutive, covering ``[0, T)``.

    Raises
    ------
    ShortTakeError
        A ``long_take`` shorter than ``min_s`` (and no user cuts are given).
    DataError
        A user cut outside the take, or two that round to the same frame.
    """
    frames = len(track)
    if cuts_s is not None:
        cut_frames = [int(round(float(c) * fps)) for c in cuts_s]
        seconds = frames / fps
        outside = [c for c, f in zip(cuts_s, cut_frames) if not 0 < f < frames]
        if outside:
            raise DataError(f"{where}: the cut list cuts at {outside[0]} s, outside the take (0 to {seconds:.2f} s)")
        if any(b <= a for a, b in zip(cut_frames, cut_frames[1:])):
            raise DataError(f"{where}: two cuts of the cut list fall on the same frame at {fps:g} fps: {list(cuts_s)}")
        edges = [0] + cut_frames + [frames]
        return [Span(a, b, "user" if b < frames else "end") for a, b in zip(edges, edges[1:])]
    if long_take and frames < min_s * fps - 1e-9:
        raise ShortTakeError(f"{where}: {frames / fps:.2f} s long, shorter than one utterance ({min_s:g} s); "
                             f"expected a take of at least {min_s:g} s of speech")
    if frames <= max_s * fps + 1e-9:
        return [Span(0, frames, "end")]
    active = speech_activity(samples, rate, fps, frames)
    speed = motion_speed(track, fps)
    candidates, scores = cut_candidates(active, speed, fps)
    cuts = choose_cuts(frames, candidates, scores, fps, min_s=min_s, max_s=max_s)
    if not cuts:  # pauses alone cannot keep the limits: allow cuts where the sound is quietest
        energy = energy_db(samples, rate, fps, frames)
        cuts = choose_cuts(frames, candidates, scores, fps, min_s=min_s, max_s=max_s, fallback=energy + speed)
    edges = [0] + [f for f, _ in cuts] + [frames]
    kinds = [k for _, k in cuts] + ["end"]
    return [Span(a, b, k) for a, b, k in zip(edges, edges[1:], kinds)]


def read_cut_list(path) -> dict[str, tuple[float, ...]]:
    """A user's cut list: a JSON object of take name -> the seconds at which to cut it, increasing.

    ``{"1114_2_01": [4.2, 9.75, 15.0], "1114_3_15": []}``: take ``1114_2_01`` is cut into
    utterances ``[0, 4.2)``, ``[4.2, 9.75)``, ``[9.75, 15.0)`` and ``[15.0, end)`` seconds; an
    empty list keeps a take whole. Takes the list does not name are cut automatically.

    Raises
    ------
    CutListError
        Not readable, not a JSON object, a take whose value is not a list of finite
        numbers > 0 in increasing order (naming the file and the take).
    """
    path = Path(os.fspath(path)).expanduser()
    expected = ('a JSON object of take name -> increasing cut times in seconds, e.g. {"1114_2_01": [4.2, 9.75]}')
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise CutListError(f"--cuts {path}: not readable ({error.strerror or error}); expected {expected}") from None
    except (ValueError, UnicodeDecodeError) as error:
        raise CutListError(f"--cuts {path}: not JSON ({error}); expected {expected}") from None
    if not isinstance(document, dict):
        raise CutListError(f"--cuts {path}: a JSON {type(document).__name__}; expected {expected}")
    cuts = {}
    for take, times in document.items():
        if not isinstance(times, list) or not all(isinstance(t, (int, float)) and not isinstance(t, bool)
                                                  for t in times):
            raise CutListError(f"--cuts {path}: take {take!r}: {times!r:.60} is not a list of numbers; expected {expected}")
        if not all(math.isfinite(t) and t > 0 for t in times) or any(b <= a for a, b in zip(times, times[1:])):
            raise CutListError(f"--cuts {path}: take {take!r}: cut times {times!r:.80} are not positive and "
                               "increasing")
        cuts[str(take)] = tuple(float(t) for t in times)
    return cuts


def check_cut_list(cuts: dict, takes, *, path) -> None:
    """Refuse a cut list that names a take the corpus does not have (:class:`CutListError`, listing the takes)."""
    known = set(takes)
    unknown = sorted(set(cuts) - known)
    if unknown:
        raise CutListError(f"--cuts {path}: takes not in the corpus: {unknown[:5]}; its takes are "
                           f"{sorted(known)[:10]}{' ...' if len(known) > 10 else ''}")
