"""The CDFace model: two part priors, the audio encoder and the two code querying modules.

:class:`CDFaceModel` composes the pieces; :meth:`CDFaceModel.teacher_forced` is the
training pass (ground-truth past motion, all ``N^l`` lip and ``N^l N^u`` upper-face
samples of every frame at once) and :meth:`CDFaceModel.sample` the auto-regressive
inference of any set of (lip sample, upper-face sample) pairs.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from baselines.cdface.query import AudioProjection, PartQuery, shift_right
from baselines.cdface.vqvae import PartVQVAE
from baselines.common.device import module_device
from blendvoca.errors import UserError

__all__ = ["CDFaceModel", "sample_pairs"]


def sample_pairs(num_samples: int, num_lips: int, num_upper: int, *, seed: int = 0, control: str = "none") -> list:
    """The (lip head, upper-face head) pair of each of ``num_samples`` samples.

    ``control="none"`` (diverse): the pairs ``(a, (a + m) mod N^u)`` for ``k = a + m N^l``
    visit all ``N^l N^u`` pairs before any repeats, the first ``min(N^l, N^u)`` with
    distinct lip and upper-face heads. ``control="lips"``: one lip head, the
    upper-face heads in turn. ``seed`` relabels the heads (random permutations), so
    different seeds give different samples.

    Returns
    -------
    list of ``num_samples`` (int, int)
    """
    if control not in ("none", "lips"):
        raise ValueError(f"sample_pairs: expected control 'none' or 'lips', got {control!r}")
    rng = np.random.default_rng(int(seed))
    lips, upper = rng.permutation(num_lips), rng.permutation(num_upper)
    pairs = []
    for k in range(int(num_samples)):
        if control == "lips":
            pairs.append((int(lips[0]), int(upper[k % num_upper])))
            continue
        k %= num_lips * num_upper
        a, m = k % num_lips, k // num_lips
        pairs.append((int(lips[a]), int(upper[(a + m) % num_upper])))
    return pairs


class CDFaceModel(nn.Module):
    """Trainable CDFace modules (the frozen audio feature extractor lives outside).

    Parameters
    ----------
    lip_dim, upper_dim : int
        ``3 V_l`` and ``3 V_u``.
    feature_dim : int
        Size of the frozen audio features.
    num_styles : int
        Training speakers (style tokens).
    model : dict
        The ``model`` section of :func:`baselines.cdface.presets.resolve_config`.
    """

    def __init__(self, lip_dim: int, upper_dim: int, feature_dim: int, num_styles: int, model: dict):
        super().__init__()
        m = model

        def vq(dim):
            return PartVQVAE(dim, hidden=m["vq_hidden"], layers=m["vq_layers"], heads=m["vq_heads"],
                             num_codes=m["num_codes"], code_dim=m["code_dim"], codebook_size=m["codebook_size"],
                             half_width=m["vq_half_width"], period=m["period"], dropout=m["dropout"])

        self.lip_vq, self.upper_vq = vq(lip_dim), vq(upper_dim)
        self.audio = AudioProjection(feature_dim, m["width"], layers=m["audio_layers"], heads=m["heads"],
                                     half_width=m["audio_self_half_width"], dropout=m["dropout"])
        self.style = nn.Embedding(int(num_styles), m["width"])
        common = dict(width=m["width"], layers=m["query_layers"], heads=m["heads"], self_context=m["self_context"],
                      audio_half_width=m["audio_half_width"], period=m["period"], dropout=m["dropout"])
        if m["upper_context"] not in ("ground-truth", "predicted"):
            raise UserError(f"CDFaceModel: expected upper_context 'ground-truth' or 'predicted', got {m['upper_context']!r}")
        self.upper_context = m["upper_context"]
        self.lip_query = PartQuery(lip_dim, self.lip_vq.latent_dim, m["num_lip_samples"], **common)
        self.upper_query = PartQuery(upper_dim, self.upper_vq.latent_dim, m["num_upper_samples"],
                                     context_dim=lip_dim, **common)

    @property
    def num_lip_samples(self) -> int:
        return self.lip_query.num_samples

    @property
    def num_upper_samples(self) -> int:
        return self.upper_query.num_samples

    def query_parameters(self):
        """Parameters trained in the querying stage (the part priors stay frozen)."""
        for module in (self.audio, self.style, self.lip_query, self.upper_query):
            yield from module.parameters()

    def teacher_forced(self, lips, upper, features, style, *, offset=None, first_lips=None, first_upper=None,
                       past_dropout: float = 0.0) -> dict:
        """All samples of every frame of a batch, past motion from the ground truth.

        Parameters
        ----------
        lips : (B, W, 3 V_l) Tensor; upper : (B, W, 3 V_u) Tensor
            Ground-truth part motion (model units).
        features : (B, W, F) Tensor
            Frozen audio features of the same frames.
        style : (B,) int64 Tensor
        offset : (B,) int64 Tensor, optional
            Sentence frame index of each window's first frame.
        first_lips, first_upper : (B, 3 V) Tensor, optional
            Ground truth of the frame before each window (zeros: none).
        past_dropout : float
            Probability of zeroing a frame's past motion (training only): the
            model cannot lean on the ground-truth past alone and must read the
            audio, which keeps its own auto-regressive rollout from stalling.

        Returns
        -------
        dict with ``lip_codes`` / ``lip_quantized`` (N^l, B, W, C_l), ``lips`` (N^l, B, W, 3 V_l),
        ``upper_codes`` / ``upper_quantized`` (G, N^u, B, W, C_u), ``upper`` (G, N^u, B, W, 3 V_u) with
        ``G = N^l`` (``upper_context="predicted"``) or 1 (``"ground-truth"``: the N^l groups are equal).
        """
        b, w, _ = lips.shape
        nl, nu = self.num_lip_samples, self.num_upper_samples
        offset = torch.zeros(b, dtype=torch.int64, device=lips.device) if offset is None else offset
        memory = self.audio(features)
        st = self.style(style)
        keep = torch.ones(b, w, 1, device=lips.device)
        if past_dropout > 0:
            # drawn on the CPU generator on every device: a seed drops the same frames everywhere
            keep = (torch.rand(b, w, 1) >= past_dropout).to(device=lips.device, dtype=lips.dtype)
        z_l = self.lip_query(shift_right(lips, first_lips) * keep, memory, st, offset=offset)  # (N^l, B, W, C)
        q_l, _, _ = self.lip_vq.quantized(z_l)
        x_l = self.lip_vq.decode(q_l.flatten(0, 1), offset=offset.repeat(nl)).view(nl, b, w, -1)
        if self.upper_context == "predicted":
            # each upper-face group reads the past of the lip sample it pairs with (Eq. 8)
            first = None if first_lips is None else first_lips.repeat(nl, 1)
            context = shift_right(x_l.detach().flatten(0, 1), first) * keep.repeat(nl, 1, 1)
            groups = nl
        else:
            # teacher forcing of the lip context too: every group reads the ground-truth
            # lips, so the N^l groups are equal and one is computed
            context = shift_right(lips, first_lips) * keep
            groups = 1
        past_u = (shift_right(upper, first_upper) * keep).repeat(groups, 1, 1)
        z_u = self.upper_query(past_u, memory.repeat(groups, 1, 1), st.repeat(groups, 1), context=context,
                               offset=offset.repeat(groups))  # (N^u, groups B, W, C)
        z_u = z_u.view(nu, groups, b, w, -1).transpose(0, 1)
        q_u, _, _ = self.upper_vq.quantized(z_u)
        x_u = self.upper_vq.decode(q_u.reshape(groups * nu * b, w, -1),
                                   offset=offset.repeat(groups * nu)).view(groups, nu, b, w, -1)
        return {"lip_codes": z_l, "lip_quantized": q_l, "lips": x_l,
                "upper_codes": z_u, "upper_quantized": q_u, "upper": x_u}

    @torch.no_grad()
    def sample(self, features, style: int, pairs, *, lip_codes=None, on_frame=None):
        """Auto-regressive synthesis of the samples ``pairs`` for one utterance.

        Parameters
        ----------
        features : (1, T, F) Tensor
        style : int
        pairs : list of (lip head, upper-face head)
        lip_codes : (T, C_l) Tensor, optional
            Fixed lip codes (e.g. of a reference sequence): every sample gets these
            lips and only the upper-face codes are queried.
        on_frame : callable, optional
            Called with the frame index after each frame.

        Returns
        -------
        lips : (S, T, 3 V_l) Tensor; upper : (S, T, 3 V_u) Tensor (model units), on the device of
            ``features`` (the network runs on its own device: a GPU samples for CPU callers).
        """
        home, device = features.device, module_device(self)
        features = features.to(device)
        t_total = features.shape[1]
        memory = self.audio(features)
        st = self.style(torch.as_tensor([int(style)], device=device))
        lip_heads = list(dict.fromkeys(i for i, _ in pairs)) if lip_codes is None else [0]
        stream = [lip_heads.index(i) if lip_codes is None else 0 for i, _ in pairs]
        nl, nu = len(lip_heads), len(pairs)
        dim_l, dim_u = self.lip_query.motion_dim, self.upper_query.motion_dim
        lip_past = torch.zeros(nl, t_total, dim_l, device=device)
        upper_past = torch.zeros(nu, t_total, dim_u, device=device)
        codes_l = torch.zeros(nl, t_total, self.lip_vq.latent_dim, device=device)
        if lip_codes is not None:
            codes_l[0] = torch.as_tensor(lip_codes, dtype=codes_l.dtype).to(device)
        codes_u = torch.zeros(nu, t_total, self.upper_vq.latent_dim, device=device)
        heads_l = torch.as_tensor(lip_heads, device=device)
        heads_u = torch.as_tensor([j for _, j in pairs], device=device)
        stream_t = torch.as_tensor(stream, device=device)

        def window_start(t, field):
            return 0 if field is None else max(0, t - field)

        # motion tokens of the past frames, embedded once per frame
        tok_l = torch.zeros(nl, t_total, self.lip_query.width, device=device)
        tok_l[:, 0] = self.lip_query.embed(lip_past[:, :1])[:, 0]
        tok_u = torch.zeros(nu, t_total, self.upper_query.width, device=device)
        tok_u[:, 0] = self.upper_query.embed(upper_past[:, :1], lip_past[stream_t, :1])[:, 0]
        rows_l, rows_u = torch.arange(nl, device=device), torch.arange(nu, device=device)
        for t in range(t_total):
            if lip_codes is None:
                lo = window_start(t, self.lip_query.receptive_field)
                z = self.lip_query(None, memory.expand(nl, -1, -1), st.expand(nl, -1), tokens=tok_l[:, lo:t + 1],
                                   start=lo, last=True)  # (N^l, nl, C)
                q, _, _ = self.lip_vq.quantized(z[heads_l, rows_l][:, None])
                codes_l[:, t] = q[:, 0]
            lo = window_start(t, self.upper_query.receptive_field)
            z = self.upper_query(None, memory.expand(nu, -1, -1), st.expand(nu, -1), tokens=tok_u[:, lo:t + 1],
                                 start=lo, last=True)
            q, _, _ = self.upper_vq.quantized(z[heads_u, rows_u][:, None])
            codes_u[:, t] = q[:, 0]
            if t + 1 < t_total:
                d = window_start(t, self.lip_vq.receptive_field)
                lip_past[:, t + 1] = self.lip_vq.decode(codes_l[:, d:t + 1], offset=d, last=True)
                d = window_start(t, self.upper_vq.receptive_field)
                upper_past[:, t + 1] = self.upper_vq.decode(codes_u[:, d:t + 1], offset=d, last=True)
                tok_l[:, t + 1] = self.lip_query.embed(lip_past[:, t + 1:t + 2])[:, 0]
                tok_u[:, t + 1] = self.upper_query.embed(upper_past[:, t + 1:t + 2], lip_past[stream_t, t + 1:t + 2])[:, 0]
            if on_frame is not None:
                on_frame(t)
        lips = self.lip_vq.decode(codes_l)
        upper = self.upper_vq.decode(codes_u)
        return lips[stream_t].to(home), upper.to(home)

    @torch.no_grad()
    def encode_lips(self, lips) -> torch.Tensor:
        """Quantized lip codes ``(T, C_l)`` of a reference lip motion ``(T, 3 V_l)`` (model units)."""
        lips = torch.as_tensor(lips, dtype=torch.float32).to(module_device(self))
        q, _, _ = self.lip_vq.quantized(self.lip_vq.encode(lips[None]))
        return q[0]
