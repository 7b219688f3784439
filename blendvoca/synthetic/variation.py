"""Motion that the inputs (the audio and the speaker id) do not determine, in the speech shapes.

The plan of a sentence drives both its audio and its articulation, so without
this module the motion is almost a function of the audio. Here, in the
speech shapes themselves:

- **speaker style** (fixed per speaker, so determined by the speaker id): the
  speaker's own viseme targets (jaw and rounding offsets per vowel and per
  consonant place), a left/right asymmetry of the lip motion and a rest posture
  (jaw slightly open, lips rounded or spread, a slight smile);
- **articulation intensity** (per utterance, per phrase, drifting slowly): the
  jaw and rounding excursions are scaled by ``exp(u + p(t) + d(t))``;
- **gesture onset jitter**: every phone boundary of the *articulation* moves by
  a zero-mean random time (the audio keeps the plan's timing), in the range of
  the token-to-token variability of anticipatory lip-rounding onsets
  (Perkell & Matthies 1992; see ``docs/synthetic.md``);
- **pause gestures**: random lip presses, smiles and one-sided corner pulls in
  the pauses (leading and trailing silence, phrase pauses);
- for the oracle samples only, fresh draws of what the old generator already
  randomised per sentence (the audio-motion lag, the 3 % articulatory jitter,
  blinks and brows) and of the head motion.

``scale`` (from :func:`undetermined_scale`, set by ``--audio-determined F``)
multiplies the size of every undetermined component; ``F = 1`` turns the
module off and the corpus is the old one bit for bit.

Random streams: every component draws from its own generator,
``SeedSequence([seed, 4]).spawn(len(COMPONENTS))[c]`` extended by the item's
spawn key ``(speaker[, sentence, sample])`` (exactly what ``.spawn`` gives the
children of that child), so adding or removing a component, or changing how
much one draws, leaves the draws of every other one unchanged; stream kind 4
was never used by the old generator (its kinds are 0-3), whose draws are
therefore unchanged too. ``sample`` is 0 for the ground truth and ``k + 1``
for oracle sample ``k``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from blendvoca.errors import UserError
from blendvoca.synthetic.phonetics import CONSONANTS, VOWELS
from blendvoca.synthetic.plan import SILENCE, SentencePlan

#: Stream kind of this module's generators (``[seed, 4]``); the old generator used 0-3.
STREAM_KIND = 4
#: One random stream per component, in this order. Append only: a component's
#: stream is its index's child, so reordering would change the draws.
COMPONENTS = ("style", "intensity", "onset", "pauses", "resample", "head")
#: The sample key of the ground truth; oracle sample ``k`` is ``k + 1``.
TRUTH = 0

#: Places of articulation (the consonant classes of the speaker's viseme offsets).
PLACES = tuple(sorted({c["place"] for c in CONSONANTS.values()}))
#: The classes whose targets a speaker shifts: every vowel and every place.
PHONE_CLASSES = (*VOWELS, *PLACES)

#: Speaker style (not scaled: it is determined by the speaker id).
STYLE = {
    "vowel_jaw_sd": 0.08, "vowel_round_sd": 0.15,
    "consonant_jaw_sd": 0.04, "consonant_round_sd": 0.10,
    "asymmetry_max": 0.25,
    "rest_jaw_max": 0.06, "rest_round_max": 0.15, "rest_smile_max": 0.20,
}
#: Articulation intensity at scale 1: log-gain standard deviations and time constants.
INTENSITY = {"utterance_sd": 0.12, "phrase_sd": 0.10, "drift_sd": 0.08, "drift_sigma_s": 0.6,
             "phrase_smoothing_s": 0.15, "phrase_pause_s": 0.15, "limit_sd": 2.0}
#: Gesture onset jitter at scale 1 (seconds; clipped at ``limit_sd`` standard
#: deviations and so that every segment keeps at least 30 % of its length).
ONSET = {"sd_s": 0.025, "limit_sd": 2.5, "max_fraction": 0.35,
         "source": "Perkell & Matthies (1992), J. Acoust. Soc. Am. 91(5):2911-2925: token-to-token "
                   "variability of the onset of anticipatory lip protrusion, tens of milliseconds"}
#: Pause gestures: one gesture per pause with probability ``min(1, probability * scale)``.
PAUSES = {"min_pause_s": 0.15, "probability": 0.6, "kinds": ["press", "smile", "corner_left", "corner_right"],
          "weights": [0.35, 0.30, 0.175, 0.175], "duration_fraction": [0.5, 1.0], "amplitude": [0.4, 1.0]}
#: New driving signals (in [0, 1]) that the face model understands.
GESTURE_SIGNALS = tuple(PAUSES["kinds"])

#: ``--audio-determined F`` -> ``scale``: ``(scale, share)`` with the share of a speaker's
#: speech-shape coefficient variance that the conditional mean explains, measured on
#: built corpora (12 speakers x 6 sentences of 3-5 s, 6 oracle samples, seed 2:
#: ``python -m blendvoca.synthetic.calibrate --out DIR --speakers 12 --sentences 6
#: --oracle-samples 6 --seed 2 --scales 0,0.5,1,1.25,1.5,2,3,4``; docs/synthetic.md).
#: Decreasing in scale; scale 0 keeps the speaker styles, so its share is the floor
#: that the per-sentence lag and jitter set.
CALIBRATION = ((0.0, 0.851), (0.5, 0.823), (1.0, 0.761), (1.25, 0.731), (1.5, 0.703), (2.0, 0.654), (3.0, 0.569),
               (4.0, 0.497))


def component_rng(seed: int, component: str, *item: int) -> np.random.Generator:
    """The generator of ``component`` for one item (``speaker[, sentence, sample]``).

    ``SeedSequence([seed, STREAM_KIND]).spawn(len(COMPONENTS))[index]`` is the
    component's stream; the item's keys extend its spawn key, as spawning from it
    would.
    """
    if component not in COMPONENTS:
        raise ValueError(f"component_rng: unknown component {component!r}; expected one of {COMPONENTS}")
    root = np.random.SeedSequence([int(seed), STREAM_KIND])
    child = root.spawn(len(COMPONENTS))[COMPONENTS.index(component)]
    keys = tuple(int(k) for k in item)
    return np.random.default_rng(np.random.SeedSequence(child.entropy, spawn_key=child.spawn_key + keys))


def undetermined_scale(audio_determined: float) -> float:
    """``scale`` of the undetermined components for a declared audio-determined share F.

    Raises
    ------
    UserError
        F outside the range the generator can make: ``(F_min, F_max] or F = 1``,
        where F_max is what the per-sentence lag and jitter alone leave.
    """
    f = float(audio_determined)
    if not (math.isfinite(f) and 0.0 < f <= 1.0):
        raise UserError(f"audio_determined: expected 0 < F <= 1, got {audio_determined!r}")
    scales = np.array([s for s, _ in CALIBRATION])
    shares = np.array([v for _, v in CALIBRATION])
    if f > shares[0] and f < 1.0:
        raise UserError(
            f"audio_determined: F = {f:g} cannot be made: the per-sentence audio-motion lag and jitter alone "
            f"leave {1 - shares[0]:.2f} of the speech shapes' variance undetermined (measured share "
            f"{shares[0]:.2f}); use F <= {shares[0]:.2f}, or F = 1 for the corpus without the new components")
    if f < shares[-1]:
        raise UserError(f"audio_determined: F = {f:g} is below what the generator can make "
                        f"({shares[-1]:.2f}); use {shares[-1]:.2f} <= F <= {shares[0]:.2f} or F = 1")
    if f >= 1.0:
        return 0.0
    return float(np.interp(-f, -shares, scales))


# ----------------------------------------------------------------------------- speaker style


def speaker_style(seed: int, speaker: int) -> dict:
    """A speaker's style (JSON-ready), from the ``style`` stream of that speaker.

    Returns
    -------
    dict
        ``targets``: phone class -> ``[jaw, round]`` offsets of the viseme targets;
        ``asymmetry`` (relative, + makes the +x side of the lips move more);
        ``rest``: ``{"jaw", "round", "smile"}`` posture added to every frame.
    """
    rng = component_rng(seed, "style", speaker)
    targets = {}
    for name in VOWELS:
        targets[name] = [float(rng.normal(0.0, STYLE["vowel_jaw_sd"])), float(rng.normal(0.0, STYLE["vowel_round_sd"]))]
    for place in PLACES:
        targets[place] = [float(rng.normal(0.0, STYLE["consonant_jaw_sd"])),
                          float(rng.normal(0.0, STYLE["consonant_round_sd"]))]
    return {
        "targets": targets,
        "asymmetry": float(rng.uniform(-STYLE["asymmetry_max"], STYLE["asymmetry_max"])),
        "rest": {"jaw": float(rng.uniform(0.0, STYLE["rest_jaw_max"])),
                 "round": float(rng.uniform(-STYLE["rest_round_max"], STYLE["rest_round_max"])),
                 "smile": float(rng.uniform(0.0, STYLE["rest_smile_max"]))},
    }


# ----------------------------------------------------------------------------- per-sentence components


def phrases(plan: SentencePlan, min_pause: float = INTENSITY["phrase_pause_s"]) -> list[tuple[float, float]]:
    """``[(start, end), ...]`` seconds of the plan's phrases: speech between pauses of ``min_pause`` or more."""
    out, start = [], None
    for p, a, b in zip(plan.phones, plan.starts, plan.ends):
        if p == SILENCE and b - a >= min_pause:
            if start is not None:
                out.append((start, float(a)))
                start = None
        elif start is None:
            start = float(a)
    if start is not None:
        out.append((start, float(plan.ends[-1])))
    return out


def pauses(plan: SentencePlan, min_pause: float = PAUSES["min_pause_s"]) -> list[tuple[float, float]]:
    """``[(start, end), ...]`` seconds of the plan's silences of ``min_pause`` or more."""
    return [(float(a), float(b)) for p, a, b in zip(plan.phones, plan.starts, plan.ends)
            if p == SILENCE and b - a >= min_pause]


def draw_intensity(rng: np.random.Generator, plan: SentencePlan, num_frames: int, scale: float,
                   fps: int = 60) -> dict:
    """Articulation intensity of one sentence: ``utterance ()``, ``phrases (P,)`` (standard normal
    draws), ``drift (T,)`` (unit-variance smooth noise), each clipped at ``limit_sd``, and the
    resulting ``gain (T,)``."""
    spans = phrases(plan)
    limit = INTENSITY["limit_sd"]  # bounded: a speaker does not triple the articulation now and then
    utterance = float(np.clip(rng.standard_normal(), -limit, limit))
    levels = np.clip(rng.standard_normal(len(spans)), -limit, limit)
    sigma = INTENSITY["drift_sigma_s"] * fps
    pad = int(3 * sigma)
    drift = gaussian_filter1d(rng.standard_normal(num_frames + 2 * pad), sigma, mode="wrap")[pad:pad + num_frames]
    drift = np.clip(drift / (drift.std() + 1e-12), -limit, limit) if num_frames > 1 else np.zeros(num_frames)
    times = np.arange(num_frames) / fps
    step = np.zeros(num_frames)
    for (a, b), level in zip(spans, levels):
        step[(times >= a) & (times < b)] = level
    phrase = gaussian_filter1d(step, INTENSITY["phrase_smoothing_s"] * fps, mode="nearest")
    log_gain = scale * (INTENSITY["utterance_sd"] * utterance + INTENSITY["phrase_sd"] * phrase
                        + INTENSITY["drift_sd"] * drift)
    return {"utterance": utterance, "phrases": levels, "drift": drift, "gain": np.exp(log_gain)}


def draw_onsets(rng: np.random.Generator, plan: SentencePlan, scale: float) -> np.ndarray:
    """Shifts ``(S - 1,)`` seconds of the plan's inner boundaries (gesture onsets) for the articulation."""
    lengths = plan.ends - plan.starts
    z = rng.standard_normal(len(lengths) - 1)
    sd = ONSET["sd_s"] * scale
    shifts = np.clip(z, -ONSET["limit_sd"], ONSET["limit_sd"]) * sd
    # A boundary between segments b and b + 1 never takes more than max_fraction of either.
    frac = ONSET["max_fraction"]
    return np.clip(shifts, -frac * lengths[:-1], frac * lengths[1:])


def jittered_plan(plan: SentencePlan, shifts: np.ndarray) -> SentencePlan:
    """The plan with its inner boundaries moved by ``shifts`` (same phones, same duration)."""
    ends = plan.ends.copy()
    ends[:-1] = ends[:-1] + np.asarray(shifts, dtype=np.float64)
    starts = np.concatenate([[0.0], ends[:-1]])
    return dataclasses.replace(plan, starts=starts, ends=ends)


def draw_pauses(rng: np.random.Generator, plan: SentencePlan, scale: float) -> np.ndarray:
    """Pause gestures ``(N, 4)``: kind index (into ``GESTURE_SIGNALS``), start (s, audio
    timeline), duration (s), amplitude in [0, 1]."""
    rows = []
    probability = min(1.0, PAUSES["probability"] * scale)
    weights = np.asarray(PAUSES["weights"], dtype=np.float64)
    for a, b in pauses(plan):
        # Every pause draws the same numbers, whether or not it gets a gesture.
        u, kind = rng.random(), int(rng.choice(len(weights), p=weights / weights.sum()))
        frac, place, amp = rng.uniform(*PAUSES["duration_fraction"]), rng.random(), rng.uniform(*PAUSES["amplitude"])
        if u >= probability:
            continue
        duration = frac * (b - a)
        rows.append([kind, a + place * (b - a - duration), duration, min(1.0, amp * min(scale, 1.0))])
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


def gesture_signals(gestures: np.ndarray, num_frames: int, lag_frames: int, fps: int = 60) -> dict[str, np.ndarray]:
    """The pause gestures as driving signals ``(T,)`` in [0, 1] on the motion timeline (shifted by the lag):
    a ``sin^2`` bump per gesture; overlapping gestures of one kind take the larger value."""
    out = {name: np.zeros(num_frames) for name in GESTURE_SIGNALS}
    times = np.arange(num_frames) / fps - lag_frames / fps
    for kind, start, duration, amplitude in np.asarray(gestures).reshape(-1, 4):
        phase = (times - start) / max(duration, 1e-9)
        inside = (phase >= 0) & (phase <= 1)
        track = out[GESTURE_SIGNALS[int(kind)]]
        track[inside] = np.maximum(track[inside], amplitude * np.sin(np.pi * phase[inside]) ** 2)
    return out


@dataclass(frozen=True)
class SentenceVariation:
    """The undetermined components of one draw (ground truth or oracle sample) of a sentence.

    Attributes
    ----------
    motion_plan : SentencePlan
        The plan with the articulation's onsets jittered (the audio keeps the plan's).
    offsets : dict
        The speaker's viseme target offsets (``style["targets"]``).
    rest : dict
        The speaker's rest posture.
    gain : (T,) ndarray
        Articulation intensity per frame.
    gestures : (N, 4) ndarray
        Pause gestures (see :func:`draw_pauses`).
    arrays : dict
        Every draw, for the ground-truth record.
    """

    motion_plan: SentencePlan
    offsets: dict
    rest: dict
    gain: np.ndarray
    gestures: np.ndarray
    arrays: dict


def sentence_variation(seed: int, speaker: int, sentence: int, sample: int, plan: SentencePlan,
                       num_frames: int, style: dict, scale: float) -> SentenceVariation:
    """Draw the undetermined components of one sentence draw, each from its own stream."""
    item = (speaker, sentence, sample)
    intensity = draw_intensity(component_rng(seed, "intensity", *item), plan, num_frames, scale)
    shifts = draw_onsets(component_rng(seed, "onset", *item), plan, scale)
    gestures = draw_pauses(component_rng(seed, "pauses", *item), plan, scale)
    motion_plan = jittered_plan(plan, shifts)
    arrays = {
        "intensity_utterance": np.float64(intensity["utterance"]),
        "intensity_phrases": np.asarray(intensity["phrases"], dtype=np.float64),
        "intensity_drift": intensity["drift"],
        "intensity_gain": intensity["gain"],
        "onset_shifts": shifts,
        "motion_phone_starts": motion_plan.starts,
        "motion_phone_ends": motion_plan.ends,
        "pause_gestures": gestures,
    }
    return SentenceVariation(motion_plan=motion_plan, offsets=style["targets"], rest=style["rest"],
                             gain=intensity["gain"], gestures=gestures, arrays=arrays)


def settings(audio_determined: float, scale: float) -> dict:
    """The sidecar's record of the components: what they are, their parameters and their streams."""
    return {
        "declared": float(audio_determined),
        "scale": float(scale),
        "meaning": "the fraction of a speaker's speech-shape coefficient variance that the inputs (audio, speaker "
                   "id) determine: 1 - E[Var(coeffs | audio, speaker)] / E[Var(coeffs | speaker)]",
        "calibration": [list(row) for row in CALIBRATION],
        "streams": f"numpy SeedSequence([seed, {STREAM_KIND}]).spawn({len(COMPONENTS)})[index of the component in "
                   f"{list(COMPONENTS)}], spawn key extended by (speaker) for style and by (speaker, sentence, "
                   f"sample) otherwise; sample 0 is the ground truth, k + 1 oracle sample k",
        "components": {
            "style": {**STYLE, "scaled": False, "classes": list(PHONE_CLASSES)},
            "intensity": {**INTENSITY, "applies_to": ["jaw", "round"],
                          "gain": "exp(scale * (utterance_sd * u + phrase_sd * smoothed phrase level + drift_sd * "
                                  "drift))"},
            "onset": {**ONSET, "sd_at_scale_s": ONSET["sd_s"] * scale},
            "pauses": {**PAUSES, "probability_at_scale": min(1.0, PAUSES["probability"] * scale),
                       "amplitude_factor_at_scale": min(scale, 1.0)},
            "resample": {"what": "oracle samples only: a fresh lag, articulatory jitter, blinks and brows "
                                 "(the old per-sentence draws, same distributions)"},
            "head": {"what": "oracle samples only, with head motion: a fresh head pose track"},
        },
    }
