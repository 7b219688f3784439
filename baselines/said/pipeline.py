"""The SAiD pipeline: a model with its config and column names; generation, editing, save/load."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import torch

from baselines.said.checkpoint import read_checkpoint, save_checkpoint
from baselines.said.edit import check_edit_inputs
from baselines.said.guidance import classifier_free_guidance
from baselines.said.model import SAiDModel
from baselines.said.normalization import (
    data_bounds,
    from_diffusion_space,
    to_diffusion_space,
)
from baselines.said.parametrization import noise_from_output
from baselines.said.presets import resolve_config
from baselines.said.sample import sample_diffusion
from baselines.said.schedule import alphas_cumprod_schedule, alphas_of
from baselines.said.threads import torch_threads

FPS = 60
SAMPLE_RATE = 16000


def frames_for_audio(num_samples: int, fps: int = FPS, sample_rate: int = SAMPLE_RATE) -> int:
    """Return the number of coefficient frames covering ``num_samples`` audio samples (at least 1)."""
    return max(1, round(num_samples * fps / sample_rate))


class SAiD:
    """A SAiD model with its configuration and coefficient names.

    Parameters
    ----------
    config : dict
        From :func:`baselines.said.presets.resolve_config`.
    names : sequence of str
        Coefficient column names ``(K,)``.
    model : SAiDModel, optional
        Built from ``config`` when omitted.
    """

    def __init__(self, config: dict, names, model: SAiDModel | None = None):
        self.config = config
        self.names = tuple(names)
        self.model = model if model is not None else SAiDModel(num_coeffs=len(self.names), **config["model"])
        if self.model.num_coeffs != len(self.names):
            raise ValueError(f"SAiD: model has {self.model.num_coeffs} coefficients but {len(self.names)} names were given")
        d = config["diffusion"]
        self.alphas_cumprod = torch.from_numpy(alphas_cumprod_schedule(d["num_train_steps"], d["schedule"])).float()
        self.history: dict = {}
        self.device = torch.device("cpu")

    def to(self, device) -> SAiD:
        """Move the model and schedule to ``device`` (e.g. ``"cuda"``); returns self."""
        self.device = torch.device(device)
        self.model.to(self.device)
        self.alphas_cumprod = self.alphas_cumprod.to(self.device)
        return self

    def to_diffusion(self, coeffs: torch.Tensor) -> torch.Tensor:
        """Map coefficients ``(..., K)`` in [0, 1] to the diffusion's data space."""
        return to_diffusion_space(coeffs, self.model.coeff_mean, self.model.coeff_scale)

    def from_diffusion(self, x: torch.Tensor) -> torch.Tensor:
        """Map diffusion samples ``(..., K)`` back to coefficients in [0, 1]."""
        return from_diffusion_space(x, self.model.coeff_mean, self.model.coeff_scale)

    @classmethod
    def from_preset(cls, names, preset: str = "cpu-demo", **overrides) -> SAiD:
        """Return an untrained model of ``preset`` with ``overrides`` (see :func:`resolve_config`)."""
        return cls(resolve_config(preset, **overrides), names)

    # ---- generation ---------------------------------------------------------------
    @torch.no_grad()
    def generate(
        self,
        audio: np.ndarray,
        num_frames: int | None = None,
        *,
        samples: int = 1,
        seed: int = 0,
        reference: np.ndarray | None = None,
        mask: np.ndarray | None = None,
        sampler: str | None = None,
        num_steps: int | None = None,
        guidance: float | None = None,
        eta: float | None = None,
        progress: bool = False,
    ) -> np.ndarray:
        """Return coefficient tracks sampled for one utterance.

        Parameters
        ----------
        audio : (N,) float ndarray
            Mono speech at 16 kHz, any length.
        num_frames : int, optional
            ``T``; defaults to the audio duration at 60 fps.
        samples : int, default 1
            Number of independent samples ``S``.
        seed : int, default 0
        reference, mask : (T, K) ndarray, optional
            Editing: where ``mask`` is 1 the output equals ``reference`` exactly and the
            rest is generated consistently with it (in-betweening, per-blendshape
            constraints).  Columns in ``self.names`` order.
        sampler, num_steps, guidance, eta : optional
            Override the config's sampling section.
        progress : bool, default False

        Returns
        -------
        coeffs : (S, T, K) float64 ndarray in [0, 1]
        """
        audio = np.asarray(audio)
        if audio.ndim != 1 or audio.size == 0:
            raise ValueError(f"SAiD.generate: expected (N,) mono audio at 16 kHz, got shape {audio.shape}")
        if int(samples) != samples or samples < 1:
            raise ValueError(f"SAiD.generate: expected samples >= 1, got {samples!r}")
        num_frames = frames_for_audio(audio.shape[0]) if num_frames is None else int(num_frames)
        if num_frames < 2:
            raise ValueError(f"SAiD.generate: expected num_frames >= 2, got {num_frames}")
        k = len(self.names)
        check_edit_inputs(reference, mask, num_frames, k)
        s = self.config["sampling"]
        sampler = sampler or s["sampler"]
        num_steps = int(num_steps or s["num_steps"])
        guidance = s["guidance"] if guidance is None else float(guidance)
        eta = s["eta"] if eta is None else float(eta)

        ref_x = mask_t = None
        if reference is not None:
            ref = np.asarray(reference, dtype=np.float64)
            if ref.min() < 0 or ref.max() > 1:
                raise ValueError("SAiD.generate: expected reference coefficients in [0, 1]")
            ref_x = self.to_diffusion(torch.from_numpy(ref).float().to(self.device))
            mask_t = torch.from_numpy(np.asarray(mask, dtype=np.float32)).to(self.device)

        model = self.model.eval()
        with torch_threads(self.config["training"].get("num_threads")):
            generator = torch.Generator(device=self.device).manual_seed(int(seed))
            wav = torch.from_numpy(audio.astype(np.float32))[None].to(self.device)
            cond = model.condition(model.audio_features(wav, num_frames)).expand(samples, -1, -1)  # (S, T, D)
            both = torch.cat([cond, model.null_condition(samples, num_frames)])
            # the condition's cross-attention keys/values, once per utterance
            cond_cache, both_cache = model.context_cache(cond), model.context_cache(both)

            prediction = self.config["diffusion"].get("prediction", "epsilon")

            def noise_fn(x, t):
                a = alphas_of(t, self.alphas_cumprod)
                if guidance == 0:
                    return noise_from_output(model(x, t, cond, cond_cache), x, a, prediction)
                # one batched pass for the conditional and the unconditional estimate (the authors' UNet
                # repeats x itself after the layers that do not see the condition)
                xx, aa = torch.cat([x, x]), torch.cat([a, a])
                out = model(x, t, both, both_cache) if model.architecture == "authors" else model(xx, torch.cat([t, t]), both, both_cache)
                eps = noise_from_output(out, xx, aa, prediction)
                return classifier_free_guidance(eps[:samples], eps[samples:], guidance)

            x = sample_diffusion(
                noise_fn,
                (samples, num_frames, k),
                self.alphas_cumprod,
                sampler=sampler,
                num_steps=num_steps,
                eta=eta,
                clip=data_bounds(model.coeff_mean, model.coeff_scale) if s.get("clip", True) else None,
                reference=ref_x,
                mask=mask_t,
                generator=generator,
                progress=progress,
            )
        out = self.from_diffusion(x.double()).cpu().numpy()
        if reference is not None:
            # exact, not float32-rounded, reference values where the mask keeps them
            m = np.asarray(mask, dtype=np.float64)
            out = m * np.asarray(reference, dtype=np.float64) + (1.0 - m) * out
        return out

    # ---- persistence -------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write the checkpoint file ``path`` (config, names, weights, history)."""
        return save_checkpoint(path, self.model, self.config, self.names, self.history)

    @classmethod
    def load(cls, path: str | os.PathLike) -> SAiD:
        """Return the pipeline stored in the checkpoint file ``path``."""
        payload = read_checkpoint(path)
        said = cls(payload["config"], payload["names"])
        missing, unexpected = said.model.load_state_dict(payload["state_dict"], strict=False)
        missing = [m for m in missing if not m.startswith("encoder.")]
        if missing or unexpected:
            raise ValueError(f"SAiD checkpoint {path}: weights do not match the config (missing {missing[:5]}, unexpected {unexpected[:5]})")
        said.history = payload.get("history", {})
        return said
