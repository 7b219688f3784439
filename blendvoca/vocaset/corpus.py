"""``open_vocaset``: open a VOCASET corpus in either layout, detected from its files."""

from __future__ import annotations

import os
from pathlib import Path

from blendvoca.errors import UserError
from blendvoca.vocaset.base import SIDECAR, VocasetCorpus
from blendvoca.vocaset.official import OfficialVocaset
from blendvoca.vocaset.processed import ProcessedVocaset
from blendvoca.vocaset.splits import NUM_VERTICES

__all__ = ["SIDECAR", "VocasetCorpus", "detect_layout", "open_vocaset"]


def detect_layout(root) -> str:
    """``"processed"`` (data_verts.npy + pickles) or ``"official"`` (per-frame PLY folders).

    Parameters
    ----------
    root : str or os.PathLike
        The corpus folder.

    Raises
    ------
    FileNotFoundError
        ``root`` does not exist (an ``OSError``: command-line tools report it as one line, exit 2).
    UserError
        ``root`` exists but holds neither layout.
    """
    root = Path(os.fspath(root))
    if not root.is_dir():
        raise FileNotFoundError(f"VOCASET root not found: {root}")
    if (root / "data_verts.npy").is_file() or (root / "subj_seq_to_idx.pkl").is_file():
        return "processed"
    if (root / "unposedcleaneddata").is_dir() or (root / "templates").is_dir():
        return "official"
    raise UserError(
        f"{root}: not a VOCASET folder. Expected either the official download layout "
        "(templates/<subject>.ply, unposedcleaneddata/<subject>/sentenceNN/sentenceNN.NNNNNN.ply, "
        "audio/<subject>/sentenceNN.wav) or the processed layout (data_verts.npy, subj_seq_to_idx.pkl, "
        f"raw_audio_fixed.pkl, templates.pkl); found {sorted(p.name for p in root.iterdir())[:10]}"
    )


def open_vocaset(root, *, num_vertices: int = NUM_VERTICES) -> VocasetCorpus:
    """Open a VOCASET corpus in either layout (auto-detected).

    Parameters
    ----------
    root : str or os.PathLike
        The folder of the official download (``templates/``,
        ``unposedcleaneddata/``, ``audio/``) or of the processed files
        (``data_verts.npy``, ``subj_seq_to_idx.pkl``, ``raw_audio_fixed.pkl``,
        ``templates.pkl``).
    num_vertices : int
        Expected vertices per mesh (FLAME: 5023).

    Returns
    -------
    VocasetCorpus
        With ``subjects``, ``sentences(subject)``, ``template(subject) -> (V, 3)``,
        ``frames(subject, sentence) -> (T, V, 3)`` float64 at 60 fps,
        ``audio(subject, sentence) -> (samples float32, rate)`` at the native rate,
        ``splits``, ``faces``, ``problems`` and ``scan()``.
    """
    reader = ProcessedVocaset if detect_layout(root) == "processed" else OfficialVocaset
    return reader(root, num_vertices=num_vertices)
