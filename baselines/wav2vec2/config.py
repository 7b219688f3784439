"""wav2vec 2.0 configurations: the released base model's, and a tiny one for tests."""

from __future__ import annotations

__all__ = ["BASE_960H_CONFIG", "base_config", "tiny_config"]

#: ``config.json`` of ``facebook/wav2vec2-base-960h``, the encoder FaceFormer,
#: CodeTalker and SAiD build on (architecture fields only; the CTC head is unused).
BASE_960H_CONFIG = {
    "model_type": "wav2vec2",
    "vocab_size": 32,
    "hidden_size": 768,
    "num_hidden_layers": 12,
    "num_attention_heads": 12,
    "intermediate_size": 3072,
    "hidden_act": "gelu",
    "hidden_dropout": 0.1,
    "activation_dropout": 0.1,
    "attention_dropout": 0.1,
    "feat_proj_dropout": 0.1,
    "final_dropout": 0.1,
    "layerdrop": 0.1,
    "initializer_range": 0.02,
    "layer_norm_eps": 1e-5,
    "feat_extract_norm": "group",
    "feat_extract_activation": "gelu",
    "conv_dim": [512, 512, 512, 512, 512, 512, 512],
    "conv_stride": [5, 2, 2, 2, 2, 2, 2],
    "conv_kernel": [10, 3, 3, 3, 3, 2, 2],
    "conv_bias": False,
    "num_conv_pos_embeddings": 128,
    "num_conv_pos_embedding_groups": 16,
    "do_stable_layer_norm": False,
    "apply_spec_augment": True,
    "mask_time_prob": 0.05,
    "mask_time_length": 10,
    "mask_feature_prob": 0.0,
    "mask_feature_length": 10,
    "ctc_loss_reduction": "sum",
    "ctc_zero_infinity": False,
    "pad_token_id": 0,
    "bos_token_id": 1,
    "eos_token_id": 2,
}


def _transformers():
    try:
        import transformers
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("wav2vec 2.0 needs transformers: pip install transformers") from exc
    return transformers


def base_config(**overrides):
    """``transformers.Wav2Vec2Config`` of ``facebook/wav2vec2-base-960h`` (offline).

    Parameters
    ----------
    **overrides
        Config fields to change (e.g. ``num_hidden_layers`` for a smaller test copy).
    """
    return _transformers().Wav2Vec2Config(**{**BASE_960H_CONFIG, **overrides})


def tiny_config(**overrides):
    """A tiny ``Wav2Vec2Config`` (2 layers, hidden 32) with the base model's frame rate, for tests."""
    fields = dict(
        hidden_size=32,
        num_hidden_layers=2,
        num_attention_heads=2,
        intermediate_size=64,
        conv_dim=(16, 16, 16, 16, 16, 16, 16),
        num_conv_pos_embeddings=16,
        num_conv_pos_embedding_groups=4,
        do_stable_layer_norm=False,
        feat_extract_norm="group",
    )
    fields.update(overrides)
    return _transformers().Wav2Vec2Config(**fields)
