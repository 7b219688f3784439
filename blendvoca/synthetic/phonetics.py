"""Phone inventory of the synthetic speech: acoustic and articulatory targets.

A deliberately small inventory (six vowels, eleven consonant classes) that is
enough for syllable structure, formant movement, bilabial closures and
fricative noise. Formants are adult-male averages (Peterson & Barney style
values, Hz) and are scaled per speaker by a vocal-tract-length factor.
Articulatory targets are in normalised units that the motion model turns into
millimetres: ``jaw`` in [0, 1] (1 = widest open vowel), ``round`` in [-1, 1]
(+1 rounded and protruded, -1 spread).
"""

from __future__ import annotations

# name: (F1, F2, F3, jaw, round, loudness)
VOWELS: dict[str, tuple[float, float, float, float, float, float]] = {
    "a": (730.0, 1090.0, 2440.0, 1.00, 0.0, 1.00),
    "e": (530.0, 1840.0, 2480.0, 0.60, -0.5, 0.85),
    "i": (270.0, 2290.0, 3010.0, 0.22, -1.0, 0.70),
    "o": (570.0, 840.0, 2410.0, 0.62, 0.8, 0.90),
    "u": (300.0, 870.0, 2240.0, 0.25, 1.0, 0.70),
    "@": (500.0, 1500.0, 2500.0, 0.40, 0.0, 0.75),
}

# name: dict of
#   place: "bilabial" | "labiodental" | "alveolar" | "postalveolar" | "velar" | "labiovelar"
#   manner: "stop" | "nasal" | "fricative" | "approximant"
#   voiced: bool
#   noise: (low Hz, high Hz, relative level) of the frication / burst noise, or None
#   duration: seconds (typical)
#   jaw: jaw target during the consonant (0 = closed)
#   round: lip rounding target during the consonant
CONSONANTS: dict[str, dict] = {
    "p": dict(place="bilabial", manner="stop", voiced=False, noise=(500.0, 4000.0, 0.35), duration=0.085, jaw=0.05, round=0.0),
    "b": dict(place="bilabial", manner="stop", voiced=True, noise=(300.0, 3000.0, 0.15), duration=0.070, jaw=0.05, round=0.0),
    "m": dict(place="bilabial", manner="nasal", voiced=True, noise=None, duration=0.080, jaw=0.05, round=0.0),
    "f": dict(place="labiodental", manner="fricative", voiced=False, noise=(1500.0, 7500.0, 0.18), duration=0.100, jaw=0.10, round=-0.2),
    "v": dict(place="labiodental", manner="fricative", voiced=True, noise=(1500.0, 7000.0, 0.08), duration=0.080, jaw=0.10, round=-0.2),
    "t": dict(place="alveolar", manner="stop", voiced=False, noise=(2500.0, 8000.0, 0.35), duration=0.075, jaw=0.15, round=0.0),
    "d": dict(place="alveolar", manner="stop", voiced=True, noise=(2000.0, 6000.0, 0.15), duration=0.065, jaw=0.15, round=0.0),
    "s": dict(place="alveolar", manner="fricative", voiced=False, noise=(4000.0, 9500.0, 0.30), duration=0.115, jaw=0.08, round=-0.4),
    "n": dict(place="alveolar", manner="nasal", voiced=True, noise=None, duration=0.070, jaw=0.18, round=0.0),
    "l": dict(place="alveolar", manner="approximant", voiced=True, noise=None, duration=0.065, jaw=0.25, round=0.0),
    "S": dict(place="postalveolar", manner="fricative", voiced=False, noise=(2000.0, 6000.0, 0.30), duration=0.115, jaw=0.10, round=0.6),
    "k": dict(place="velar", manner="stop", voiced=False, noise=(1200.0, 4500.0, 0.30), duration=0.080, jaw=0.25, round=0.0),
    "g": dict(place="velar", manner="stop", voiced=True, noise=(1000.0, 4000.0, 0.12), duration=0.065, jaw=0.25, round=0.0),
    "w": dict(place="labiovelar", manner="approximant", voiced=True, noise=None, duration=0.070, jaw=0.15, round=1.0),
}

# Relative frequencies (roughly English-like: alveolars common, /S/ and /g/ rare).
CONSONANT_WEIGHTS: dict[str, float] = {
    "p": 0.06, "b": 0.06, "m": 0.08, "f": 0.05, "v": 0.04, "t": 0.12, "d": 0.08,
    "s": 0.10, "n": 0.12, "l": 0.08, "S": 0.03, "k": 0.07, "g": 0.03, "w": 0.05,
}
VOWEL_WEIGHTS: dict[str, float] = {"a": 0.20, "e": 0.18, "i": 0.18, "o": 0.14, "u": 0.10, "@": 0.20}

# Nasal murmur: a low resonance with weak higher formants (Hz).
NASAL_FORMANTS = (250.0, 1200.0, 2300.0)
