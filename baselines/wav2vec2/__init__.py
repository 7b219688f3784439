"""wav2vec 2.0 for the baselines that use it (SAiD, FaceFormer, CodeTalker, CDFace).

One place for: the ``facebook/wav2vec2-base-960h`` configuration (shipped, so the
authors' checkpoints load offline), a tiny configuration for tests, the state-dict
layouts of old and new transformers versions, the pretrained weights of a local
directory, and the feature pass with the interpolation to the motion frame rate that
these methods insert after the CNN.
"""

from .config import BASE_960H_CONFIG, base_config, tiny_config
from .features import interpolated_features, linear_interpolation, projected_features
from .pretrained import pretrained_wav2vec2_model
from .state_dict import current_layout_state, legacy_layout_state, wav2vec2_model

__all__ = [
    "BASE_960H_CONFIG",
    "base_config",
    "current_layout_state",
    "interpolated_features",
    "legacy_layout_state",
    "linear_interpolation",
    "pretrained_wav2vec2_model",
    "projected_features",
    "tiny_config",
    "wav2vec2_model",
]
