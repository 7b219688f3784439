"""The authors' SAiD network in their state_dict layout, and loading of the published ``SAiD.pth``.

The published file is the ``state_dict`` of the authors' ``SAID_UNet1D`` (trained
with ``feature_dim = -1``, i.e. no projection layer).  Its keys:

* ``audio_encoder.*``: a ``transformers.Wav2Vec2Model`` with the
  ``facebook/wav2vec2-base-960h`` architecture (``feature_extractor.conv_layers.{0..6}``,
  ``feature_projection``, ``encoder.pos_conv_embed.conv.{bias, weight_g, weight_v}``
  — written by an older torch; :mod:`baselines.wav2vec2.state_dict` renames them —
  ``encoder.layer_norm``, ``encoder.layers.{0..11}``, ``masked_spec_embed``);
* ``null_cond_emb``: ``(1, 1, 768)``, the trainable condition of classifier-free guidance;
* ``audio_proj_layer.{weight, bias}``: only when trained with ``feature_dim > 0``;
* ``denoiser.model.*``: :class:`baselines.said.unet1d.ConditionalUNet1D` with
  ``model_channels = 192``, ``num_head_channels = 32`` (6 heads), context 768.

:func:`official_state_keys` lists them for a configuration; :func:`load_official`
loads strictly.  :meth:`SAID_UNet1D.process_audio` is the authors' waveform
normalisation (zero mean, unit variance, ``eps = 1e-7``, as the wav2vec 2.0
feature extractor does it) and :meth:`SAID_UNet1D.get_audio_embedding` their
encoder pass with the CNN features interpolated to the coefficient frame count.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch
from torch import nn

from baselines.common.checkpoint import load_checkpoint_file, load_into
from baselines.common.encoders.wav2vec2 import normalize_waveform
from baselines.said.unet1d import ConditionalUNet1D
from baselines.wav2vec2 import base_config, interpolated_features, legacy_layout_state, wav2vec2_model
from blendvoca.errors import DataError

SAMPLE_RATE = 16000
FPS = 60


class UNet1DConditionModel(nn.Module):
    """``(B, T, C)`` wrapper of :class:`ConditionalUNet1D`, stored as ``model`` (the authors' layout)."""

    def __init__(self, in_channels: int, out_channels: int, cross_attention_dim: int, dropout: float = 0.1,
                 model_channels: int = 192, num_head_channels: int = 32):
        super().__init__()
        self.in_channels, self.out_channels = in_channels, out_channels
        self.cross_attention_dim = cross_attention_dim
        self.model = ConditionalUNet1D(in_channels, out_channels, cross_attention_dim, model_channels,
                                       num_head_channels, dropout=dropout)

    def forward(self, sample, timestep, encoder_hidden_states=None, caches=None, lengths=None):
        """sample (B, T, C), timestep (B,), encoder_hidden_states (B, S, D) -> (B, T, C); ``lengths (B,)``: valid
        frames of zero-padded rows."""
        return self.model(sample.transpose(1, 2), timestep, encoder_hidden_states, caches, lengths).transpose(1, 2)


class SAID_UNet1D(nn.Module):  # noqa: N801 - the authors' class name
    """SAiD: wav2vec 2.0 encoder, optional projection, null condition and the conditional 1-D UNet.

    Parameters
    ----------
    audio_config : transformers.Wav2Vec2Config, optional
        Defaults to the base-960h configuration (shipped, no download).
    in_channels : int, default 32
    feature_dim : int, default -1
        > 0: a Linear projection of the audio features to this size
        (``audio_proj_layer``); otherwise the features enter the UNet as they are.
    dropout : float, default 0.1
    model_channels, num_head_channels : int
        The UNet's width and head size (192, 32 in the published model).
    prediction_type : {"epsilon", "v_prediction", "sample"}, default "epsilon"
        What the network's output means (stored for the samplers).
    """

    def __init__(self, audio_config=None, in_channels: int = 32, feature_dim: int = -1, dropout: float = 0.1,
                 model_channels: int = 192, num_head_channels: int = 32, prediction_type: str = "epsilon"):
        super().__init__()
        self.audio_config = audio_config if audio_config is not None else base_config()
        self.audio_encoder = wav2vec2_model(self.audio_config)
        self.sampling_rate = SAMPLE_RATE
        self.prediction_type = prediction_type
        hidden = int(self.audio_config.hidden_size)
        self.feature_dim = int(feature_dim)
        if self.feature_dim > 0:
            self.audio_proj_layer = nn.Linear(hidden, self.feature_dim)
        self.null_cond_emb = nn.Parameter(torch.randn(1, 1, self.feature_dim if self.feature_dim > 0 else hidden))
        self.denoiser = UNet1DConditionModel(in_channels, in_channels, self.feature_dim if self.feature_dim > 0 else hidden,
                                             dropout, model_channels, num_head_channels)

    @property
    def in_channels(self) -> int:
        return self.denoiser.in_channels

    def process_audio(self, waveform: torch.Tensor) -> torch.Tensor:
        """Return waveforms ``(B, N)`` (or ``(N,)``) normalised to zero mean and unit variance, ``(B, N)`` float32."""
        waveform = torch.as_tensor(waveform, dtype=torch.float32)
        return normalize_waveform(waveform[None] if waveform.ndim == 1 else waveform)

    def get_audio_embedding(self, waveform: torch.Tensor, num_frames: int) -> torch.Tensor:
        """Return the condition ``(B, num_frames, D)`` for processed waveforms ``(B, N)``."""
        features = interpolated_features(self.audio_encoder, waveform, num_frames)
        if self.feature_dim > 0:
            features = self.audio_proj_layer(features)
        return features

    def null_condition(self, batch: int, num_frames: int) -> torch.Tensor:
        """Return the null condition repeated to ``(batch, num_frames, D)``."""
        return self.null_cond_emb.expand(batch, num_frames, -1)

    def forward(self, noisy_samples, timesteps, audio_embedding=None, caches=None, lengths=None):
        """Return the network output ``(B, T, C)`` for ``noisy_samples (B, T, C)``, ``timesteps (B,)`` or scalar;
        ``lengths (B,)``: valid frames of zero-padded rows (one embedding frame per frame)."""
        timesteps = torch.as_tensor(timesteps, device=noisy_samples.device)
        if timesteps.ndim == 0 or timesteps.shape[0] == 1:
            timesteps = timesteps.reshape(1).repeat(noisy_samples.shape[0])
        return self.denoiser(noisy_samples, timesteps, audio_embedding, caches, lengths)

    @torch.no_grad()
    def predict_noise(self, noisy: torch.Tensor, timesteps: torch.Tensor, waveform: torch.Tensor) -> torch.Tensor:
        """The authors' noise prediction for raw 16 kHz waveforms.

        Parameters
        ----------
        noisy : (B, T, 32) Tensor
        timesteps : (B,) Tensor
        waveform : (B, N) Tensor
            Raw waveforms; normalised here as :meth:`process_audio` does.

        Returns
        -------
        (B, T, 32) Tensor
        """
        if noisy.ndim != 3 or noisy.shape[-1] != self.in_channels:
            raise ValueError(f"SAID_UNet1D.predict_noise: expected noisy (B, T, {self.in_channels}), got {tuple(noisy.shape)}")
        if waveform.ndim != 2 or waveform.shape[0] != noisy.shape[0]:
            raise ValueError(f"SAID_UNet1D.predict_noise: expected waveform ({noisy.shape[0]}, N), got {tuple(waveform.shape)}")
        embedding = self.get_audio_embedding(self.process_audio(waveform), noisy.shape[1])
        return self(noisy, timesteps, embedding)


def is_official_state(state) -> bool:
    """True when ``state`` is a mapping in the authors' ``SAID_UNet1D`` layout."""
    return isinstance(state, dict) and "null_cond_emb" in state and any(k.startswith("denoiser.model.") for k in state)


def official_state_keys(feature_dim: int = -1, audio_config=None) -> list[str]:
    """The keys of an authors' ``SAID_UNet1D`` state_dict (legacy ``weight_g``/``weight_v`` names for the
    positional convolution, as in the published file)."""
    with torch.device("meta"):
        model = SAID_UNet1D(audio_config, feature_dim=feature_dim)
    return list(legacy_layout_state(model.state_dict()))


def load_official(path: str | os.PathLike, *, audio_config=None, num_head_channels: int = 32,
                  prediction_type: str = "epsilon", map_location="cpu") -> SAID_UNet1D:
    """Load the authors' ``SAiD.pth`` (or any ``SAID_UNet1D`` state_dict) strictly; return the module in eval mode.

    The UNet width, the coefficient count and the projection are read from the
    tensor shapes; the wav2vec 2.0 configuration is the base model's unless given.

    Parameters
    ----------
    path : str or os.PathLike
        ``~`` is expanded.
    audio_config : transformers.Wav2Vec2Config, optional
    num_head_channels : int, default 32
        Not recorded in the weights; the published model's value.
    prediction_type : str, default "epsilon"
    map_location : default "cpu"

    Raises
    ------
    UserError
        If the file is missing.
    DataError
        If it is not in the authors' layout, or does not match the architecture
        (names the missing and unexpected keys).
    """
    path = Path(os.fspath(path)).expanduser()
    state = load_checkpoint_file(path, where="SAiD official weights", map_location=map_location)
    if isinstance(state, dict) and "state_dict" in state and not is_official_state(state):
        state = state["state_dict"]
    if not is_official_state(state):
        raise DataError(f"SAiD official weights: expected a SAID_UNet1D state_dict (null_cond_emb, denoiser.model.*) "
                        f"in {path}")
    return model_from_state(state, audio_config=audio_config, num_head_channels=num_head_channels,
                            prediction_type=prediction_type, where=str(path))


def model_from_state(state: dict, *, audio_config=None, num_head_channels: int = 32, prediction_type: str = "epsilon",
                     where: str = "state_dict") -> SAID_UNet1D:
    """Build a :class:`SAID_UNet1D` matching ``state``'s shapes and load it strictly (see :func:`load_official`;
    :func:`~baselines.common.checkpoint.load_into`: missing, unexpected or misshapen weights are a ``DataError``)."""
    try:
        conv_in = state["denoiser.model.input_blocks.0.0.weight"]
    except KeyError as exc:
        raise DataError(f"SAiD official weights: {where} has no denoiser.model.input_blocks.0.0.weight") from exc
    proj = state.get("audio_proj_layer.weight")
    model = SAID_UNet1D(
        audio_config,
        in_channels=int(conv_in.shape[1]),
        feature_dim=int(proj.shape[0]) if proj is not None else -1,
        model_channels=int(conv_in.shape[0]),
        num_head_channels=num_head_channels,
        prediction_type=prediction_type,
    )
    load_into(model, state, where=f"SAiD official weights: {where}")
    return model.eval()
