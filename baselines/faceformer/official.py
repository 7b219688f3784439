"""Loading the authors' released FaceFormer checkpoint (``vocaset.pth``) offline.

The file is a plain ``state_dict`` of the authors' ``Faceformer`` including the
wav2vec 2.0 weights. Widths, period, layers and the number of training speakers are
read from the tensors' shapes; the wav2vec 2.0 architecture is the shipped base-960h
configuration unless told otherwise. Both the legacy ``weight_g``/``weight_v`` and the
current parametrization names of the positional convolution are accepted.
"""

from __future__ import annotations

import os

from baselines.common.checkpoint import checkpoint_state, load_into, require_key
from baselines.common.motion_decoder import decoder_config_from_state
from baselines.faceformer.model import Faceformer

__all__ = ["faceformer_config_from_state", "load_official"]


def faceformer_config_from_state(state: dict, *, audio: dict | None = None, n_head: int = 4,
                                 dataset: str = "vocaset", where: str = "faceformer") -> dict:
    """Model config (:data:`~baselines.faceformer.model.DEFAULT_CONFIG` keys) that fits ``state``.

    The speakers are the inputs of the one-hot style layer ``obj_vector`` ``(feature_dim, num_subjects)``.
    """
    num_subjects = int(require_key(state, "obj_vector.weight", where).shape[1])
    return decoder_config_from_state(state, num_subjects=num_subjects, audio=audio, n_head=n_head, dataset=dataset,
                                     where=where)


def load_official(path: str | os.PathLike, *, wav2vec2_config=None, n_head: int = 4, dataset: str = "vocaset"):
    """The authors' FaceFormer from ``vocaset.pth``, in eval mode.

    Parameters
    ----------
    path : str or os.PathLike
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
    path = os.fspath(path)
    where = f"faceformer.load_official({path})"
    state = checkpoint_state(path, where=where)
    audio = {"kind": "wav2vec2", "config": wav2vec2_config or "base"}
    model = Faceformer(faceformer_config_from_state(state, audio=audio, n_head=n_head, dataset=dataset, where=where))
    load_into(model, state, where=where)
    return model.eval()
