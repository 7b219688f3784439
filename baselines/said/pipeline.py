"""The SAiD pipeline: a model with its config and column names; generation, editing, save/load."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import torch

from baselines.common.chunking import chunk_plan, chunk_setting, generate_in_chunks
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
from baselines.said.sample import padded_batch, sample_diffusion, utterance_noise
from baselines.said.samplers import SAMPLERS
from baselines.said.schedule import alphas_cumprod_schedule, alphas_of
from blendvoca.errors import DataError, UserError
from blendvoca.runtime.threads import limited_threads

FPS = 60
SAMPLE_RATE = 16000
#: Default chunk length in training windows: 10 s for ``cpu-demo`` (1 s windows), 20 s for ``paper``.
CHUNK_WINDOWS = 10


def frames_for_audio(num_samples: int, fps: int = FPS, sample_rate: int = SAMPLE_RATE) -> int:
    """Return the number of coefficient frames covering ``num_samples`` audio samples (at least 1)."""
    return max(1, round(num_samples * fps / sample_rate))


def checked_utterance(audio, num_frames: int | None, where: str) -> tuple[np.ndarray, int]:
    """``(audio, num_frames)`` of one utterance to sample: mono audio, at least two frames
    (default :func:`frames_for_audio`); otherwise an error naming ``where``."""
    audio = np.asarray(audio)
    if audio.ndim != 1 or audio.size == 0:
        raise DataError(f"{where}: expected (N,) mono audio at 16 kHz, got shape {audio.shape}")
    num_frames = frames_for_audio(audio.shape[0]) if num_frames is None else int(num_frames)
    if num_frames < 2:
        raise UserError(f"{where}: expected num_frames >= 2, got {num_frames}")
    return audio, num_frames


def check_sampling(sampling: dict, num_train_steps: int) -> None:
    """A UserError naming the key unless ``sampling`` (a config's sampling section) can drive the samplers."""
    problems = []
    if sampling.get("sampler") not in SAMPLERS:
        problems.append(f"sampler in {SAMPLERS}, got {sampling.get('sampler')!r}")
    steps = sampling.get("num_steps")
    if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= steps <= num_train_steps:
        problems.append(f"num_steps an integer in [1, {num_train_steps}], got {steps!r}")
    for key in ("guidance", "eta"):
        value = sampling.get(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0:
            problems.append(f"{key} a number >= 0, got {value!r}")
    if problems:
        raise UserError("SAiD sampling: expected " + "; ".join(problems))


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
    @property
    def chunk_frames(self) -> int:
        """Frames per chunk of a long utterance: ``chunk_frames`` of the config, default
        :data:`CHUNK_WINDOWS` training windows (:mod:`baselines.common.chunking`)."""
        window = int(self.config.get("training", {}).get("window") or FPS)
        return chunk_setting(self.config, "chunk_frames", CHUNK_WINDOWS * window)

    @property
    def chunk_overlap(self) -> int:
        """Frames two chunks share (the crossfade): ``chunk_overlap`` of the config, default half a
        training window (0.5 s for ``cpu-demo``), where the UNet's receptive field has settled."""
        window = int(self.config.get("training", {}).get("window") or FPS)
        return chunk_setting(self.config, "chunk_overlap", max(1, window // 2))

    @property
    def lookahead_s(self) -> float:
        """Audio after frame ``t`` that frame ``t`` needs, in seconds, at worst: the UNet sees its whole
        chunk in both directions, so the first frame of a chunk waits for the chunk's last audio."""
        return self.chunk_frames / FPS

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

        Returns
        -------
        coeffs : (S, T, K) float64 ndarray in [0, 1]
        """
        if int(samples) != samples or samples < 1:
            raise UserError(f"SAiD.generate: expected samples >= 1, got {samples!r}")
        audio, num_frames = checked_utterance(audio, num_frames, "SAiD.generate")
        check_edit_inputs(reference, mask, num_frames, len(self.names))
        options = {"samples": samples, "seed": seed, "sampler": sampler, "num_steps": num_steps,
                   "guidance": guidance, "eta": eta}
        plan = chunk_plan(num_frames, self.chunk_frames, self.chunk_overlap)
        if plan.chunked and reference is None:
            # a long utterance: chunk by chunk (each its own audio features and chain, the
            # same seed for each), crossfaded; an edit keeps the whole track in one chain
            return generate_in_chunks(lambda wav, frames, _index: self._generate_whole(wav, frames, **options),
                                      audio, num_frames, plan)
        return self._generate_whole(audio, num_frames, reference=reference, mask=mask, **options)

    @torch.no_grad()
    def _generate_whole(self, audio, num_frames: int, *, samples, seed, sampler, num_steps, guidance, eta,
                        reference=None, mask=None) -> np.ndarray:
        """:meth:`generate` of ``num_frames`` frames in one chain, whatever the chunk length."""
        ref_x = mask_t = None
        if reference is not None:
            ref = np.asarray(reference, dtype=np.float64)
            if ref.min() < 0 or ref.max() > 1:
                raise DataError("SAiD.generate: expected reference coefficients in [0, 1]")
            ref_x = self.to_diffusion(torch.from_numpy(ref).float().to(self.device))
            mask_t = torch.from_numpy(np.asarray(mask, dtype=np.float32)).to(self.device)

        with limited_threads(self.config["training"].get("num_threads"), torch_only=True):
            wav = torch.from_numpy(audio.astype(np.float32))[None].to(self.device)
            x = self._sample([wav], [num_frames], [int(seed)], samples=samples, reference=ref_x, mask=mask_t,
                             **self._sampling(sampler, num_steps, guidance, eta))
        out = self.from_diffusion(x.double()).cpu().numpy()
        if reference is not None:
            # exact, not float32-rounded, reference values where the mask keeps them
            m = np.asarray(mask, dtype=np.float64)
            out = m * np.asarray(reference, dtype=np.float64) + (1.0 - m) * out
        return out

    @torch.no_grad()
    def generate_many(
        self,
        utterances,
        *,
        samples: int = 1,
        seeds,
        sampler: str | None = None,
        num_steps: int | None = None,
        guidance: float | None = None,
        eta: float | None = None,
    ) -> list[np.ndarray]:
        """Return the tracks of several utterances, sampled as one batched chain.

        The same as ``[self.generate(audio, T, samples=samples, seed=seed, ...)
        for (audio, T), seed in zip(utterances, seeds)]`` up to float rounding: each
        utterance draws its noise from its own seed, and the network sees every
        track zero-padded to the longest with its length, so that no layer mixes
        in padded frames (:class:`baselines.said.unet1d.ConditionalUNet1D`).  The
        ``compact`` UNet has no lengths: it samples one utterance at a time.

        Parameters
        ----------
        utterances : sequence of (audio (N,) ndarray, num_frames int or None)
        samples : int, default 1
        seeds : sequence of int
            One per utterance.
        sampler, num_steps, guidance, eta
            As for :meth:`generate`.

        Returns
        -------
        list of (S, T_i, K) float64 ndarrays in [0, 1]
        """
        utterances, seeds = list(utterances), [int(seed) for seed in seeds]
        if len(seeds) != len(utterances):
            raise ValueError(f"SAiD.generate_many: expected one seed per utterance, got {len(seeds)} for {len(utterances)}")
        if not utterances:
            return []
        options = {"sampler": sampler, "num_steps": num_steps, "guidance": guidance, "eta": eta}
        def long(audio, frames):
            return (frames_for_audio(np.asarray(audio).shape[0]) if frames is None else int(frames)) > self.chunk_frames

        if self.model.architecture != "authors" or len(utterances) == 1 or any(long(*u) for u in utterances):
            # one at a time: a long utterance goes chunk by chunk (:meth:`generate`)
            return [self.generate(audio, frames, samples=samples, seed=seed, **options)
                    for (audio, frames), seed in zip(utterances, seeds)]
        if int(samples) != samples or samples < 1:
            raise UserError(f"SAiD.generate_many: expected samples >= 1, got {samples!r}")
        waves, lengths = [], []
        for index, (audio, frames) in enumerate(utterances):
            audio, frames = checked_utterance(audio, frames, f"SAiD.generate_many: utterance {index}")
            waves.append(torch.from_numpy(audio.astype(np.float32))[None].to(self.device))
            lengths.append(frames)
        with limited_threads(self.config["training"].get("num_threads"), torch_only=True):
            x = self._sample(waves, lengths, seeds, samples=int(samples),
                             **self._sampling(sampler, num_steps, guidance, eta))
        out = self.from_diffusion(x.double()).cpu().numpy()
        return [out[i * samples:(i + 1) * samples, :frames] for i, frames in enumerate(lengths)]

    def _sampling(self, sampler, num_steps, guidance, eta) -> dict:
        """The sampling keywords of :meth:`_sample`: each value given, else the config's."""
        s = self.config["sampling"]
        return {"sampler": sampler or s["sampler"], "num_steps": int(num_steps or s["num_steps"]),
                "guidance": s["guidance"] if guidance is None else float(guidance),
                "eta": s["eta"] if eta is None else float(eta)}

    def _sample(self, waves, lengths, seeds, *, samples, sampler, num_steps, guidance, eta, reference=None,
                mask=None) -> torch.Tensor:
        """The diffusion samples ``(n S, max T, K)`` of ``n`` utterances (rows ``i S .. i S + S - 1``: utterance ``i``,
        zero beyond its ``lengths[i]`` frames), each drawing its noise from ``torch.Generator().manual_seed(seeds[i])``."""
        model = self.model.eval()
        k = len(self.names)
        num_frames = max(lengths)
        padded = any(frames != num_frames for frames in lengths)
        # CPU generators on every device: a seed gives the same noise on a GPU as on the CPU
        # (the noise is drawn on the generator's device and moved, baselines.said.sample)
        generators = [torch.Generator().manual_seed(seed) for seed in seeds]
        conds = [model.condition(model.audio_features(wav, frames)).expand(samples, -1, -1)
                 for wav, frames in zip(waves, lengths)]  # (S, T_i, D) each
        cond = padded_batch(conds, num_frames)
        rows = cond.shape[0]
        both = torch.cat([cond, model.null_condition(rows, num_frames)])
        # the condition's cross-attention keys/values, once per batch of utterances
        cond_cache, both_cache = model.context_cache(cond), model.context_cache(both)
        row_lengths = torch.tensor(lengths, device=self.device).repeat_interleave(samples) if padded else None
        prediction = self.config["diffusion"].get("prediction", "epsilon")

        def noise_fn(x, t):
            a = alphas_of(t, self.alphas_cumprod)
            if guidance == 0:
                return noise_from_output(model(x, t, cond, cond_cache, lengths=row_lengths), x, a, prediction)
            # one batched pass for the conditional and the unconditional estimate (the authors' UNet
            # repeats x itself after the layers that do not see the condition)
            xx, aa = torch.cat([x, x]), torch.cat([a, a])
            if model.architecture == "authors":
                out = model(x, t, both, both_cache, lengths=row_lengths)
            else:
                out = model(xx, torch.cat([t, t]), both, both_cache)
            eps = noise_from_output(out, xx, aa, prediction)
            return classifier_free_guidance(eps[:rows], eps[rows:], guidance)

        s = self.config["sampling"]
        return sample_diffusion(
            noise_fn,
            (rows, num_frames, k),
            self.alphas_cumprod,
            sampler=sampler,
            num_steps=num_steps,
            eta=eta,
            clip=data_bounds(model.coeff_mean, model.coeff_scale) if s.get("clip", True) else None,
            reference=reference,
            mask=mask,
            generator=generators[0],
            draw=utterance_noise(generators, lengths, samples, k, num_frames=num_frames,
                                 dtype=self.alphas_cumprod.dtype, device=self.device),
        )

    # ---- persistence -------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write the checkpoint file ``path`` (config, names, weights, history)."""
        return save_checkpoint(path, self.model, self.config, self.names, self.history)

    @classmethod
    def load(cls, path: str | os.PathLike) -> SAiD:
        """Return the pipeline stored in the checkpoint file ``path``."""
        payload = read_checkpoint(path)
        said = cls(payload["config"], payload["names"])
        try:
            missing, unexpected = said.model.load_state_dict(payload["state_dict"], strict=False)
        except (AttributeError, KeyError, TypeError, RuntimeError) as exc:  # tensors of other shapes than the config's
            raise DataError(f"SAiD checkpoint {path}: weights do not match the config "
                            f"({type(exc).__name__}: {' '.join(str(exc).split())[:300]})") from None
        missing = [m for m in missing if not m.startswith("encoder.")]
        if missing or unexpected:
            raise DataError(f"SAiD checkpoint {path}: weights do not match the config (missing {missing[:5]}, unexpected {unexpected[:5]})")
        said.history = payload.get("history", {})
        return said
