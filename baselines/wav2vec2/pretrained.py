"""wav2vec 2.0 weights from a local ``from_pretrained`` directory (e.g. ``facebook/wav2vec2-base-960h``).

Nothing is downloaded: the user puts the directory (``config.json`` and the weights)
on disk once and names it.
"""

from __future__ import annotations

import os
from pathlib import Path

from blendvoca.errors import UserError

from .config import _transformers

__all__ = ["pretrained_wav2vec2_model"]


def pretrained_wav2vec2_model(path: str | os.PathLike):
    """The ``transformers.Wav2Vec2Model`` stored in the local directory ``path`` (``~`` expanded).

    Raises
    ------
    UserError
        ``path`` holds no ``config.json``.
    """
    path = Path(os.fspath(path)).expanduser()
    if not (path / "config.json").is_file():
        raise UserError(f"wav2vec 2.0: expected a local directory with config.json at {path}; download "
                        "facebook/wav2vec2-base-960h there first (or set BLENDVOCA_WAV2VEC2)")
    return _transformers().Wav2Vec2Model.from_pretrained(str(path))
