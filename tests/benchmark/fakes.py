"""Fabricated BlendVOCA data on disk for the benchmark tests: a rig on the FLAME
sample head with localized smooth blendshapes, smooth random tracks, and speech-like
audio whose loudness follows the mouth opening, written as a BlendVOCA folder
(:func:`make_dataset`) for the tests that read one through ``open_blendvoca``, the
renderer or the region metrics (FLAME topology). Tests that need a dataset object
in memory use ``benchmark.testing.FakeBlendVOCA``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blendvoca.names import BLENDVOCA_NAMES

RATE = 16000
FPS = 60


def flame_head(assets_dir: Path):
    from blendvoca.io.mesh import read_mesh

    v, f = read_mesh(assets_dir / "voca" / "FLAME_sample.ply")
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64)


def fake_rig(neutral, faces, seed: int = 0):
    """A 32-shape rig: mouth shapes move a bump around the mouth, cheek and nose
    shapes bumps on the cheeks and nose; jawOpen moves the chin down."""
    from blendvoca.rig import Rig

    rng = np.random.default_rng(seed)
    tip = neutral[np.argmax(neutral[:, 2])]
    mouth = tip + np.array([0.0, -0.04, -0.015])
    spots = {"cheek": tip + np.array([0.04, -0.02, -0.03]), "nose": tip + np.array([0.0, 0.0, -0.01])}
    deltas = np.zeros((len(BLENDVOCA_NAMES), *neutral.shape))
    for k, name in enumerate(BLENDVOCA_NAMES):
        centre = spots["cheek"] if name.startswith("cheek") else spots["nose"] if name.startswith("nose") else mouth
        if name.endswith("Right"):
            centre = centre * np.array([-1, 1, 1])
        sigma = 0.03 if name == "jawOpen" else 0.012
        w = np.exp(-((neutral - centre) ** 2).sum(axis=1) / (2 * sigma**2))
        direction = np.array([0.0, -1.0, 0.2]) if name == "jawOpen" else rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        deltas[k] = (0.012 if name == "jawOpen" else 0.004) * w[:, None] * direction
    return Rig(neutral, deltas, tuple(BLENDVOCA_NAMES), faces)


def smooth_track(num_frames: int, rng, channels: int = len(BLENDVOCA_NAMES), width: float = 4.0) -> np.ndarray:
    """Smooth random coefficients in [0, 1], (T, C)."""
    from scipy.ndimage import gaussian_filter1d

    x = gaussian_filter1d(rng.normal(size=(num_frames + 40, channels)), width, axis=0)[20:-20]
    x = (x - x.min(axis=0)) / (np.ptp(x, axis=0) + 1e-12)
    return x * rng.uniform(0.2, 0.9, size=channels)


def speech_for(opening: np.ndarray, rng, fps: float = FPS, rate: int = RATE) -> np.ndarray:
    """Noise carrier whose amplitude follows ``opening`` (T,) at ``fps``, (N,) float32."""
    n = int(len(opening) / fps * rate)
    t = np.arange(n) / rate
    amp = np.interp(t, np.arange(len(opening)) / fps, opening)
    carrier = rng.normal(size=n) * 0.5 + np.sin(2 * np.pi * 140 * t)
    x = amp * carrier
    return (0.5 * x / np.abs(x).max()).astype(np.float32)


def make_dataset(root: Path, assets_dir: Path, subjects=("FakeA", "FakeB", "FakeC"), sentences: int = 3,
                 frames: tuple[int, int] = (150, 200), seed: int = 0, samples: int = 0) -> Path:
    """Write a tiny BlendVOCA folder through ``blendvoca.format``: rigs/, blendshape_coeffs/
    (with ``samples`` extra noisy samples per sentence), audio/, splits.json, manifest.json.

    Split: the first subject is train, the second val, the others test.
    """
    from blendvoca import format as fmt

    rng = np.random.default_rng(seed)
    neutral, faces = flame_head(assets_dir)
    jaw = BLENDVOCA_NAMES.index("jawOpen")
    for i, subject in enumerate(subjects):
        fmt.write_rig(root, subject, fake_rig(neutral + rng.normal(scale=1e-4, size=neutral.shape), faces, seed=i))
        for j in range(1, sentences + 1):
            sentence = f"sentence{j:02d}"
            track = smooth_track(int(rng.integers(*frames)), rng)
            fmt.write_coeffs(root, subject, sentence, track, BLENDVOCA_NAMES)
            for k in range(samples):
                noisy = np.clip(track + rng.normal(scale=0.05, size=track.shape), 0, 1)
                fmt.write_coeffs(root, subject, sentence, noisy, BLENDVOCA_NAMES, sample=k)
            fmt.write_audio(root, subject, sentence, speech_for(track[:, jaw], rng), RATE)
    fmt.write_splits(root, {"train": [subjects[0]], "val": [subjects[1]], "test": list(subjects[2:])})
    fmt.write_folder_manifest(root)  # what open_blendvoca reads: every file listed with its sha256
    return root
