"""Log-mel spectrogram encoder: speech features with no pretrained weights."""

from __future__ import annotations

import torch
from torch import nn

from baselines.common.encoders.interpolate import interpolate_features
from baselines.common.mel import mel_filterbank

__all__ = ["LogMelEncoder", "log_mel_spectrogram", "mel_filterbank"]


def log_mel_spectrogram(
    audio: torch.Tensor,
    filters: torch.Tensor,
    *,
    n_fft: int = 400,
    hop_length: int = 160,
    window: torch.Tensor | None = None,
    top_db: float = 80.0,
) -> torch.Tensor:
    """Return a gain-normalised log-mel spectrogram in ``[-1, 1]``.

    Power mel energies in dB relative to each utterance's maximum, floored at
    ``-top_db``, then mapped affinely from ``[-top_db, 0]`` to ``[-1, 1]``: a change of
    recording gain leaves the features unchanged.

    Parameters
    ----------
    audio : (B, N) Tensor
        Mono waveforms at the filters' sample rate.
    filters : (n_mels, n_fft // 2 + 1) Tensor
    n_fft, hop_length : int
        Defaults: 25 ms window, 10 ms hop at 16 kHz (100 frames per second).
    window : (n_fft,) Tensor, optional
        Defaults to a Hann window.
    top_db : float, default 80.0

    Returns
    -------
    features : (B, 1 + N // hop_length, n_mels) Tensor
    """
    if audio.ndim != 2:
        raise ValueError(f"log_mel_spectrogram: expected (B, N) audio, got shape {tuple(audio.shape)}")
    if window is None:
        window = torch.hann_window(n_fft, dtype=audio.dtype, device=audio.device)
    spec = torch.stft(audio, n_fft=n_fft, hop_length=hop_length, window=window, center=True, return_complex=True)
    power = spec.real**2 + spec.imag**2  # (B, F, frames)
    mel = torch.einsum("mf,bft->btm", filters.to(power.dtype), power)
    db = 10.0 * torch.log10(mel.clamp(min=1e-10))
    db = db - db.amax(dim=(1, 2), keepdim=True)
    return db.clamp(min=-top_db) / (top_db / 2) + 1.0


class LogMelEncoder(nn.Module):
    """Frozen log-mel speech encoder (no pretrained weights), resampled to the frame count.

    Parameters
    ----------
    n_mels : int, default 80
    n_fft : int, default 400
    hop_length : int, default 160
    sample_rate : int, default 16000
    top_db : float, default 80.0
    """

    def __init__(self, n_mels: int = 80, n_fft: int = 400, hop_length: int = 160, sample_rate: int = 16000, top_db: float = 80.0):
        super().__init__()
        self.n_fft, self.hop_length, self.top_db = int(n_fft), int(hop_length), float(top_db)
        self.sample_rate = int(sample_rate)
        self.feature_dim = int(n_mels)
        filters = torch.from_numpy(mel_filterbank(n_fft, n_mels, sample_rate)).float()
        self.register_buffer("filters", filters, persistent=False)
        self.register_buffer("window", torch.hann_window(n_fft), persistent=False)

    def forward(self, audio: torch.Tensor, num_frames: int) -> torch.Tensor:
        """Return features ``(B, num_frames, n_mels)`` for audio ``(B, N)``."""
        if audio.shape[-1] < self.n_fft // 2 + 1:
            # stft's reflect padding needs at least n_fft/2 + 1 samples
            pad = self.n_fft // 2 + 1 - audio.shape[-1]
            audio = torch.nn.functional.pad(audio, (0, pad))
        feats = log_mel_spectrogram(
            audio, self.filters, n_fft=self.n_fft, hop_length=self.hop_length, window=self.window.to(audio.dtype), top_db=self.top_db
        )
        return interpolate_features(feats, num_frames)


