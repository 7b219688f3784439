"""Calibration of the lip-sync estimators by shifting each utterance's audio.

A real capture carries its own audio-motion offset, so an estimator is not checked
against 0 but against itself: the audio of every utterance is delayed by ``k``
frames (:func:`shifted_audio`; ``k < 0`` advances it) and a sound estimator then
reads exactly ``k`` frames *less* than on the same utterance unshifted (positive
offsets mean the motion comes after the audio; delaying the audio makes the motion
earlier). :func:`calibrate` runs every estimator on every utterance and shift and
:class:`Calibration` summarises: the share of utterance-shifts whose estimate moved
by the shift within one frame (and exactly), the spread of the unshifted estimates,
their agreement with the geometric estimator's, and the confidence on the true
pairs (shift 0) against the shifted ones.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.runtime.progress import bar

#: Audio shifts (frames at 60 fps) of ``python -m benchmark.lipsync.calibrate``: 0 and
#: +-1, +-2, +-4, +-8.
DEFAULT_SHIFTS = (0, 1, -1, 2, -2, 4, -4, 8, -8)
#: Distance (frames) within which an estimate counts as right.
TOLERANCE = 1


def shifted_audio(samples, shift: int, rate: int = 16000, fps: float = 60.0) -> np.ndarray:
    """The audio delayed by ``shift`` frames at ``fps`` (advanced when negative), same length.

    A delay prepends ``round(shift * rate / fps)`` zero samples and drops as many at
    the end; an advance drops them at the start and appends zeros, so the speech at
    sample ``n`` of the input is at ``n + shift * rate / fps`` of the output.

    Parameters
    ----------
    samples : (N,) array_like
    shift : int
        Frames; positive delays the audio (the motion then comes ``shift`` frames
        earlier against it).
    rate : int
    fps : float

    Returns
    -------
    (N,) ndarray of the input's dtype
    """
    x = np.asarray(samples)
    if x.ndim != 1 or x.size == 0:
        raise UserError(f"shifted_audio: expected mono samples (N,), got shape {x.shape}")
    n = int(round(shift * rate / fps))
    if abs(n) >= len(x):
        raise UserError(f"shifted_audio: a shift of {shift} frames ({n} samples) is not shorter than the audio "
                        f"({len(x)} samples)")
    if n == 0:
        return x.copy()
    out = np.zeros_like(x)
    if n > 0:
        out[n:] = x[:-n]
    else:
        out[:n] = x[-n:]
    return out


def checked_shifts(shifts) -> tuple[int, ...]:
    """The shifts as distinct integers, 0 included (the reference), in the order given.

    Raises
    ------
    UserError
        Not integers, repeated, or without 0.
    """
    try:
        values = [int(s) for s in shifts]
    except (TypeError, ValueError):
        raise UserError(f"shifts: expected integers (frames at 60 fps), got {shifts!r}") from None
    if any(float(s) != v for s, v in zip(shifts, values)):
        raise UserError(f"shifts: expected whole frames, got {list(shifts)!r}")
    if len(set(values)) != len(values):
        raise UserError(f"shifts: each shift once, got {values}")
    if 0 not in values or len(values) < 2:
        raise UserError(f"shifts: expected 0 (the unshifted reference) and at least one other shift, got {values}")
    return tuple(values)


@dataclass(frozen=True)
class Utterance:
    """One utterance to calibrate on: its name, mono audio and rate, and per estimator
    what the estimator reads of its motion (an activity track, a coefficient track)."""

    name: str
    audio: np.ndarray
    rate: int
    motion: Mapping = field(default_factory=dict)


@dataclass(frozen=True)
class Calibration:
    """Estimates of every estimator on every utterance and audio shift.

    Attributes
    ----------
    shifts : tuple of int
        Audio shifts in frames (0 included).
    names : tuple of str
        Utterance names.
    offsets, confidences : dict
        ``{estimator: (utterances, shifts) array}``, offsets in the estimator's frames.
    frames_per_shift : dict
        ``{estimator: its frames per 60 fps frame}`` (1 except for 25 fps SyncNet).
    """

    shifts: tuple
    names: tuple
    offsets: dict
    confidences: dict
    frames_per_shift: dict = field(default_factory=dict)

    def _moved(self, estimator: str) -> np.ndarray:
        """(utterances, shifts) error of the move: estimate - unshifted estimate + expected move."""
        off = np.asarray(self.offsets[estimator], dtype=np.float64)
        ref = off[:, self.shifts.index(0)][:, None]
        scale = self.frames_per_shift.get(estimator, 1.0)
        return (off - ref) + scale * np.asarray(self.shifts, dtype=np.float64)[None, :]

    def within(self, estimator: str, tolerance: float = TOLERANCE) -> float:
        """Share of utterance-shifts (shift 0 left out) whose estimate moved by the
        shift within ``tolerance`` frames of the estimator."""
        err = self._moved(estimator)[:, [i for i, s in enumerate(self.shifts) if s != 0]]
        return float(np.mean(np.abs(err) <= tolerance + 1e-9))

    def within_by_shift(self, estimator: str, tolerance: float = TOLERANCE) -> dict:
        """``{shift: share of utterances within tolerance}``, shift 0 left out."""
        err = self._moved(estimator)
        return {s: float(np.mean(np.abs(err[:, i]) <= tolerance + 1e-9)) for i, s in enumerate(self.shifts) if s != 0}

    def unshifted(self, estimator: str) -> np.ndarray:
        """(utterances,) estimates on the audio as recorded."""
        return np.asarray(self.offsets[estimator], dtype=np.float64)[:, self.shifts.index(0)]

    def agreement(self, estimator: str, reference: str = "geometric", tolerance: float = TOLERANCE) -> float:
        """Share of utterances whose unshifted estimates of the two estimators are within
        ``tolerance`` frames (both in 60 fps frames)."""
        a = self.unshifted(estimator) / self.frames_per_shift.get(estimator, 1.0)
        b = self.unshifted(reference) / self.frames_per_shift.get(reference, 1.0)
        return float(np.mean(np.abs(a - b) <= tolerance + 1e-9))

    def summary(self) -> dict:
        """The figures of :func:`calibration_markdown`, JSON-ready."""
        out = {"shifts": list(self.shifts), "utterances": len(self.names), "tolerance_frames": TOLERANCE,
               "estimators": {}}
        zero = self.shifts.index(0)
        for est in self.offsets:
            conf = np.asarray(self.confidences[est], dtype=np.float64)
            moved = self._moved(est)
            base = self.unshifted(est)
            others = [i for i, s in enumerate(self.shifts) if s != 0]
            entry = {
                "within_1": self.within(est),
                "exact": float(np.mean(np.abs(moved[:, others]) < 0.5)),
                "within_1_by_shift": {str(k): v for k, v in self.within_by_shift(est).items()},
                "unshifted": {"mean": float(base.mean()), "std": float(base.std()), "median": float(np.median(base)),
                              "min": float(base.min()), "max": float(base.max())},
                "confidence_true": float(conf[:, zero].mean()),
                "confidence_shifted": float(conf[:, others].mean()),
                "frames_per_shift": self.frames_per_shift.get(est, 1.0),
            }
            if est != "geometric" and "geometric" in self.offsets:
                entry["agrees_with_geometric"] = self.agreement(est)
            out["estimators"][est] = entry
        out["per_utterance"] = [{"name": n, **{est: [int(v) for v in self.offsets[est][i]] for est in self.offsets}}
                                for i, n in enumerate(self.names)]
        return out


def calibrate(utterances: Sequence[Utterance], estimators: Mapping[str, Callable], *,
              shifts=DEFAULT_SHIFTS, fps: float = 60.0, frames_per_shift: Mapping | None = None) -> Calibration:
    """Every estimator on every utterance with its audio shifted by every shift.

    Parameters
    ----------
    utterances : sequence of Utterance
    estimators : mapping
        ``{name: estimate(motion, samples, rate) -> SyncEstimate}``; ``motion`` is
        ``utterance.motion[name]``.
    shifts : sequence of int
        Frames at ``fps``; must hold 0.
    frames_per_shift : mapping, optional
        ``{name: estimator frames per shift frame}`` (25 / 60 for SyncNet).

    Returns
    -------
    Calibration

    Raises
    ------
    UserError
        No utterances, no estimators or bad shifts.
    """
    shifts = checked_shifts(shifts)
    if not utterances:
        raise UserError("calibrate: no utterances to calibrate on")
    if not estimators:
        raise UserError("calibrate: no estimators")
    offsets = {name: np.zeros((len(utterances), len(shifts)), dtype=np.int64) for name in estimators}
    confidences = {name: np.zeros((len(utterances), len(shifts))) for name in estimators}
    for u, utt in enumerate(bar(list(utterances), desc="calibration", unit="utterance")):
        missing = [name for name in estimators if name not in utt.motion]
        if missing:
            raise DataError(f"calibrate: utterance {utt.name} has no motion for {missing}")
        for j, shift in enumerate(shifts):
            samples = shifted_audio(utt.audio, shift, utt.rate, fps)
            for name, estimate in estimators.items():
                est = estimate(utt.motion[name], samples, utt.rate)
                offsets[name][u, j] = est.offset
                confidences[name][u, j] = est.confidence
    return Calibration(shifts=shifts, names=tuple(u.name for u in utterances), offsets=offsets,
                       confidences=confidences, frames_per_shift=dict(frames_per_shift or {}))


_LABELS = {"geometric": "geometric", "expert": "learned expert", "syncnet": "SyncNet"}


def calibration_markdown(cal: Calibration, title: str = "") -> str:
    """A markdown table of a calibration: per estimator the share within one frame
    (overall and per shift), the exact share, the unshifted spread, the agreement with
    the geometric estimator and the confidences."""
    s = cal.summary()
    ests = list(s["estimators"])
    head = "| | " + " | ".join(_LABELS.get(e, e) for e in ests) + " |"
    rule = "|---|" + "---|" * len(ests)
    rows = [f"| moved by the shift within 1 frame ({len(cal.names)} utterances x "
            f"{len(cal.shifts) - 1} shifts) | " + " | ".join(f"{s['estimators'][e]['within_1']:.1%}" for e in ests) + " |",
            "| ... exactly | " + " | ".join(f"{s['estimators'][e]['exact']:.1%}" for e in ests) + " |"]
    for shift in cal.shifts:
        if shift == 0:
            continue
        rows.append(f"| ... shift {shift:+d} | " + " | ".join(
            f"{s['estimators'][e]['within_1_by_shift'][str(shift)]:.0%}" for e in ests) + " |")
    rows.append("| unshifted estimate: median [min, max], std | " + " | ".join(
        "{median:g} [{min:g}, {max:g}], {std:.2f}".format(**s["estimators"][e]["unshifted"]) for e in ests) + " |")
    if len(ests) > 1 and "geometric" in ests:
        rows.append("| unshifted within 1 frame of the geometric | " + " | ".join(
            f"{s['estimators'][e]['agrees_with_geometric']:.1%}" if "agrees_with_geometric" in s["estimators"][e]
            else "" for e in ests) + " |")
    rows.append("| confidence: true pairs / shifted pairs | " + " | ".join(
        f"{s['estimators'][e]['confidence_true']:.3f} / {s['estimators'][e]['confidence_shifted']:.3f}"
        for e in ests) + " |")
    lines = ([f"**{title}**", ""] if title else []) + [head, rule, *rows]
    return "\n".join(lines) + "\n"
