"""CDFace end to end: config, face parts, templates, the frozen audio encoder, the model.

``CDFace.from_preset(parts, styles, templates)`` builds an untrained model;
:func:`baselines.cdface.train.train_cdface` trains it; :meth:`CDFace.generate`
returns ``(S, T, V, 3)`` vertices in metres for any 16 kHz speech, diverse or with
the lips fixed; :meth:`CDFace.save` / :meth:`CDFace.load` round-trip everything
but the frozen audio encoder's weights (rebuilt from the config).
"""

from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np
import torch

from baselines.cdface.model import CDFaceModel, sample_pairs
from baselines.cdface.parts import FaceParts
from baselines.cdface.presets import DEFAULT_PRESET, resolve_config
from baselines.common.checkpoint import load_checkpoint_file, old_format_hint, safe_payload, save_checkpoint_file
from baselines.common.encoders import build_encoder
from blendvoca.errors import DataError, UserError
from blendvoca.runtime.progress import bar
from blendvoca.runtime.threads import limited_threads

__all__ = ["CONTROL_MODES", "CDFace"]

#: ``control`` values of :meth:`CDFace.generate`.
CONTROL_MODES = ("none", "lips")


class CDFace:
    """A CDFace model with everything it needs to animate a speaker's mesh.

    Parameters
    ----------
    config : dict
        From :func:`baselines.cdface.presets.resolve_config`.
    parts : FaceParts
    styles : list of str
        Training speakers, one style token each.
    templates : dict str -> (V, 3) array_like
        Neutral meshes (metres) of the speakers it can animate by name.
    """

    def __init__(self, config: dict, parts: FaceParts, styles, templates: dict):
        self.config = copy.deepcopy(config)
        self.parts = parts
        self.styles = [str(s) for s in styles]
        if not self.styles:
            raise DataError("CDFace: expected at least one style (training speaker)")
        self.templates = {str(k): np.asarray(v, dtype=np.float64) for k, v in templates.items()}
        for name, tpl in self.templates.items():
            if tpl.shape != (parts.num_vertices, 3):
                raise DataError(f"CDFace: template of {name} has shape {tpl.shape}, expected ({parts.num_vertices}, 3)")
        self.encoder = build_encoder(self.config["model"]["encoder"])
        self.model = CDFaceModel(3 * len(parts.lips), 3 * len(parts.upper), self.encoder.feature_dim,
                                 len(self.styles), self.config["model"])

    @classmethod
    def from_preset(cls, parts: FaceParts, styles, templates: dict, preset: str = DEFAULT_PRESET, **overrides):
        """Untrained model of a preset with flat ``overrides`` (see ``resolve_config``)."""
        return cls(resolve_config(preset, **overrides), parts, styles, templates)

    @property
    def motion_scale(self) -> float:
        return float(self.config["model"]["motion_scale"])

    @torch.no_grad()
    def features(self, audio, num_frames: int) -> torch.Tensor:
        """Frozen audio features ``(1, num_frames, F)`` of mono 16 kHz ``audio`` ``(N,)``."""
        audio = torch.as_tensor(np.asarray(audio, dtype=np.float32))
        if audio.ndim != 1:
            raise DataError(f"CDFace.features: expected mono audio (N,), got shape {tuple(audio.shape)}")
        return self.encoder(audio[None], int(num_frames)).float()

    def split_motion(self, vertices, template) -> tuple[np.ndarray, np.ndarray]:
        """``(T, V, 3)`` metres -> lip ``(T, 3 V_l)`` and upper ``(T, 3 V_u)`` displacements (model units)."""
        disp = (np.asarray(vertices, dtype=np.float64) - np.asarray(template, dtype=np.float64)) * self.motion_scale
        lips, upper = self.parts.split(disp)
        return lips.astype(np.float32), upper.astype(np.float32)

    def style_index(self, style=None) -> int:
        """Index of a style token: a training speaker's name, an index, or None (the first)."""
        if style is None:
            return 0
        if isinstance(style, (int, np.integer)) and not isinstance(style, bool):
            if not 0 <= style < len(self.styles):
                raise UserError(f"CDFace: style index {style} outside [0, {len(self.styles)})")
            return int(style)
        if str(style) not in self.styles:
            raise UserError(f"CDFace: unknown style {style!r}; training speakers: {self.styles}")
        return self.styles.index(str(style))

    def template_for(self, subject=None, template=None) -> np.ndarray:
        """The neutral mesh to animate: ``template`` when given, else the stored one of ``subject``."""
        if template is not None:
            template = np.asarray(template, dtype=np.float64)
            if template.shape != (self.parts.num_vertices, 3):
                raise DataError(f"CDFace: expected a template ({self.parts.num_vertices}, 3), got {template.shape}")
            return template
        if subject not in self.templates:
            raise UserError(f"CDFace: no template stored for subject {subject!r}; known: {sorted(self.templates)}; "
                            "pass a template mesh")
        return self.templates[subject]

    def generate(self, audio, num_frames: int, *, subject=None, template=None, samples: int = 1, seed: int = 0,
                 control: str = "none", reference=None, style=None) -> np.ndarray:
        """Animate ``S`` samples of a speaker's mesh for one utterance.

        Parameters
        ----------
        audio : (N,) float array, 16 kHz mono
        num_frames : int
            ``T`` at 60 fps.
        subject : str, optional
            Speaker whose stored template is animated (or pass ``template``).
        template : (V, 3) array_like, optional
        samples : int
        seed : int
            Relabels the sample heads (see :func:`baselines.cdface.model.sample_pairs`).
        control : {"none", "lips"}
            ``"lips"``: the lip codes are fixed (one lip sample, or ``reference``)
            and only the upper face varies between samples.
        reference : (T, V, 3) array_like, optional
            With ``control="lips"``: the lips are this sequence's lip codes.
        style : str or int, optional
            Training speaker whose style token is used (default the first).

        Returns
        -------
        (S, T, V, 3) float64 ndarray, metres.
        """
        if control not in CONTROL_MODES:
            raise UserError(f"CDFace.generate: expected control in {CONTROL_MODES}, got {control!r}")
        if reference is not None and control != "lips":
            raise UserError("CDFace.generate: a reference sequence fixes the lips; use control='lips'")
        if int(samples) < 1:
            raise UserError(f"CDFace.generate: expected samples >= 1, got {samples}")
        tpl = self.template_for(subject, template)
        num_frames = int(num_frames)
        pairs = sample_pairs(int(samples), self.model.num_lip_samples, self.model.num_upper_samples, seed=seed, control=control)
        lip_codes = None
        if reference is not None:
            reference = np.asarray(reference, dtype=np.float64)
            if reference.ndim != 3 or reference.shape[1:] != tpl.shape:
                raise DataError(f"CDFace.generate: expected a reference (T, {tpl.shape[0]}, 3), got {reference.shape}")
            reference = reference[:num_frames]
            if len(reference) < num_frames:
                reference = np.concatenate([reference, np.repeat(reference[-1:], num_frames - len(reference), 0)])
            lip_codes = self.model.encode_lips(self.split_motion(reference, tpl)[0])
        self.model.eval()
        frames = bar(total=num_frames, desc="CDFace: frames", unit="frame")
        try:
            with limited_threads(self.config["training"]["num_threads"], torch_only=True):
                lips, upper = self.model.sample(self.features(audio, num_frames), self.style_index(style), pairs,
                                                lip_codes=lip_codes, on_frame=lambda t: frames.update(1))
        finally:
            frames.close()
        disp = self.parts.compose(lips.double().numpy(), upper.double().numpy()) / self.motion_scale
        return tpl[None, None] + disp

    def save(self, path: str | os.PathLike) -> None:
        """Write config, parts, styles, templates and the trained state to ``path``
        (atomically): tensors, numbers and strings only (the part indices as int64 and
        the templates as float64 tensors), so the file loads with ``weights_only=True``."""
        payload = {
            "config": self.config,
            "parts": {"lips": self.parts.lips, "upper": self.parts.upper, "num_vertices": self.parts.num_vertices},
            "styles": self.styles,
            "templates": dict(self.templates),
            "state_dict": self.model.state_dict(),
        }
        save_checkpoint_file(path, safe_payload(payload, where=f"CDFace.save {os.fspath(path)}"))

    @classmethod
    def load(cls, path: str | os.PathLike) -> CDFace:
        """Rebuild from :meth:`save`'s file.

        Raises
        ------
        UserError
            No file at ``path``.
        DataError
            A file that :meth:`save` did not write: not a torch file, pickled objects
            (an earlier version's format: the message names the converter), or
            weights that do not fit the stored configuration.
        """
        path = Path(os.fspath(path))
        payload = load_checkpoint_file(path, where="CDFace.load", old_format_hint=old_format_hint(path))
        if not isinstance(payload, dict) or not {"config", "parts", "styles", "templates", "state_dict"} <= set(payload):
            raise DataError(f"CDFace.load: {path} is not a checkpoint written by CDFace.save")
        try:
            stored = payload["parts"]
            parts = FaceParts(np.asarray(stored["lips"]), np.asarray(stored["upper"]), int(stored["num_vertices"]))
            templates = {k: np.asarray(v) for k, v in payload["templates"].items()}
            obj = cls(payload["config"], parts, payload["styles"], templates)
            obj.model.load_state_dict(payload["state_dict"])
        except (AttributeError, KeyError, TypeError, ValueError, RuntimeError) as exc:
            raise DataError(f"CDFace.load: {path} does not hold a model CDFace can restore "
                            f"({type(exc).__name__}: {' '.join(str(exc).split())[:300]})") from None
        obj.model.eval()
        obj.model.requires_grad_(False)
        return obj
