"""The network: 1-D CNN over time on log-mel frames -> bidirectional GRU -> sigmoid coefficients."""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["AudioToCoefficients"]


class AudioToCoefficients(nn.Module):
    """Log-mel frames to blendshape coefficients in (0, 1).

    Parameters
    ----------
    n_mels : int
        Mel bands of the input (the convolutions' input channels).
    num_coeffs : int
        Output coefficients (32).
    channels : int
        Channels of the two temporal convolutions (kernel 5, about 83 ms each at 60 fps).
    hidden : int
        GRU hidden size per direction.

    Notes
    -----
    Input ``(B, T, n_mels)``, output ``(B, T, num_coeffs)``. end2end_AU_speech uses
    2-D convolutions over (frequency, time); a 1-D convolution with the mel bands
    as channels has the same receptive field in time at a fraction of the CPU cost,
    which is what keeps training within minutes on two cores.
    """

    def __init__(self, n_mels: int = 40, num_coeffs: int = 32, channels: int = 64, hidden: int = 64):
        super().__init__()
        self.cnn = nn.Sequential(
            nn.Conv1d(n_mels, channels, 5, padding=2), nn.BatchNorm1d(channels), nn.ReLU(),
            nn.Conv1d(channels, channels, 5, padding=2), nn.BatchNorm1d(channels), nn.ReLU(),
        )
        self.gru = nn.GRU(channels, hidden, batch_first=True, bidirectional=True)
        self.head = nn.Linear(2 * hidden, num_coeffs)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        """``(B, T, K)`` coefficients in (0, 1) of ``(B, T, n_mels)`` features, on the device of
        ``features`` (which move to the network's first: a GPU network serves CPU callers)."""
        home, device = features.device, self.head.weight.device
        x = self.cnn(features.to(device).transpose(1, 2))  # (B, C, T)
        x, _ = self.gru(x.transpose(1, 2))  # (B, T, 2H)
        return torch.sigmoid(self.head(x)).to(home)
