"""Control tracks: a sentence plan turned into smooth signals on a regular time grid.

Every track is evaluated on the same control grid (1 kHz by default): the
piecewise-constant phone targets of the plan, shaped within each segment and
smoothed with a Gaussian kernel (zero-phase, so smoothing never shifts a track
in time, which keeps the true audio-motion lag exactly the one that is applied).
The audio synthesiser samples the acoustic tracks; the motion model samples the
articulatory tracks at 60 fps.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from blendvoca.synthetic.phonetics import CONSONANTS, NASAL_FORMANTS, VOWELS
from blendvoca.synthetic.plan import SentencePlan

CONTROL_RATE = 1000  # Hz


def control_times(duration: float, control_rate: int = CONTROL_RATE) -> np.ndarray:
    """``(C,) float64`` sample times (s) of the control grid covering ``[0, duration]``."""
    return np.arange(int(np.ceil(duration * control_rate)) + 1, dtype=np.float64) / control_rate


def segment_index(plan: SentencePlan, times: np.ndarray) -> np.ndarray:
    """``(N,) int64``: the plan segment that contains each time (clamped to the ends)."""
    idx = np.searchsorted(plan.ends, times, side="right")
    return np.clip(idx, 0, len(plan.phones) - 1)


def _control_grid(plan: SentencePlan, control_rate: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(times, segment, position)``: the control grid, each time's plan segment and its position in it (0 to 1)."""
    grid = control_times(plan.duration, control_rate)
    seg = segment_index(plan, grid)
    length = np.maximum(plan.ends[seg] - plan.starts[seg], 1e-9)
    return grid, seg, np.clip((grid - plan.starts[seg]) / length, 0.0, 1.0)


def _next_vowel(plan: SentencePlan) -> list[str]:
    """For each segment, the vowel of its syllable (or the nearest following vowel)."""
    out, following = [None] * len(plan.phones), "@"
    for i in range(len(plan.phones) - 1, -1, -1):
        if plan.phones[i] in VOWELS:
            following = plan.phones[i]
        out[i] = following
    # A coda takes its own syllable's vowel, which precedes it.
    for i, p in enumerate(plan.phones):
        if p in CONSONANTS and i > 0 and plan.phones[i - 1] in VOWELS and plan.syllables[i - 1] == plan.syllables[i]:
            out[i] = plan.phones[i - 1]
    return out


def amplitude_track(plan: SentencePlan, times: np.ndarray, *, smoothing: float = 0.008,
                    control_rate: int = CONTROL_RATE) -> np.ndarray:
    """Voicing amplitude (the syllable envelope), ``(N,) float64`` >= 0.

    Vowels carry ``loudness * stress`` with a rise-and-fall shape inside the
    nucleus (so every syllable has one clear peak); voiced consonants carry a
    weaker murmur; silence and voiceless consonants carry none.

    Parameters
    ----------
    plan : SentencePlan
    times : (N,) ndarray
        Times in seconds at which to evaluate the track.
    smoothing : float
        Gaussian smoothing (seconds) of the onsets and offsets.
    """
    grid, seg, tau = _control_grid(plan, control_rate)
    target = np.zeros(len(grid))
    for i, p in enumerate(plan.phones):
        mask = seg == i
        if p in VOWELS:
            target[mask] = VOWELS[p][5] * plan.stress[i] * (0.55 + 0.45 * np.sin(np.pi * tau[mask]))
        elif p in CONSONANTS:
            c = CONSONANTS[p]
            if c["voiced"]:
                level = {"nasal": 0.30, "approximant": 0.45, "stop": 0.10, "fricative": 0.18}[c["manner"]]
                target[mask] = level * plan.stress[i]
    track = gaussian_filter1d(target, smoothing * control_rate, mode="nearest")
    return np.interp(times, grid, track)


def noise_track(plan: SentencePlan, times: np.ndarray, *, smoothing: float = 0.004,
                control_rate: int = CONTROL_RATE) -> np.ndarray:
    """Frication / burst amplitude, ``(N,) float64`` >= 0.

    Fricatives are noisy over their whole segment (peaking in the middle); stops
    release a burst in their last 30 ms.
    """
    grid, seg, tau = _control_grid(plan, control_rate)
    target = np.zeros(len(grid))
    for i, p in enumerate(plan.phones):
        c = CONSONANTS.get(p)
        if c is None or c["noise"] is None:
            continue
        mask = seg == i
        level = c["noise"][2]
        if c["manner"] == "fricative":
            target[mask] = level * np.sin(np.pi * tau[mask]) ** 0.5
        else:
            remaining = plan.ends[i] - grid[mask]
            target[mask] = level * np.exp(-np.clip(0.03 - remaining, 0, None) / 0.012) * (remaining < 0.03)
    track = gaussian_filter1d(target, smoothing * control_rate, mode="nearest")
    return np.interp(times, grid, track)


def formant_track(plan: SentencePlan, times: np.ndarray, *, scale: float = 1.0, smoothing: float = 0.020,
                  control_rate: int = CONTROL_RATE) -> np.ndarray:
    """Formant frequencies F1..F3 in Hz, ``(N, 3) float64``.

    Vowels take their targets; consonants take the formants of their syllable's
    vowel pulled towards their place of articulation (bilabials lower F2,
    alveolars raise it towards 1.8 kHz, nasals use a nasal murmur); the
    Gaussian smoothing produces the formant transitions. ``scale`` is the
    speaker's vocal-tract-length factor (1.0 adult male, ~1.18 adult female).
    """
    grid, seg, _ = _control_grid(plan, control_rate)
    nearest_vowel = _next_vowel(plan)
    targets = np.zeros((len(plan.phones), 3))
    for i, p in enumerate(plan.phones):
        f = np.array(VOWELS[nearest_vowel[i]][:3])
        if p in CONSONANTS:
            c = CONSONANTS[p]
            if c["manner"] == "nasal":
                f = np.array(NASAL_FORMANTS)
            elif c["place"] in ("bilabial", "labiodental", "labiovelar"):
                f = f * np.array([0.7, 0.8, 0.95])
            elif c["place"] in ("alveolar", "postalveolar"):
                f = np.array([0.8 * f[0], 0.5 * f[1] + 900.0, f[2]])
        targets[i] = f
    track = gaussian_filter1d(targets[seg], smoothing * control_rate, axis=0, mode="nearest") * scale
    return np.stack([np.interp(times, grid, track[:, k]) for k in range(3)], axis=1)


def articulation_tracks(plan: SentencePlan, times: np.ndarray, *, smoothing: float = 0.030,
                        control_rate: int = CONTROL_RATE, offsets: dict | None = None) -> dict[str, np.ndarray]:
    """Articulatory targets of the plan, each ``(N,) float64``, on the audio timeline.

    Parameters
    ----------
    plan : SentencePlan
    times : (N,) ndarray
        Seconds.
    smoothing : float
        Gaussian smoothing of the targets (seconds).
    control_rate : int
    offsets : dict, optional
        A speaker's own viseme targets (``blendvoca.synthetic.variation``): phone
        class -> ``(jaw, round)`` added to the inventory's targets; classes are the
        vowels (``"a"``, ``"e"``, ...) and the consonants' places
        (``"bilabial"``, ...). None: the inventory's targets exactly.

    Returns
    -------
    dict
        ``jaw`` in [0, 1] (opening, vowel openness times stress, closed for
        consonants and silence), ``round`` in [-1, 1] (protrusion vs spreading),
        ``closure`` in [0, 1] (bilabial lip closure), ``labiodental`` in [0, 1]
        (lower lip raised to the upper teeth), ``envelope`` (the syllable
        envelope: ``amplitude_track`` smoothed like the articulators).
    """
    grid, seg, tau = _control_grid(plan, control_rate)
    jaw = np.zeros(len(grid))
    rnd = np.zeros(len(grid))
    closure = np.zeros(len(grid))
    labiodental = np.zeros(len(grid))
    nearest_vowel = _next_vowel(plan)
    for i, p in enumerate(plan.phones):
        mask = seg == i
        if p in VOWELS:
            _, _, _, openness, rounding, _ = VOWELS[p]
            if offsets is not None:
                openness, rounding = openness + offsets[p][0], rounding + offsets[p][1]
            jaw[mask] = openness * min(plan.stress[i], 1.3) * (0.7 + 0.3 * np.sin(np.pi * tau[mask]))
            rnd[mask] = rounding
        elif p in CONSONANTS:
            c = CONSONANTS[p]
            if offsets is None:
                jaw[mask] = c["jaw"]
                # Lips anticipate the syllable's vowel unless the consonant sets them itself.
                rnd[mask] = c["round"] if c["round"] != 0.0 else 0.6 * VOWELS[nearest_vowel[i]][4]
            else:
                d_jaw, d_round = offsets[c["place"]]
                vowel = nearest_vowel[i]
                jaw[mask] = max(c["jaw"] + d_jaw, 0.0)
                rnd[mask] = d_round + (c["round"] if c["round"] != 0.0
                                       else 0.6 * (VOWELS[vowel][4] + offsets[vowel][1]))
            if c["place"] == "bilabial":
                closure[mask] = 1.0
            elif c["place"] == "labiodental":
                labiodental[mask] = 1.0
        # silence: everything at rest (zeros)
    sigma = smoothing * control_rate
    out = {
        "jaw": gaussian_filter1d(jaw, sigma, mode="nearest"),
        "round": gaussian_filter1d(rnd, sigma, mode="nearest"),
        # Closures are faster gestures than jaw opening.
        "closure": np.clip(gaussian_filter1d(closure, 0.5 * sigma, mode="nearest") * 1.6, 0.0, 1.0),
        "labiodental": np.clip(gaussian_filter1d(labiodental, 0.5 * sigma, mode="nearest") * 1.4, 0.0, 1.0),
    }
    amp = amplitude_track(plan, grid, control_rate=control_rate)
    out["envelope"] = gaussian_filter1d(amp, sigma, mode="nearest")
    return {k: np.interp(times, grid, v) for k, v in out.items()}
