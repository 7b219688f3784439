"""Generation with the authors' published SAiD weights, as their inference script does it.

The audio is padded with zeros to a whole number of coefficient frames (800
samples per 3 frames at 16 kHz and 60 fps), normalised, encoded once, and
:func:`baselines.said.inference.said_inference` samples all requested tracks in
one batch; the output is cut to the utterance's frame count.  Columns are the
authors' order, which is :data:`blendvoca.names.BLENDVOCA_NAMES`.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import torch

from baselines.said.inference import said_inference
from baselines.said.official import FPS, SAMPLE_RATE, load_official

#: The authors' inference script defaults.
OFFICIAL_SAMPLING = {"sampler": "ddim", "num_steps": 1000, "guidance": 2.0, "guidance_rescale": 0.0, "eta": 0.0}


def fitted_length(num_samples: int, num_frames: int | None = None) -> tuple[int, int]:
    """Return ``(padded samples, model frames)``: audio padded to a multiple of ``16000 / gcd(16000, 60)`` samples,
    long enough for ``num_frames`` frames when given."""
    block = SAMPLE_RATE // math.gcd(SAMPLE_RATE, FPS)
    need = num_samples if num_frames is None else max(num_samples, math.ceil(num_frames * SAMPLE_RATE / FPS))
    padded = math.ceil(need / block) * block
    return padded, padded * FPS // SAMPLE_RATE


class OfficialSAiD:
    """The authors' ``SAID_UNet1D`` with its sampling settings, generating like :class:`baselines.said.pipeline.SAiD`.

    Parameters
    ----------
    model : SAID_UNet1D
    sampling : dict, optional
        Overrides of :data:`OFFICIAL_SAMPLING`.
    """

    def __init__(self, model, sampling: dict | None = None):
        from blendvoca.names import BLENDVOCA_NAMES

        self.model = model.eval()
        self.names = tuple(BLENDVOCA_NAMES)
        self.sampling = {**OFFICIAL_SAMPLING, **(sampling or {})}
        self.device = torch.device("cpu")
        self.config = {"preset": "official", "sampling": dict(self.sampling)}

    @classmethod
    def load(cls, path: str | os.PathLike, **sampling) -> OfficialSAiD:
        """Load ``SAiD.pth`` strictly (:func:`baselines.said.official.load_official`)."""
        return cls(load_official(Path(path)), sampling)

    def to(self, device) -> OfficialSAiD:
        self.device = torch.device(device)
        self.model.to(self.device)
        return self

    @torch.no_grad()
    def generate(self, audio, num_frames=None, *, samples=1, seed=0, reference=None, mask=None, sampler=None,
                 num_steps=None, guidance=None, eta=None, guidance_rescale=None, strength=1.0,
                 save_intermediates=False, progress=False, return_intermediates=False):
        """Return ``(S, T, 32)`` tracks in [0, 1] (float64) for mono 16 kHz ``audio (N,)``.

        ``reference``/``mask`` ``(T, 32)``: edit (the authors' ``init_samples``/``mask``,
        with ``strength``).  With ``return_intermediates`` also the list of the chain's
        states, each ``(S, T, 32)``.
        """
        audio = np.asarray(audio, dtype=np.float32)
        if audio.ndim != 1 or audio.size == 0:
            raise ValueError(f"OfficialSAiD.generate: expected (N,) mono audio at 16 kHz, got shape {audio.shape}")
        s = self.sampling
        if reference is not None:
            num_frames = int(np.asarray(reference).shape[0]) if num_frames is None else num_frames
        out_frames = int(audio.shape[0] * FPS / SAMPLE_RATE) if num_frames is None else int(num_frames)
        padded, frames = fitted_length(audio.shape[0], out_frames)
        wav = torch.zeros(1, padded)
        wav[0, : audio.shape[0]] = torch.from_numpy(audio)
        wav = wav.to(self.device)
        gen = torch.Generator(device=self.device).manual_seed(int(seed))
        init = edit_mask = None
        if reference is not None:
            init = torch.zeros(samples, frames, len(self.names), device=self.device)
            init[:, :out_frames] = torch.as_tensor(np.asarray(reference, dtype=np.float32), device=self.device)
            if mask is not None:
                edit_mask = torch.zeros_like(init)
                edit_mask[:, :out_frames] = torch.as_tensor(np.asarray(mask, dtype=np.float32), device=self.device)
        embedding = self.model.get_audio_embedding(self.model.process_audio(wav), frames)
        out = said_inference(
            self.model, embedding, batch=int(samples),
            num_steps=int(num_steps or s["num_steps"]), sampler=sampler or s["sampler"],
            guidance=s["guidance"] if guidance is None else float(guidance),
            guidance_rescale=s["guidance_rescale"] if guidance_rescale is None else float(guidance_rescale),
            eta=s["eta"] if eta is None else float(eta), strength=float(strength),
            init_samples=init, mask=edit_mask, generator=gen,
            save_intermediates=save_intermediates or return_intermediates, progress=progress,
        )
        tracks = out.result[:, :out_frames].double().cpu().numpy()
        if return_intermediates:
            return tracks, [x[:, :out_frames].double().cpu().numpy() for x in out.intermediates]
        return tracks
