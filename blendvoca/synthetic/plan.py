"""Sentence plans: the timed phone sequence that both the audio and the motion follow.

A plan is the single source of truth for one synthetic sentence: silence, then
words of one to three syllables (optional onset consonant, vowel nucleus,
optional coda), short word gaps and at most one phrase pause, then silence.
The speech audio is synthesised from it and the facial motion is driven by it,
which is what makes lip sync real and measurable on the synthetic corpus.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blendvoca.synthetic.phonetics import CONSONANT_WEIGHTS, CONSONANTS, VOWEL_WEIGHTS, VOWELS

SILENCE = "_"


@dataclass(frozen=True)
class SentencePlan:
    """Timed phone segments of one sentence.

    Attributes
    ----------
    phones : tuple of str, length S
        Phone names (keys of ``VOWELS`` / ``CONSONANTS``) or ``"_"`` for silence.
    starts, ends : (S,) float64
        Segment boundaries in seconds; contiguous, ``starts[0] == 0``,
        ``ends[-1] == duration``.
    syllables : (S,) int64
        Syllable index of each segment, -1 for silence.
    stress : (S,) float64
        Stress weight of the segment's syllable (1.0 unstressed .. 1.4 stressed),
        0 for silence.
    duration : float
        Sentence length in seconds.
    """

    phones: tuple[str, ...]
    starts: np.ndarray
    ends: np.ndarray
    syllables: np.ndarray
    stress: np.ndarray
    duration: float

    def is_vowel(self) -> np.ndarray:
        """``(S,) bool``: which segments are vowel nuclei."""
        return np.array([p in VOWELS for p in self.phones], dtype=bool)

    @property
    def num_syllables(self) -> int:
        return int(self.syllables.max()) + 1 if len(self.syllables) else 0


def _choice(rng: np.random.Generator, weights: dict[str, float]) -> str:
    names = list(weights)
    p = np.array([weights[n] for n in names], dtype=np.float64)
    return names[int(rng.choice(len(names), p=p / p.sum()))]


def sentence_plan(
    rng: np.random.Generator,
    duration: float,
    *,
    speaking_rate: float = 1.0,
    lead_silence: tuple[float, float] = (0.25, 0.45),
    tail_silence: tuple[float, float] = (0.25, 0.45),
) -> SentencePlan:
    """Random timed phone sequence of exactly ``duration`` seconds.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of all randomness (the plan is a pure function of its state).
    duration : float
        Sentence length in seconds; must leave at least 0.4 s of speech after the
        leading and trailing silences.
    speaking_rate : float
        Speaker tempo factor (1.0 is about 4.5 syllables per second).
    lead_silence, tail_silence : (low, high)
        Ranges of the silent margins in seconds (scaled down for sentences
        shorter than 3 s).

    Returns
    -------
    SentencePlan
    """
    if not np.isfinite(duration) or duration <= 0:
        raise ValueError(f"sentence_plan: duration must be a positive number of seconds, got {duration!r}")
    if not 0.3 <= speaking_rate <= 3.0:
        raise ValueError(f"sentence_plan: speaking_rate must be in [0.3, 3], got {speaking_rate!r}")
    # Short (test-size) sentences get proportionally shorter margins.
    margin_scale = min(1.0, duration / 3.0)
    lead = rng.uniform(*lead_silence) * margin_scale
    tail = rng.uniform(*tail_silence) * margin_scale
    span = duration - lead - tail
    if span < 0.4:
        raise ValueError(
            f"sentence_plan: duration {duration:.3f} s leaves {span:.3f} s of speech after the "
            f"silent margins; expected at least 0.4 s"
        )
    phones: list[str] = []
    lengths: list[float] = []
    syllables: list[int] = []
    stress: list[float] = []
    phrase_pause_used = False
    t, syllable = 0.0, 0
    while t < span:
        n_syll = int(rng.choice([1, 2, 3], p=[0.45, 0.38, 0.17]))
        stressed = int(rng.integers(n_syll))
        for k in range(n_syll):
            s = 1.4 if k == stressed else 1.0
            jitter = lambda: float(rng.uniform(0.8, 1.2)) / speaking_rate  # noqa: E731
            if rng.random() < 0.75:
                c = _choice(rng, CONSONANT_WEIGHTS)
                phones.append(c); lengths.append(CONSONANTS[c]["duration"] * jitter())
                syllables.append(syllable); stress.append(s)
            v = _choice(rng, VOWEL_WEIGHTS)
            phones.append(v); lengths.append(rng.uniform(0.09, 0.15) * (1.25 if s > 1 else 1.0) / speaking_rate)
            syllables.append(syllable); stress.append(s)
            if rng.random() < 0.22:
                c = _choice(rng, CONSONANT_WEIGHTS)
                phones.append(c); lengths.append(CONSONANTS[c]["duration"] * jitter())
                syllables.append(syllable); stress.append(s)
            syllable += 1
        t = float(np.sum(lengths))
        if t >= span:
            break
        # Word boundary: mostly no gap, sometimes a short pause, once a phrase pause.
        u = rng.random()
        if not phrase_pause_used and span > 2.5 and t > 0.35 * span and u < 0.35:
            gap = rng.uniform(0.18, 0.32)
            phrase_pause_used = True
        elif u < 0.5:
            gap = rng.uniform(0.05, 0.12)
        else:
            gap = 0.0
        if gap > 0:
            phones.append(SILENCE); lengths.append(gap); syllables.append(-1); stress.append(0.0)
        t = float(np.sum(lengths))
    if phones[-1] == SILENCE:  # never end speech on a pause: the tail silence follows
        phones.pop(); lengths.pop(); syllables.pop(); stress.pop()
    # Stretch the speech uniformly so it fills the span exactly (factor close to 1).
    lengths_arr = np.asarray(lengths, dtype=np.float64) * (span / float(np.sum(lengths)))
    all_lengths = np.concatenate([[lead], lengths_arr, [tail]])
    ends = np.cumsum(all_lengths)
    ends[-1] = duration
    starts = np.concatenate([[0.0], ends[:-1]])
    return SentencePlan(phones=(SILENCE, *phones, SILENCE), starts=starts, ends=ends,
                        syllables=np.array([-1, *syllables, -1], dtype=np.int64),
                        stress=np.array([0.0, *stress, 0.0], dtype=np.float64), duration=float(duration))
