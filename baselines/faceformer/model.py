"""FaceFormer (Fan et al., CVPR 2022) with the authors' module and parameter names.

``Faceformer`` holds ``audio_encoder`` (wav2vec 2.0), ``audio_feature_map``,
``vertice_map`` (motion encoder), ``PPE`` (periodic positional encoding),
``transformer_decoder``, ``vertice_map_r`` (motion decoder) and ``obj_vector`` (the
one-hot style embedding), so the authors' ``vocaset.pth`` loads with ``strict=True``.
Motion is ``(B, T, V*3)`` vertex positions at 30 fps; the network works on
displacements from the speaker's template.
"""

from __future__ import annotations

import copy

import torch
from torch import nn

from baselines.common.device import module_device
from baselines.common.motion_decoder import SpeechMotionTransformer, decode_step, decode_teacher_forced
from blendvoca.errors import UserError

__all__ = ["DEFAULT_CONFIG", "Faceformer", "resolved_model_config"]

#: The authors' VOCASET settings (main.py defaults; 4 heads, 1 layer, wav2vec 2.0 base).
DEFAULT_CONFIG = {
    "dataset": "vocaset",
    "vertice_dim": 5023 * 3,
    "feature_dim": 64,
    "period": 30,
    "n_head": 4,
    "num_layers": 1,
    "num_subjects": 8,
    "dropout": 0.1,
    "max_seq_len": 600,
    "fps": 30,
    "audio": {"kind": "wav2vec2", "config": "base"},
}


def resolved_model_config(**overrides) -> dict:
    """:data:`DEFAULT_CONFIG` with ``overrides`` (unknown keys are an error)."""
    unknown = sorted(set(overrides) - set(DEFAULT_CONFIG))
    if unknown:
        raise UserError(f"model config: unknown keys {unknown}; expected some of {sorted(DEFAULT_CONFIG)}")
    cfg = copy.deepcopy(DEFAULT_CONFIG)
    cfg.update(copy.deepcopy(overrides))
    return cfg


class Faceformer(SpeechMotionTransformer):
    """FaceFormer: speech-driven autoregressive transformer over vertex sequences.

    Parameters
    ----------
    config : dict, optional
        Keys of :data:`DEFAULT_CONFIG` (missing ones take the default).
    """

    def __init__(self, config: dict | None = None):
        super().__init__()
        self.config = resolved_model_config(**(config or {}))
        cfg = self.config
        self.build_speech_decoder(cfg)
        self.vertice_map_r = nn.Linear(cfg["feature_dim"], cfg["vertice_dim"])
        self.obj_vector = nn.Linear(cfg["num_subjects"], cfg["feature_dim"], bias=False)
        nn.init.constant_(self.vertice_map_r.weight, 0)
        nn.init.constant_(self.vertice_map_r.bias, 0)

    def forward(self, audio: torch.Tensor, template: torch.Tensor, vertice: torch.Tensor, one_hot: torch.Tensor) -> torch.Tensor:
        """Teacher-forced prediction ``(B, T, V*3)`` of ``vertice`` (the training pass).

        Parameters
        ----------
        audio : (B, N) Tensor
        template : (B, V*3) Tensor
        vertice : (B, T, V*3) Tensor
            Ground-truth motion; frame ``t``'s input is frame ``t - 1`` (the template at ``t = 0``).
        one_hot : (B, num_subjects) Tensor
            Style (training speaker) of each sequence.
        """
        template = template.unsqueeze(1)
        style = self.obj_vector(one_hot).unsqueeze(1)
        memory = self.audio_features(audio, vertice.shape[1])
        previous = torch.cat([template, vertice[:, :-1]], dim=1) - template
        inputs = self.PPE(self.vertice_map(previous) + style)
        out = decode_teacher_forced(self.transformer_decoder, inputs, memory, **self.decode_options())
        return self.vertice_map_r(out) + template

    def predict(self, audio: torch.Tensor, template: torch.Tensor, one_hot: torch.Tensor, num_frames: int | None = None) -> torch.Tensor:
        """Autoregressive prediction ``(B, T, V*3)``, the authors' ``predict``.

        Frame 0's input is the style embedding; frame ``t``'s input is the motion
        embedding of the predicted frame ``t - 1`` plus the style embedding.

        Parameters
        ----------
        audio : (B, N) Tensor
        template : (B, V*3) Tensor
        one_hot : (B, num_subjects) Tensor
        num_frames : int, optional
            Default (the authors'): ``int(cnn_frames / 50 * 30)``.

        The inputs may be on any device: they move to the network's, and the result
        comes back on ``audio``'s (a network on a GPU predicts for CPU callers).
        """
        home, device = audio.device, module_device(self)
        audio, template, one_hot = audio.to(device), template.to(device), one_hot.to(device)
        template = template.unsqueeze(1)
        style = self.obj_vector(one_hot).unsqueeze(1)
        memory = self.audio_features(audio, num_frames)
        cache = [None] * len(self.transformer_decoder.layers)
        token = style
        outputs = []
        for t in range(memory.shape[1]):
            x = self.PPE.dropout(token + self.PPE.at(t, token))
            out = self.vertice_map_r(decode_step(self.transformer_decoder, x, memory, cache, **self.decode_options()))
            outputs.append(out)
            token = self.vertice_map(out) + style
        return (torch.cat(outputs, dim=1) + template).to(home)
