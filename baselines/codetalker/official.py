"""Loading the authors' released CodeTalker checkpoints offline.

``vocaset_stage1.pth.tar`` is ``{"state_dict": VQ-VAE}``; ``vocaset_stage2.pth.tar`` is
``{"state_dict": ...}`` with everything else (wav2vec 2.0 included) and no
``autoencoder.`` keys. Widths are read from the tensors; head counts are not stored
(the authors': 8 in the VQ-VAE, 4 in the decoder).
"""

from __future__ import annotations

import os

from baselines.codetalker.model import CodeTalker
from baselines.codetalker.vqvae import VQAutoEncoder
from baselines.common.checkpoint import checkpoint_state, count_layers, load_into, require_key
from baselines.common.motion_decoder import decoder_config_from_state

__all__ = ["load_official", "stage1_config_from_state", "stage2_config_from_state"]


def stage1_config_from_state(state: dict, *, num_attention_heads: int = 8, where: str = "codetalker stage 1") -> dict:
    """VQ-VAE config that fits a stage-1 state dict (keys without the ``autoencoder.`` prefix)."""
    mapping = require_key(state, "encoder.vertice_mapping.0.weight", where)
    codebook = require_key(state, "quantize.embedding.weight", where)
    l1 = require_key(state, "encoder.encoder_transformer.net.1.fn.fn.l1.weight", where)
    hidden = int(mapping.shape[0])
    return {
        "in_dim": int(mapping.shape[1]),
        "hidden_size": hidden,
        "num_hidden_layers": count_layers(state, "encoder.encoder_transformer.net.") // 2,
        "num_attention_heads": int(num_attention_heads),
        "intermediate_size": int(l1.shape[0]),
        "quant_factor": 0,
        "face_quan_num": hidden // int(codebook.shape[1]),
        "INaffine": "encoder.squasher.0.2.weight" in state,
        "n_embed": int(codebook.shape[0]),
        "zquant_dim": int(codebook.shape[1]),
    }


def stage2_config_from_state(state: dict, *, audio: dict | None = None, n_head: int = 4, dataset: str = "vocaset",
                             where: str = "codetalker stage 2") -> dict:
    """Stage-2 config that fits a stage-2 state dict.

    The speakers are the rows of the style embedding ``learnable_style_emb`` ``(num_subjects, feature_dim)``.
    """
    num_subjects = int(require_key(state, "learnable_style_emb.weight", where).shape[0])
    return decoder_config_from_state(state, num_subjects=num_subjects, audio=audio, n_head=n_head, dataset=dataset,
                                     where=where)


def load_official(stage2_path: str | os.PathLike, stage1_path: str | os.PathLike, *, wav2vec2_config=None,
                  n_head: int = 4, vq_heads: int = 8, dataset: str = "vocaset"):
    """The authors' CodeTalker from their stage-2 and stage-1 files, in eval mode.

    Parameters
    ----------
    stage2_path, stage1_path : str or os.PathLike
        ``vocaset_stage2.pth.tar`` and ``vocaset_stage1.pth.tar``.
    wav2vec2_config : "base", "tiny" or dict, optional
        Default: the shipped base-960h configuration.
    n_head, vq_heads : int
        Heads of the stage-2 decoder (4) and of the VQ-VAE transformers (8).
    dataset : {"vocaset", "BIWI"}

    Returns
    -------
    baselines.codetalker.model.CodeTalker
        ``predict(audio, template, one_hot)`` as the authors'.
    """
    stage2_path, stage1_path = os.fspath(stage2_path), os.fspath(stage1_path)
    where1 = f"codetalker.load_official stage 1 ({stage1_path})"
    where2 = f"codetalker.load_official stage 2 ({stage2_path})"
    s1 = checkpoint_state(stage1_path, where=where1)
    s2 = checkpoint_state(stage2_path, where=where2)
    if any(k.startswith("autoencoder.") for k in s1):
        s1 = {k[len("autoencoder."):]: v for k, v in s1.items() if k.startswith("autoencoder.")}
    vq = VQAutoEncoder(stage1_config_from_state(s1, num_attention_heads=vq_heads, where=where1))
    load_into(vq, s1, where=where1)
    s2 = {k: v for k, v in s2.items() if not k.startswith("autoencoder.")}
    audio = {"kind": "wav2vec2", "config": wav2vec2_config or "base"}
    model = CodeTalker(stage2_config_from_state(s2, audio=audio, n_head=n_head, dataset=dataset, where=where2),
                       autoencoder=vq)
    full = {**s2, **{"autoencoder." + k: v for k, v in vq.state_dict().items()}}
    load_into(model, full, where=where2)
    return model.eval()
