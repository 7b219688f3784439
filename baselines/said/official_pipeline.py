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
from baselines.said.sample import padded_batch, utterance_noise
from blendvoca.errors import DataError
from blendvoca.names import BLENDVOCA_NAMES

#: The authors' inference script defaults.
OFFICIAL_SAMPLING = {"sampler": "ddim", "num_steps": 1000, "guidance": 2.0, "guidance_rescale": 0.0, "eta": 0.0}


def fitted_length(num_samples: int, num_frames: int | None = None) -> tuple[int, int]:
    """Return ``(padded samples, model frames)``: audio padded to a multiple of ``16000 / gcd(16000, 60)`` samples,
    long enough for ``num_frames`` frames when given."""
    block = SAMPLE_RATE // math.gcd(SAMPLE_RATE, FPS)
    need = num_samples if num_frames is None else max(num_samples, math.ceil(num_frames * SAMPLE_RATE / FPS))
    padded = math.ceil(need / block) * block
    return padded, padded * FPS // SAMPLE_RATE


def padded_waveform(audio: np.ndarray, num_frames: int | None = None) -> tuple[torch.Tensor, int, int]:
    """``(wav (1, N') float32 Tensor, model frames, output frames)`` of mono 16 kHz ``audio (N,)``: zero-padded as
    :func:`fitted_length` says, for ``num_frames`` output frames (default: the audio's duration at 60 fps)."""
    out_frames = int(audio.shape[0] * FPS / SAMPLE_RATE) if num_frames is None else int(num_frames)
    padded, frames = fitted_length(audio.shape[0], out_frames)
    wav = torch.zeros(1, padded)
    wav[0, : audio.shape[0]] = torch.from_numpy(np.asarray(audio, dtype=np.float32))
    return wav, frames, out_frames


class OfficialSAiD:
    """The authors' ``SAID_UNet1D`` with its sampling settings, generating like :class:`baselines.said.pipeline.SAiD`.

    Parameters
    ----------
    model : SAID_UNet1D
    sampling : dict, optional
        Overrides of :data:`OFFICIAL_SAMPLING`.
    """

    def __init__(self, model, sampling: dict | None = None):
        self.model = model.eval()
        self.names = tuple(BLENDVOCA_NAMES)
        self.sampling = {**OFFICIAL_SAMPLING, **(sampling or {})}
        self.device = torch.device("cpu")
        self.config = {"preset": "official", "sampling": dict(self.sampling)}

    @classmethod
    def load(cls, path: str | os.PathLike, **sampling) -> OfficialSAiD:
        """Load ``SAiD.pth`` strictly (:func:`baselines.said.official.load_official`)."""
        return cls(load_official(Path(os.fspath(path))), sampling)

    def to(self, device) -> OfficialSAiD:
        self.device = torch.device(device)
        self.model.to(self.device)
        return self

    def _sampling(self, sampler, num_steps, guidance, eta, guidance_rescale) -> dict:
        """The sampling keywords of :func:`said_inference`: each value given, else :attr:`sampling`'s."""
        s = self.sampling
        return {"num_steps": int(num_steps or s["num_steps"]), "sampler": sampler or s["sampler"],
                "guidance": s["guidance"] if guidance is None else float(guidance),
                "guidance_rescale": s["guidance_rescale"] if guidance_rescale is None else float(guidance_rescale),
                "eta": s["eta"] if eta is None else float(eta)}

    @torch.no_grad()
    def generate(self, audio, num_frames=None, *, samples=1, seed=0, reference=None, mask=None, sampler=None,
                 num_steps=None, guidance=None, eta=None, guidance_rescale=None, strength=1.0,
                 save_intermediates=False, return_intermediates=False):
        """Return ``(S, T, 32)`` tracks in [0, 1] (float64) for mono 16 kHz ``audio (N,)``.

        ``reference``/``mask`` ``(T, 32)``: edit (the authors' ``init_samples``/``mask``,
        with ``strength``).  With ``return_intermediates`` also the list of the chain's
        states, each ``(S, T, 32)``.
        """
        audio = np.asarray(audio, dtype=np.float32)
        if audio.ndim != 1 or audio.size == 0:
            raise DataError(f"OfficialSAiD.generate: expected (N,) mono audio at 16 kHz, got shape {audio.shape}")
        if reference is not None:
            num_frames = int(np.asarray(reference).shape[0]) if num_frames is None else num_frames
        wav, frames, out_frames = padded_waveform(audio, num_frames)
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
            self.model, embedding, batch=int(samples), strength=float(strength), init_samples=init, mask=edit_mask,
            generator=gen, save_intermediates=save_intermediates or return_intermediates,
            **self._sampling(sampler, num_steps, guidance, eta, guidance_rescale),
        )
        tracks = out.result[:, :out_frames].double().cpu().numpy()
        if return_intermediates:
            return tracks, [x[:, :out_frames].double().cpu().numpy() for x in out.intermediates]
        return tracks

    @torch.no_grad()
    def generate_many(self, utterances, *, samples=1, seeds, sampler=None, num_steps=None, guidance=None, eta=None,
                      guidance_rescale=None) -> list[np.ndarray]:
        """Return the tracks of several utterances, sampled as one batched chain.

        The same as ``[self.generate(audio, T, samples=samples, seed=seed, ...) for ...]``
        up to float rounding: each utterance is encoded alone and draws its noise from
        its own seed; the chain runs on all tracks zero-padded to the longest, with
        their lengths (:func:`baselines.said.inference.said_inference`).

        Parameters
        ----------
        utterances : sequence of (audio (N,) ndarray, num_frames int or None)
        samples : int
        seeds : sequence of int
            One per utterance.

        Returns
        -------
        list of (S, T_i, 32) float64 ndarrays in [0, 1]
        """
        utterances, seeds = list(utterances), [int(seed) for seed in seeds]
        if len(seeds) != len(utterances):
            raise ValueError(f"OfficialSAiD.generate_many: expected one seed per utterance, got {len(seeds)} "
                             f"for {len(utterances)}")
        options = {"sampler": sampler, "num_steps": num_steps, "guidance": guidance, "eta": eta,
                   "guidance_rescale": guidance_rescale}
        if len(utterances) <= 1:
            return [self.generate(audio, frames, samples=samples, seed=seed, **options)
                    for (audio, frames), seed in zip(utterances, seeds)]
        embeddings, out_frames = [], []
        for index, (audio, num_frames) in enumerate(utterances):
            audio = np.asarray(audio, dtype=np.float32)
            if audio.ndim != 1 or audio.size == 0:
                raise DataError(f"OfficialSAiD.generate_many: utterance {index}: expected (N,) mono audio at 16 kHz, "
                                f"got shape {audio.shape}")
            wav, frames, wanted = padded_waveform(audio, num_frames)
            embeddings.append(self.model.get_audio_embedding(self.model.process_audio(wav.to(self.device)), frames))
            out_frames.append(wanted)
        lengths = [e.shape[1] for e in embeddings]
        longest = max(lengths)
        embedding = padded_batch([e.expand(samples, -1, -1) for e in embeddings], longest)
        generators = [torch.Generator(device=self.device).manual_seed(seed) for seed in seeds]
        draw = utterance_noise(generators, lengths, samples, len(self.names), num_frames=longest,
                               dtype=torch.float32, device=self.device)
        out = said_inference(
            self.model, embedding, batch=embedding.shape[0], draw=draw,
            lengths=torch.tensor(lengths, device=self.device).repeat_interleave(samples),
            **self._sampling(sampler, num_steps, guidance, eta, guidance_rescale),
        )
        result = out.result.double().cpu().numpy()
        return [result[i * samples:(i + 1) * samples, :frames] for i, frames in enumerate(out_frames)]
