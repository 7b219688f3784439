"""Synthetic speaker identities: smooth, plausible shape variations of a FLAME template.

An identity is the template under (1) an anisotropic scaling about its centroid
(head width / height / depth, a few percent) and (2) a smooth spatial
displacement field made of mirrored pairs of Gaussian radial basis bumps with
centimetre widths and millimetre-to-centimetre amplitudes (fuller cheeks, a
longer chin, a wider nose...). The field is a function of space, not of the
surface normal, so small rigid parts such as the eyeballs move almost rigidly
with the face around them and nothing is noisy.
"""

from __future__ import annotations

import numpy as np


def identity_displacement(vertices: np.ndarray, rng: np.random.Generator, *, num_bumps: int = 6,
                          amplitude: float = 0.004, width: tuple[float, float] = (0.025, 0.055), scale: float = 0.05,
                          asymmetry: float = 0.15) -> np.ndarray:
    """Displacement field ``(V, 3) float64`` that turns ``vertices`` into a new identity.

    Parameters
    ----------
    vertices : (V, 3) ndarray
        Template vertices in metres, face looking along +z, x the left-right axis
        (FLAME's frame; the mirror plane is x = centroid x).
    rng : numpy.random.Generator
    num_bumps : int
        Number of mirrored bump pairs.
    amplitude : float
        Standard deviation (m) of each bump's displacement vector.
    width : (low, high)
        Range of the bump widths (Gaussian sigma, metres).
    scale : float
        Largest relative change of each head dimension (uniform in +-scale).
    asymmetry : float
        Relative difference allowed between the two bumps of a mirrored pair.

    Returns
    -------
    (V, 3) ndarray
        Add to ``vertices`` to get the new speaker's neutral face.
    """
    V = np.asarray(vertices, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        raise ValueError(f"identity_displacement: vertices must be (V, 3) with V > 0, got shape {V.shape}")
    center = V.mean(axis=0)
    factors = 1.0 + rng.uniform(-scale, scale, size=3)
    displacement = (V - center) * (factors - 1.0)
    mirror = np.array([-1.0, 1.0, 1.0])
    for _ in range(num_bumps):
        c = V[rng.integers(len(V))]
        a = rng.normal(0.0, amplitude, size=3)
        s = rng.uniform(*width)
        c_m = (c - center) * mirror + center
        for cc, aa in ((c, a), (c_m, a * mirror * (1.0 + rng.uniform(-asymmetry, asymmetry)))):
            w = np.exp(-np.sum((V - cc) ** 2, axis=1) / (2.0 * s * s))
            displacement += w[:, None] * aa
    return displacement


def speaker_neutral(template: np.ndarray, rng: np.random.Generator, **kwargs) -> np.ndarray:
    """A new speaker's neutral face, ``(V, 3) float64``: template plus ``identity_displacement``."""
    V = np.asarray(template, dtype=np.float64)
    return V + identity_displacement(V, rng, **kwargs)


def speaker_profile(rng: np.random.Generator) -> dict[str, float]:
    """Voice and speaking-style parameters of one synthetic speaker.

    Returns
    -------
    dict
        ``f0`` (Hz), ``formant_scale``, ``speaking_rate``, ``jaw_gain``,
        ``round_gain``, ``brow_gain``, ``blink_rate`` (blinks per second).
    """
    female = bool(rng.random() < 0.5)
    return {
        "f0": float(rng.uniform(175.0, 230.0) if female else rng.uniform(95.0, 140.0)),
        "formant_scale": float(rng.uniform(1.12, 1.20) if female else rng.uniform(0.97, 1.05)),
        "speaking_rate": float(rng.uniform(0.85, 1.15)),
        "jaw_gain": float(rng.uniform(0.75, 1.25)),
        "round_gain": float(rng.uniform(0.7, 1.3)),
        "brow_gain": float(rng.uniform(0.3, 1.2)),
        "blink_rate": float(rng.uniform(0.15, 0.45)),
    }
