"""Driving signals of the facial motion at 60 fps, on the motion timeline.

The articulatory tracks of a sentence plan are sampled at the motion frame
times shifted by the true audio-motion lag, so frame ``t`` shows the
articulation of audio time ``(t - lag_frames) / fps``: a positive lag means the
face moves *after* the sound. Blinks, brow movement and a small articulatory
jitter are added; none of them depend on the ARKit rig.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from blendvoca.synthetic.plan import SentencePlan
from blendvoca.synthetic.tracks import articulation_tracks
from blendvoca.synthetic.variation import gesture_signals

FPS = 60

SIGNAL_NAMES = ("jaw", "round", "closure", "labiodental", "blink", "brow")
#: The signals of a corpus with undetermined components (``--audio-determined F < 1``).
VARIED_SIGNAL_NAMES = (*SIGNAL_NAMES, "smile", "corner_left", "corner_right", "press")


def blink_signal(num_frames: int, rng: np.random.Generator, *, rate: float = 0.3, fps: int = FPS) -> np.ndarray:
    """Eye closure in [0, 1], ``(T,) float64``: Poisson blinks of 120-220 ms."""
    out = np.zeros(num_frames)
    t = rng.exponential(1.0 / rate) if rate > 0 else np.inf
    frames = np.arange(num_frames) / fps
    while t < num_frames / fps:
        length = rng.uniform(0.12, 0.22)
        phase = (frames - t) / length
        inside = (phase >= 0) & (phase <= 1)
        out[inside] = np.maximum(out[inside], np.sin(np.pi * phase[inside]) ** 2)
        t += length + rng.exponential(1.0 / rate)
    return out


def motion_signals(
    plan: SentencePlan,
    num_frames: int,
    rng: np.random.Generator,
    *,
    lag_frames: int = 0,
    profile: dict | None = None,
    fps: int = FPS,
    jitter: float = 0.03,
    variation=None,
) -> dict[str, np.ndarray]:
    """Per-frame driving signals of one sentence.

    Parameters
    ----------
    plan : SentencePlan
    num_frames : int
        T, the number of motion frames.
    rng : numpy.random.Generator
    lag_frames : int
        True audio-motion lag in frames (positive: motion after audio).
    profile : dict, optional
        Speaker style (``jaw_gain``, ``round_gain``, ``brow_gain``,
        ``blink_rate``), see ``speaker_profile``; neutral defaults otherwise.
    fps : int
    jitter : float
        Standard deviation of the smooth articulatory noise, relative.
    variation : blendvoca.synthetic.variation.SentenceVariation, optional
        The undetermined components of this draw: the articulation follows its
        onset-jittered plan with the speaker's viseme offsets, scaled by its
        intensity, from the speaker's rest posture, and its pause gestures are
        added as signals. ``rng`` is drawn from exactly as without it (the
        audio drawn after the signals is the same). None: the old model.

    Returns
    -------
    dict of (T,) ndarray
        ``jaw`` [0, 1.3], ``round`` [-1, 1], ``closure`` [0, 1],
        ``labiodental`` [0, 1], ``blink`` [0, 1], ``brow`` [0, 1] on the motion
        timeline, and ``envelope`` (the syllable envelope on the *audio*
        timeline, for lag measurements); with ``variation`` also ``smile``,
        ``corner_left``, ``corner_right`` and ``press`` in [0, 1].
    """
    if num_frames < 1:
        raise ValueError(f"motion_signals: num_frames must be >= 1, got {num_frames}")
    p = {"jaw_gain": 1.0, "round_gain": 1.0, "brow_gain": 0.7, "blink_rate": 0.3}
    p.update(profile or {})
    frame_times = np.arange(num_frames, dtype=np.float64) / fps
    audio_timeline = articulation_tracks(plan, frame_times)
    if variation is None:
        motion = articulation_tracks(plan, frame_times - lag_frames / fps)
    else:
        motion = articulation_tracks(variation.motion_plan, frame_times - lag_frames / fps,
                                     offsets=variation.offsets)

    def smooth_noise(sigma_frames: float) -> np.ndarray:
        n = gaussian_filter1d(rng.standard_normal(num_frames + 40), sigma_frames, mode="wrap")[20:-20]
        return n / (n.std() + 1e-12)

    if variation is None:
        jaw = motion["jaw"] * p["jaw_gain"] * (1.0 + jitter * smooth_noise(6.0))
        rnd = np.clip(motion["round"] * p["round_gain"] + jitter * smooth_noise(8.0), -1.0, 1.0)
    else:  # same draws, in the same order
        rest = variation.rest
        jaw = rest["jaw"] + motion["jaw"] * variation.gain * p["jaw_gain"] * (1.0 + jitter * smooth_noise(6.0))
        rnd = np.clip(rest["round"] + motion["round"] * variation.gain * p["round_gain"]
                      + jitter * smooth_noise(8.0), -1.0, 1.0)
    # Brows rise with loud (stressed) stretches of speech, slowly, plus a drift.
    brow = gaussian_filter1d(motion["envelope"], 0.25 * fps, mode="nearest")
    brow = np.clip(p["brow_gain"] * (brow / (brow.max() + 1e-12)) * 0.6 + 0.15 * smooth_noise(30.0), 0.0, 1.0)
    out = {
        "jaw": np.clip(jaw, 0.0, 1.3),
        "round": rnd,
        "closure": np.clip(motion["closure"], 0.0, 1.0),
        "labiodental": np.clip(motion["labiodental"], 0.0, 1.0),
        "blink": blink_signal(num_frames, rng, rate=p["blink_rate"], fps=fps),
        "brow": brow,
        "envelope": audio_timeline["envelope"],
    }
    if variation is not None:
        gestures = gesture_signals(variation.gestures, num_frames, lag_frames, fps=fps)
        gestures["smile"] = np.clip(gestures["smile"] + variation.rest["smile"], 0.0, 1.0)
        out.update(gestures)
    return out
