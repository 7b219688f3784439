"""CodeTalker stage 2: speech-driven autoregressive query of the frozen motion codebook.

Names as the authors' ``CodeTalker``: ``audio_encoder`` (wav2vec 2.0),
``audio_feature_map``, ``vertice_map``, ``PPE``, ``transformer_decoder`` (FaceFormer's
biased causal decoder, :mod:`baselines.common.motion_decoder`), ``feat_map`` (to
``face_quan_num * zquant_dim`` per frame), ``learnable_style_emb`` (an embedding over
the training speakers) and ``autoencoder`` (the frozen stage-1 :class:`~baselines.codetalker.vqvae.VQAutoEncoder`).
Each predicted frame feature is quantized with the codebook and decoded by the
VQ-VAE decoder; the decoded motion of the last frame is fed back as the next input.
"""

from __future__ import annotations

import copy

import torch
from torch import nn

from baselines.codetalker.vqvae import VQAutoEncoder
from baselines.common.device import module_device
from baselines.common.motion_decoder import SpeechMotionTransformer, decode_step, decode_teacher_forced
from blendvoca.errors import UserError

__all__ = ["STAGE2_DEFAULTS", "CodeTalker"]

#: The authors' VOCASET stage-2 settings (config/vocaset/stage2.yaml).
STAGE2_DEFAULTS = {
    "dataset": "vocaset",
    "vertice_dim": 5023 * 3,
    "feature_dim": 1024,
    "period": 30,
    "n_head": 4,
    "num_layers": 6,
    "num_subjects": 8,
    "dropout": 0.1,
    "max_seq_len": 600,
    "fps": 30,
    "audio": {"kind": "wav2vec2", "config": "base"},
    "motion_weight": 1.0,
    "reg_weight": 1.0,
}


class CodeTalker(SpeechMotionTransformer):
    """CodeTalker (stage 2 around a frozen stage-1 VQ-VAE).

    Parameters
    ----------
    config : dict, optional
        Keys of :data:`STAGE2_DEFAULTS`.
    stage1 : dict, optional
        Config of the VQ-VAE (:data:`~baselines.codetalker.vqvae.STAGE1_DEFAULTS` keys).
    autoencoder : VQAutoEncoder, optional
        A trained VQ-VAE to use (frozen); default a new one from ``stage1``.
    """

    def __init__(self, config: dict | None = None, stage1: dict | None = None, autoencoder: VQAutoEncoder | None = None):
        super().__init__()
        unknown = sorted(set(config or {}) - set(STAGE2_DEFAULTS))
        if unknown:
            raise UserError(f"CodeTalker stage 2: unknown keys {unknown}; expected some of {sorted(STAGE2_DEFAULTS)}")
        self.config = {**copy.deepcopy(STAGE2_DEFAULTS), **copy.deepcopy(config or {})}
        cfg = self.config
        self.autoencoder = autoencoder if autoencoder is not None else VQAutoEncoder(stage1)
        self.stage1 = self.autoencoder.config
        self.face_quan_num = int(self.stage1["face_quan_num"])
        self.zquant_dim = int(self.stage1["zquant_dim"])
        self.build_speech_decoder(cfg)
        self.feat_map = nn.Linear(cfg["feature_dim"], self.face_quan_num * self.zquant_dim, bias=False)
        self.learnable_style_emb = nn.Embedding(cfg["num_subjects"], cfg["feature_dim"])
        nn.init.constant_(self.feat_map.weight, 0)
        for p in self.autoencoder.parameters():
            p.requires_grad_(False)

    def train(self, mode: bool = True):
        """Train mode for stage 2; the frozen VQ-VAE stays in eval mode."""
        super().train(mode)
        self.autoencoder.eval()
        return self

    def stage2_state_dict(self) -> dict:
        """The state dict without the ``autoencoder.`` keys (the layout of the authors' stage-2 file)."""
        return {k: v for k, v in self.state_dict().items() if not k.startswith("autoencoder.")}

    def style(self, one_hot: torch.Tensor) -> torch.Tensor:
        """Style embedding ``(B, 1, feature_dim)`` of the arg-max speaker of ``one_hot``."""
        return self.learnable_style_emb(torch.argmax(one_hot, dim=1)).unsqueeze(1)

    def _codes(self, feat: torch.Tensor) -> torch.Tensor:
        """Frame features ``(B, T, fqn * zd)`` -> vectors ``(B, T * fqn, zd)``."""
        return feat.reshape(feat.shape[0], feat.shape[1] * self.face_quan_num, -1)

    def forward(self, audio, template, vertice, one_hot, vertice_input=None):
        """Teacher-forced pass: ``(prediction (B, T, V*3), motion_loss, reg_loss)``.

        ``motion_loss`` is the MSE of the decoded prediction, ``reg_loss`` the MSE between the
        predicted features and the VQ-VAE's quantized features of the ground truth.
        ``vertice_input`` ``(B, T, V*3)``, optional, replaces ``vertice`` as the frames fed
        back (frame ``t`` is the input of step ``t + 1``); default ``vertice`` (the authors'
        teacher forcing).
        """
        template = template.unsqueeze(1)
        style = self.style(one_hot)
        memory = self.audio_features(audio, vertice.shape[1])
        with torch.no_grad():
            feat_q_gt, _ = self.autoencoder.get_quant(vertice - template)
        feat_q_gt = feat_q_gt.permute(0, 2, 1)
        fed = vertice if vertice_input is None else vertice_input
        previous = torch.cat([template, fed[:, :-1]], dim=1) - template
        inputs = self.PPE(self.vertice_map(previous) + style)
        decoded = decode_teacher_forced(self.transformer_decoder, inputs, memory, **self.decode_options())
        feat_out = self._codes(self.feat_map(decoded))
        feat_out_q, _, _ = self.autoencoder.quantize(feat_out)
        vertice_out = self.autoencoder.decode(feat_out_q) + template
        loss_motion = torch.mean((vertice_out - vertice) ** 2)
        loss_reg = torch.mean((feat_out - feat_q_gt.detach()) ** 2)
        return vertice_out, loss_motion, loss_reg

    def loss(self, audio, template, vertice, one_hot, vertice_input=None) -> torch.Tensor:
        """``motion_weight * motion_loss + reg_weight * reg_loss`` (the authors' stage-2 objective)."""
        _, motion, reg = self(audio, template, vertice, one_hot, vertice_input)
        return self.config["motion_weight"] * motion + self.config["reg_weight"] * reg

    def predict(self, audio, template, one_hot, num_frames: int | None = None, one_hot2=None, weight_of_one_hot=None):
        """Autoregressive prediction ``(B, T, V*3)``, the authors' ``predict``.

        Step ``i`` decodes the quantized features of frames ``0..i`` with the (non-causal)
        VQ-VAE decoder and feeds the last decoded frame back (frame 0 is decoded
        from itself twice, as the authors do). The result is the decoding of all
        frames' quantized features. ``one_hot2`` / ``weight_of_one_hot`` blend two styles.
        The inputs may be on any device: they move to the network's, and the result comes
        back on ``audio``'s (a network on a GPU predicts for CPU callers).
        """
        home, device = audio.device, module_device(self)
        audio, template, one_hot = audio.to(device), template.to(device), one_hot.to(device)
        if one_hot2 is not None:
            one_hot2 = one_hot2.to(device)
        template = template.unsqueeze(1)
        style = self.learnable_style_emb(torch.argmax(one_hot, dim=1))
        if one_hot2 is not None and weight_of_one_hot is not None:
            style2 = self.learnable_style_emb(torch.argmax(one_hot2, dim=1))
            style = style * weight_of_one_hot + style2 * (1 - weight_of_one_hot)
        style = style.unsqueeze(1)
        memory = self.audio_features(audio, num_frames)
        frames = memory.shape[1]
        cache = [None] * len(self.transformer_decoder.layers)
        token, quantized = style, []
        for i in range(frames):
            x = self.PPE.dropout(token + self.PPE.at(i, token))
            out = decode_step(self.transformer_decoder, x, memory, cache, **self.decode_options())
            feat = self._codes(self.feat_map(out))
            q, _, _ = self.autoencoder.quantize(feat)
            quantized.append(q)
            if i == frames - 1:
                break
            if i == 0:
                decoded = self.autoencoder.decode_frame(torch.cat([q, q], dim=-1), 0)
            else:
                decoded = self.autoencoder.decode_frame(torch.cat(quantized, dim=-1), -1)
            token = self.vertice_map(decoded) + style
        return (self.autoencoder.decode(torch.cat(quantized, dim=-1)) + template).to(home)
