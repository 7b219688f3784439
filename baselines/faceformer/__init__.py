"""FaceFormer (Fan et al., CVPR 2022): speech-driven 3D facial animation with transformers.

``Faceformer`` is the network with the authors' parameter names, ``load_official``
loads their released ``vocaset.pth``; the benchmark plug-in is
``baselines.faceformer.plugin:FaceFormerMethod`` (registered as ``faceformer``).
The parts CodeTalker reuses (speech front ends, periodic positional encoding, biased
causal decoder, training loop, vertex plug-in base) are in :mod:`baselines.common`.
"""

from baselines.faceformer.model import DEFAULT_CONFIG, Faceformer
from baselines.faceformer.official import load_official

__all__ = ["DEFAULT_CONFIG", "Faceformer", "load_official"]
