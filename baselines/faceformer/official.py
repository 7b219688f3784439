"""Loading the authors' released FaceFormer checkpoint (``vocaset.pth``) offline.

The file is a plain ``state_dict`` of the authors' ``Faceformer`` including the
wav2vec 2.0 weights. Widths, period, layers and the number of training speakers are
read from the tensors' shapes; the wav2vec 2.0 architecture is the shipped base-960h
configuration unless told otherwise. Both the legacy ``weight_g``/``weight_v`` and the
current parametrization names of the positional convolution are accepted.
"""

from __future__ import annotations

import re
from pathlib import Path

import torch

from baselines.wav2vec2 import current_layout_state, legacy_layout_state

__all__ = ["checkpoint_state", "faceformer_config_from_state", "load_into", "load_official", "period_of_encoding"]


def checkpoint_state(path, *, where: str) -> dict:
    """The ``state_dict`` stored in ``path`` (a plain one, or under ``"state_dict"``), ``module.`` prefixes removed."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{where}: expected a checkpoint file, got {path} (not found)")
    payload = torch.load(path, map_location="cpu", weights_only=True)
    if isinstance(payload, dict) and isinstance(payload.get("state_dict"), dict):
        payload = payload["state_dict"]
    if not isinstance(payload, dict) or not all(isinstance(v, torch.Tensor) for v in payload.values()):
        raise ValueError(f"{where}: expected a state_dict of tensors in {path}, got {type(payload).__name__}")
    return {(k[len("module."):] if k.startswith("module.") else k): v for k, v in payload.items()}


def period_of_encoding(pe: torch.Tensor) -> int:
    """Period of a periodic positional encoding buffer ``(1, L, d)``: the first row equal to row 0."""
    rows = pe.reshape(pe.shape[-2], pe.shape[-1])
    for t in range(1, rows.shape[0]):
        if torch.equal(rows[t], rows[0]):
            return t
    return rows.shape[0]


def _count_layers(state: dict, prefix: str) -> int:
    pattern = re.compile(re.escape(prefix) + r"(\d+)\.")
    found = {int(m.group(1)) for k in state for m in [pattern.match(k)] if m}
    return max(found) + 1 if found else 0


def _require(state: dict, key: str, where: str) -> torch.Tensor:
    if key not in state:
        raise KeyError(f"{where}: expected key {key!r} in the authors' state_dict, not found "
                       f"(got {len(state)} keys, e.g. {sorted(state)[:5]})")
    return state[key]


def faceformer_config_from_state(state: dict, *, audio: dict | None = None, n_head: int = 4,
                                 dataset: str = "vocaset", where: str = "faceformer") -> dict:
    """Model config (:data:`~baselines.faceformer.model.DEFAULT_CONFIG` keys) that fits ``state``."""
    vertice_map = _require(state, "vertice_map.weight", where)
    obj = _require(state, "obj_vector.weight", where)
    pe = _require(state, "PPE.pe", where)
    period = period_of_encoding(pe)
    return {
        "dataset": dataset,
        "vertice_dim": int(vertice_map.shape[1]),
        "feature_dim": int(vertice_map.shape[0]),
        "period": period,
        "n_head": int(n_head),
        "num_layers": _count_layers(state, "transformer_decoder.layers."),
        "num_subjects": int(obj.shape[1]),
        "max_seq_len": int(pe.shape[1]) - period,
        "audio": audio or {"kind": "wav2vec2", "config": "base"},
    }


def load_into(model: torch.nn.Module, state: dict, *, where: str) -> None:
    """``model.load_state_dict(state, strict=True)`` after matching the wav2vec 2.0 layout to the model's."""
    wanted = model.state_dict()
    if any(k.endswith("parametrizations.weight.original0") for k in wanted):
        state = current_layout_state(state)
    else:
        state = legacy_layout_state(state)
    missing = sorted(set(wanted) - set(state))
    unexpected = sorted(set(state) - set(wanted))
    if missing or unexpected:
        raise ValueError(f"{where}: the state_dict does not match the authors' architecture: "
                         f"missing {missing[:8]}{'...' if len(missing) > 8 else ''} ({len(missing)}), "
                         f"unexpected {unexpected[:8]}{'...' if len(unexpected) > 8 else ''} ({len(unexpected)})")
    bad = [(k, tuple(state[k].shape), tuple(v.shape)) for k, v in wanted.items() if state[k].shape != v.shape]
    if bad:
        raise ValueError(f"{where}: shape mismatch (key, got, expected): {bad[:5]}")
    model.load_state_dict(state, strict=True)


def load_official(path, *, wav2vec2_config=None, n_head: int = 4, dataset: str = "vocaset"):
    """The authors' FaceFormer from ``vocaset.pth``, in eval mode.

    Parameters
    ----------
    path : path-like
        The released checkpoint (a plain state_dict).
    wav2vec2_config : "base", "tiny" or dict, optional
        wav2vec 2.0 architecture; default the shipped base-960h configuration.
    n_head : int, default 4
        Decoder heads (not stored in the file; the authors use 4).
    dataset : {"vocaset", "BIWI"}

    Returns
    -------
    baselines.faceformer.model.Faceformer
        ``predict(audio, template, one_hot)`` as the authors': audio ``(1, N)``
        normalised 16 kHz speech, template ``(1, V*3)``, one-hot ``(1, num_subjects)``.
    """
    from baselines.faceformer.model import Faceformer

    where = f"faceformer.load_official({path})"
    state = checkpoint_state(path, where=where)
    audio = {"kind": "wav2vec2", "config": wav2vec2_config or "base"}
    model = Faceformer(faceformer_config_from_state(state, audio=audio, n_head=n_head, dataset=dataset, where=where))
    load_into(model, state, where=where)
    return model.eval()
