"""wav2vec 2.0 state-dict layouts across transformers versions.

Checkpoints saved with older torch/transformers (the released FaceFormer,
CodeTalker and SAiD files) store the weight-normed positional convolution as
``encoder.pos_conv_embed.conv.weight_g`` / ``weight_v``; current versions use
``torch.nn.utils.parametrizations.weight_norm`` and name the same tensors
``...conv.parametrizations.weight.original0`` / ``original1`` (g and v, same
shapes). ``masked_spec_embed`` exists only when spec augment was configured.
"""

from __future__ import annotations

from .config import _transformers, base_config

__all__ = ["current_layout_state", "legacy_layout_state", "wav2vec2_model"]

_LEGACY = ("pos_conv_embed.conv.weight_g", "pos_conv_embed.conv.weight_v")
_CURRENT = ("pos_conv_embed.conv.parametrizations.weight.original0",
            "pos_conv_embed.conv.parametrizations.weight.original1")


def _renamed(state, old: tuple, new: tuple) -> dict:
    out = {}
    for key, value in state.items():
        for o, n in zip(old, new):
            if key.endswith(o):
                key = key[: -len(o)] + n
                break
        out[key] = value
    return out


def current_layout_state(state) -> dict:
    """``state`` with legacy ``weight_g``/``weight_v`` keys renamed to the current parametrization names."""
    return _renamed(state, _LEGACY, _CURRENT)


def legacy_layout_state(state) -> dict:
    """``state`` with current parametrization keys renamed to the legacy ``weight_g``/``weight_v`` names
    (the layout of files written by older torch/transformers)."""
    return _renamed(state, _CURRENT, _LEGACY)


def wav2vec2_model(config=None):
    """A randomly initialised ``transformers.Wav2Vec2Model`` (base-960h config by default), built offline.

    The attention implementation is the eager one, which every transformers version
    has and which returns the same values as the authors' forward passes.
    """
    config = base_config() if config is None else config
    try:
        config._attn_implementation = "eager"
    except AttributeError:  # pragma: no cover - very old transformers
        pass
    return _transformers().Wav2Vec2Model(config)
