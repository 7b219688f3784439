"""Example BlendVOCA method: speech energy drives jawOpen (see docs/methods.md)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchmark.methods import AUDIO_RATE as RATE
from benchmark.methods import FPS, Method

__all__ = ["EnergyJawMethod", "energy_envelope"]


def energy_envelope(audio, num_frames: int, *, rate: int = RATE, fps: int = FPS) -> np.ndarray:
    """RMS of the audio in windows centred on each 60 fps frame, scaled to [0, 1].

    Parameters
    ----------
    audio : (N,) ndarray
        Mono samples at ``rate``.
    num_frames : int
        Frames ``T`` at ``fps``.

    Returns
    -------
    (T,) float64 ndarray
        Divided by its maximum (zeros for silence).
    """
    audio = np.asarray(audio, dtype=np.float64)
    hop = rate / fps
    centres = (np.arange(num_frames) * hop).astype(int)
    half = int(hop)
    power = np.concatenate([[0.0], np.cumsum(audio ** 2)])
    lo = np.clip(centres - half, 0, audio.size)
    hi = np.clip(centres + half, 0, audio.size)
    rms = np.sqrt((power[hi] - power[lo]) / np.maximum(hi - lo, 1))
    peak = rms.max() if rms.size else 0.0
    return rms / peak if peak > 0 else rms


class EnergyJawMethod(Method):
    """jawOpen = gain * energy envelope (+ smooth noise per sample); others at the train mean.

    Parameters
    ----------
    noise : float
        Standard deviation of the per-sample noise on jawOpen.
    """

    name = "example-energy"
    stochastic = True

    def __init__(self, noise: float = 0.02):
        super().__init__(noise=noise)
        self.gain = None
        self.mean = None

    contract = 3  # train(dataset, request): method contract v3

    def train(self, dataset, request):
        """Least squares of jawOpen on the energy envelope, one training sentence a step.

        A step budget (``request.budget.max_steps``) stops it after that many sentences.
        After each step of ``request.checkpoint_steps(N)`` of its ``N`` steps (halfway, unless
        the runner asks for other fractions) it calls ``request.on_checkpoint(step,
        total_steps=N)`` with the fit so far in place, for the runner's check
        (docs/methods.md, "Settled or not"); a time-limited run has no known fractions and
        makes no call. ``request.device`` is unused: the fit is numpy on the CPU.
        """
        self.jaw = list(dataset.names).index("jawOpen")
        sentences = [(s, q) for s in dataset.split("train") for q in dataset.sentences(s)]
        total = min(len(sentences), request.budget.steps(len(sentences)))
        checkpoints = request.checkpoint_steps(total)
        xy = xx = 0.0
        coeff_sum, frames = 0.0, 0
        for step, (subject, sentence) in enumerate(sentences[:total], start=1):
            coeffs = np.asarray(dataset.coeffs(subject, sentence))
            audio, _ = dataset.audio(subject, sentence)
            x = energy_envelope(audio, coeffs.shape[0])
            xy, xx = xy + float(x @ coeffs[:, self.jaw]), xx + float(x @ x)
            coeff_sum, frames = coeff_sum + coeffs.sum(axis=0), frames + coeffs.shape[0]
            self.gain = xy / max(xx, 1e-12)  # least squares through the origin, over the sentences so far
            self.mean = coeff_sum / frames
            if step in checkpoints:
                request.on_checkpoint(step, total_steps=total)

    def generate(self, utterance, *, samples=1, seed=0):
        rng = np.random.default_rng(seed)
        num_frames = utterance.num_frames
        out = np.repeat(np.tile(self.mean, (num_frames, 1))[None], samples, axis=0)
        env = energy_envelope(utterance.audio, num_frames)
        noise = rng.normal(0, self.config()["noise"], size=(samples, num_frames + 8))
        noise = np.stack([np.convolve(n, np.ones(9) / 9, mode="valid") for n in noise])
        out[:, :, self.jaw] = self.gain * env[None] + noise
        return np.clip(out, 0.0, 1.0)

    def save(self, directory):
        super().save(directory)
        state = {"gain": self.gain, "mean": self.mean.tolist(), "jaw": self.jaw}
        (Path(directory) / "energy.json").write_text(json.dumps(state))

    @classmethod
    def load(cls, directory):
        method = super().load(directory)
        state = json.loads((Path(directory) / "energy.json").read_text())
        method.gain, method.mean, method.jaw = state["gain"], np.asarray(state["mean"]), state["jaw"]
        return method
