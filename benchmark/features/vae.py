"""The BlendVOCA VAE feature extractor over coefficient windows.

The architecture is the one of the published checkpoint (asset ``said-vae``): a
1-D convolutional encoder over windows of 120 frames x 32 coefficients to a 64-d
Gaussian latent, and a mirrored decoder. Module and parameter names follow the
checkpoint's state_dict keys (``encoder.conv_layers.0.weight`` ...) so that it
loads with ``strict=True``; the layer widths were read off the checkpoint itself
(convolutions 32-32-64-64-32, fully connected 1760-256-128-64).
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike

import numpy as np
import torch
from torch import nn

from blendvoca.assets import resolve
from blendvoca.errors import DataError, UserError
from blendvoca.io.torch_file import read_torch_file

WINDOW = 120
CHANNELS = 32
LATENT = 64


def _flat_size(seq_len: int) -> int:
    # conv k3 -> k3 -> k4 s2 -> k3, no padding, last conv has 32 channels
    n = seq_len - 2
    n = n - 2
    n = (n - 4) // 2 + 1
    n = n - 2
    return 32 * n


class Encoder(nn.Module):
    """Window encoder: (B, T, C) coefficients -> latent mean and log-variance (B, Z)."""

    def __init__(self, channels: int = CHANNELS, seq_len: int = WINDOW, latent: int = LATENT):
        super().__init__()
        self.conv_layers = nn.Sequential(
            nn.Conv1d(channels, 32, kernel_size=3),
            nn.BatchNorm1d(32),
            nn.LeakyReLU(0.2),
            nn.Conv1d(32, 64, kernel_size=3),
            nn.BatchNorm1d(64),
            nn.LeakyReLU(0.2),
            nn.Conv1d(64, 64, kernel_size=4, stride=2),
            nn.BatchNorm1d(64),
            nn.LeakyReLU(0.2),
            nn.Conv1d(64, 32, kernel_size=3),
            nn.Flatten(),
        )
        self.fc_layers = nn.Sequential(
            nn.Linear(_flat_size(seq_len), 256),
            nn.BatchNorm1d(256),
            nn.LeakyReLU(),
            nn.Linear(256, 128),
            nn.BatchNorm1d(128),
            nn.LeakyReLU(),
            nn.Linear(128, latent),
        )
        self.fc_mu = nn.Linear(latent, latent)
        self.fc_logvar = nn.Linear(latent, latent)

    def forward(self, coeffs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        hidden = self.fc_layers(self.conv_layers(coeffs.transpose(1, 2)))
        return self.fc_mu(hidden), self.fc_logvar(hidden)


class Decoder(nn.Module):
    """Latent (B, Z) -> reconstructed window (B, T, C), values in [0, 1)."""

    def __init__(self, channels: int = CHANNELS, seq_len: int = WINDOW, latent: int = LATENT):
        super().__init__()
        self.fc_layers = nn.Sequential(
            nn.Linear(latent, 2 * seq_len),
            nn.BatchNorm1d(2 * seq_len),
            nn.LeakyReLU(),
            nn.Linear(2 * seq_len, 4 * seq_len),
            nn.Unflatten(1, (4, seq_len)),
        )
        self.conv_layers = nn.Sequential(
            nn.ConvTranspose1d(4, 32, kernel_size=3),
            nn.BatchNorm1d(32),
            nn.LeakyReLU(0.2),
            nn.ConvTranspose1d(32, 32, kernel_size=3),
            nn.BatchNorm1d(32),
            nn.LeakyReLU(0.2),
            nn.Conv1d(32, 32, kernel_size=3),
            nn.Conv1d(32, channels, kernel_size=3),
            # parameter-free output head: coefficients live in [0, 1]
            nn.ReLU(),
            nn.Tanh(),
        )

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.conv_layers(self.fc_layers(latent)).transpose(1, 2)


class CoeffsVAE(nn.Module):
    """VAE over coefficient windows, the BlendVOCA feature extractor.

    Parameters
    ----------
    channels : int
        Coefficients per frame (32).
    seq_len : int
        Window length in frames (120 at 60 fps).
    latent : int
        Latent dimension (64).
    """

    def __init__(self, channels: int = CHANNELS, seq_len: int = WINDOW, latent: int = LATENT):
        super().__init__()
        self.channels = channels
        self.seq_len = seq_len
        self.latent = latent
        self.encoder = Encoder(channels, seq_len, latent)
        self.decoder = Decoder(channels, seq_len, latent)

    def _check(self, coeffs: torch.Tensor) -> torch.Tensor:
        if not isinstance(coeffs, torch.Tensor):
            coeffs = torch.as_tensor(np.asarray(coeffs))
        if coeffs.ndim != 3 or tuple(coeffs.shape[1:]) != (self.seq_len, self.channels):
            raise UserError(
                f"CoeffsVAE: expected coeffs of shape (B, {self.seq_len}, {self.channels}), "
                f"got {tuple(coeffs.shape)}"
            )
        param = next(self.parameters())
        return coeffs.to(dtype=param.dtype, device=param.device)

    def encode_stats(self, coeffs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent mean and log-variance, each (B, Z), of windows (B, T, C)."""
        return self.encoder(self._check(coeffs))

    def encode(self, coeffs: torch.Tensor) -> torch.Tensor:
        """Latent mean (B, Z) of windows (B, T, C): the feature of every metric."""
        return self.encode_stats(coeffs)[0]

    def decode(self, latent: torch.Tensor) -> torch.Tensor:
        """Reconstructed windows (B, T, C) from latents (B, Z)."""
        return self.decoder(latent)

    def forward(self, coeffs: torch.Tensor, sample: bool = True):
        """Mean, log-variance, latent used and reconstruction of windows (B, T, C)."""
        mean, log_var = self.encode_stats(coeffs)
        if sample:
            latent = mean + torch.exp(0.5 * log_var) * torch.randn_like(mean)
        else:
            latent = mean
        return mean, log_var, latent, self.decode(latent)


class VaeWeightsError(DataError, RuntimeError):
    """Weights that are not a BlendVOCA VAE's state_dict: a missing key, a shape that does
    not fit, or a file torch cannot read (a :class:`~blendvoca.errors.DataError`, exit 2
    on the command line; also a ``RuntimeError``, as ``load_state_dict``'s own error)."""


def load_vae_state(state: Mapping[str, torch.Tensor]) -> CoeffsVAE:
    """A :class:`CoeffsVAE` in eval mode holding ``state`` (strict key/shape match).

    Raises
    ------
    TypeError
        ``state`` is not a mapping.
    VaeWeightsError
        A key is missing or a tensor's shape does not fit the model.
    """
    if not isinstance(state, Mapping):
        raise TypeError(f"load_vae_state: expected a state_dict mapping, got {type(state).__name__}")
    try:
        latent = int(state["encoder.fc_mu.weight"].shape[0])
        channels = int(state["encoder.conv_layers.0.weight"].shape[1])
        seq_len = int(state["decoder.fc_layers.0.weight"].shape[0]) // 2
    except KeyError as err:
        raise VaeWeightsError(f"load_vae_state: state_dict lacks the key {err}; not a BlendVOCA VAE") from err
    model = CoeffsVAE(channels=channels, seq_len=seq_len, latent=latent)
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as err:  # torch's message lists the missing, unexpected and mismatched keys
        raise VaeWeightsError(f"load_vae_state: not a BlendVOCA VAE state_dict: {err}") from None
    return model.eval()


def load_published_vae(path: str | PathLike | None = None) -> CoeffsVAE:
    """Load the published BlendVOCA VAE checkpoint.

    Parameters
    ----------
    path : path-like, optional
        ``vae.pth`` (a state_dict). Default: the asset ``said-vae``.

    Returns
    -------
    CoeffsVAE
        In eval mode; ``encode(coeffs (B, 120, 32)) -> mean (B, 64)``.
    """
    if path is None:
        path = resolve("said-vae")
    state = read_torch_file(path, where="load_published_vae", error=VaeWeightsError)
    if not isinstance(state, Mapping):
        raise VaeWeightsError(f"load_published_vae: {path} holds a {type(state).__name__}, expected a state_dict")
    if "state_dict" in state and "encoder.fc_mu.weight" not in state:
        state = state["state_dict"]
    return load_vae_state(state)


def encode_windows(extractor, windows: np.ndarray, batch_size: int = 512) -> np.ndarray:
    """Features of coefficient windows through any extractor.

    Parameters
    ----------
    extractor : object with ``encode(torch.Tensor (B, T, C)) -> (B, D)``, or a callable
        over numpy arrays ``(B, T, C) -> (B, D)``.
    windows : (N, T, C) ndarray
    batch_size : int

    Returns
    -------
    (N, D) float64 ndarray
    """
    windows = np.asarray(windows)
    if windows.ndim != 3:
        raise UserError(f"encode_windows: expected windows (N, T, C), got shape {windows.shape}")
    if windows.shape[0] == 0:
        raise UserError("encode_windows: no windows to encode")
    out = []
    if hasattr(extractor, "encode") and isinstance(extractor, nn.Module):
        was_training = extractor.training
        extractor.eval()
        try:
            with torch.no_grad():
                for start in range(0, len(windows), batch_size):
                    batch = torch.as_tensor(windows[start : start + batch_size], dtype=torch.float32)
                    out.append(extractor.encode(batch).detach().cpu().double().numpy())
        finally:
            extractor.train(was_training)
    elif hasattr(extractor, "encode") or callable(extractor):
        encode = extractor.encode if hasattr(extractor, "encode") else extractor
        for start in range(0, len(windows), batch_size):
            out.append(np.asarray(encode(windows[start : start + batch_size]), dtype=np.float64))
    else:
        raise TypeError(
            f"encode_windows: expected an extractor with encode() or a callable, got {type(extractor).__name__}"
        )
    return np.concatenate(out, axis=0)
