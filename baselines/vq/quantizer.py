"""The VQ-VAE bottleneck: nearest codebook entry, straight-through gradients, VQ losses.

Semantics and parameter names follow CodeTalker's ``VectorQuantizer`` (itself the
taming-transformers / VQ-VAE formulation), so a CodeTalker stage-1 state dict loads
into it (``quantize.embedding.weight``, shape ``(n_e, e_dim)``).

Tensor layout
-------------
``forward(z)`` takes ``z`` of shape ``(B, N, e_dim)``: ``N`` vectors per batch item
(CodeTalker: ``N = frames * face_quan_num``), channels last. It returns

- ``quantized`` of shape ``(B, e_dim, N)`` (channels first, as the authors' decoder
  expects), equal in value to the nearest codebook entries and carrying the
  straight-through gradient ``d quantized / d z = identity``;
- ``loss``, the scalar ``mean((sg[z_q] - z)^2) * beta + mean((z_q - sg[z])^2)``
  (commitment term weighted by ``beta``, codebook term unweighted; ``sg`` = stop
  gradient);
- ``info = (perplexity, one_hot, indices)`` with ``one_hot`` ``(B*N, n_e)`` and
  ``indices`` ``(B*N, 1)`` int64 in row-major ``(b, n)`` order.
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["VectorQuantizer", "nearest_code_indices"]


def squared_distances(z_flat: torch.Tensor, codebook: torch.Tensor) -> torch.Tensor:
    """``||z_i - e_k||^2`` of every row of ``z_flat`` ``(M, D)`` and code of ``codebook`` ``(K, D)``: ``(M, K)``."""
    return (z_flat.pow(2).sum(dim=1, keepdim=True) + codebook.pow(2).sum(dim=1)
            - 2.0 * z_flat @ codebook.t())


def nearest_code_indices(z_flat: torch.Tensor, codebook: torch.Tensor) -> torch.Tensor:
    """Index of the nearest codebook entry (:func:`squared_distances`) of each row: ``(M,) int64``."""
    return torch.argmin(squared_distances(z_flat, codebook), dim=1)


class VectorQuantizer(nn.Module):
    """Codebook of ``n_e`` vectors of size ``e_dim`` with commitment cost ``beta``.

    Parameters
    ----------
    n_e : int
        Number of codebook entries.
    e_dim : int
        Size of each entry.
    beta : float
        Weight of the commitment loss ``||z - sg[e]||^2``.

    Attributes
    ----------
    embedding : nn.Embedding
        The codebook, ``embedding.weight`` of shape ``(n_e, e_dim)``, initialised
        uniformly in ``[-1/n_e, 1/n_e]``.
    """

    def __init__(self, n_e: int, e_dim: int, beta: float = 0.25):
        super().__init__()
        if n_e < 1 or e_dim < 1:
            raise ValueError(f"VectorQuantizer: expected n_e >= 1 and e_dim >= 1, got n_e={n_e}, e_dim={e_dim}")
        self.n_e = int(n_e)
        self.e_dim = int(e_dim)
        self.beta = float(beta)
        self.embedding = nn.Embedding(self.n_e, self.e_dim)
        with torch.no_grad():
            self.embedding.weight.uniform_(-1.0 / self.n_e, 1.0 / self.n_e)

    def _flat(self, z: torch.Tensor, where: str) -> torch.Tensor:
        if z.ndim != 3 or z.shape[-1] != self.e_dim:
            raise ValueError(f"VectorQuantizer.{where}: expected z of shape (B, N, {self.e_dim}), got {tuple(z.shape)}")
        return z.reshape(-1, self.e_dim)

    def forward(self, z: torch.Tensor):
        """Quantize ``z``.

        Parameters
        ----------
        z : (B, N, e_dim) Tensor

        Returns
        -------
        quantized : (B, e_dim, N) Tensor
            Nearest codes, straight-through gradient to ``z``.
        loss : scalar Tensor
            ``beta * commitment + codebook`` loss.
        info : tuple
            ``(perplexity, one_hot (B*N, n_e), indices (B*N, 1))``.

        Inside a mixed-precision training step on a GPU (autocast on) the search runs in
        float32 with autocast off: in bf16 it picks wrong codes.
        """
        if not (z.is_cuda and torch.is_autocast_enabled("cuda")):
            return self._quantized(z)
        with torch.autocast(device_type="cuda", enabled=False):
            return self._quantized(z.float())

    def _quantized(self, z: torch.Tensor):
        z_flat = self._flat(z, "forward")
        indices = nearest_code_indices(z_flat, self.embedding.weight).unsqueeze(1)
        one_hot = torch.zeros(indices.shape[0], self.n_e, dtype=z.dtype, device=z.device)
        one_hot.scatter_(1, indices, 1)
        z_q = (one_hot @ self.embedding.weight).view(z.shape)
        loss = self.beta * torch.mean((z_q.detach() - z) ** 2) + torch.mean((z_q - z.detach()) ** 2)
        z_q = z + (z_q - z).detach()
        usage = one_hot.mean(dim=0)
        perplexity = torch.exp(-torch.sum(usage * torch.log(usage + 1e-10)))
        return z_q.permute(0, 2, 1).contiguous(), loss, (perplexity, one_hot, indices)

    def get_distance(self, z: torch.Tensor) -> torch.Tensor:
        """Squared distances to every code, channels-first like the authors'.

        Parameters
        ----------
        z : (B, e_dim, N) Tensor

        Returns
        -------
        (B, n_e, N) Tensor
        """
        z = z.permute(0, 2, 1).contiguous()
        d = squared_distances(self._flat(z, "get_distance"), self.embedding.weight)
        return d.reshape(z.shape[0], z.shape[1], self.n_e).permute(0, 2, 1).contiguous()

    def get_codebook_entry(self, indices: torch.Tensor, shape=None) -> torch.Tensor:
        """Codebook vectors of ``indices``.

        Parameters
        ----------
        indices : (M,) int Tensor
        shape : tuple or None
            Shape to view the ``(M, e_dim)`` result as.

        Returns
        -------
        (M, e_dim) Tensor, or ``shape``
        """
        indices = indices.reshape(-1).long()
        if indices.numel() and (int(indices.min()) < 0 or int(indices.max()) >= self.n_e):
            raise IndexError(f"VectorQuantizer.get_codebook_entry: indices must lie in [0, {self.n_e}), "
                             f"got [{int(indices.min())}, {int(indices.max())}]")
        z_q = self.embedding.weight[indices]
        return z_q.view(shape) if shape is not None else z_q
