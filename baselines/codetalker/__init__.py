"""CodeTalker (Xing et al., CVPR 2023): speech-driven facial animation with a discrete motion prior.

Stage 1 is the motion VQ-VAE (:class:`VQAutoEncoder`), stage 2 the speech-conditioned
autoregressive code query (:class:`CodeTalker`); ``load_official`` loads the authors'
released VOCASET files; the plug-in is ``baselines.codetalker.plugin:CodeTalkerMethod``.
"""

from baselines.codetalker.model import STAGE2_DEFAULTS, CodeTalker
from baselines.codetalker.official import load_official
from baselines.codetalker.vqvae import STAGE1_DEFAULTS, VQAutoEncoder

__all__ = ["STAGE1_DEFAULTS", "STAGE2_DEFAULTS", "CodeTalker", "VQAutoEncoder", "load_official"]
