"""The oracle samples of a synthetic corpus, as meshes.

A corpus generated with ``--oracle-samples K`` stores, per sentence, K
conditional samples of its motion (``oracle/<subject>/<sentence>.npz``): the
driving signals of fresh draws of everything the audio and the speaker do not
fix. They are stored as signals (a few kB) rather than meshes (14 MB a
sample); :class:`OracleSamples` turns them into the meshes the generator
would have written, with the generator's own face model on the speaker's own
neutral and regions, rounded to float32 as the corpus's frames are. The build
(:mod:`blendvoca.builder`) fits them like the ground truth.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np

from blendvoca.assets import load_index_list, resolve
from blendvoca.errors import DataError
from blendvoca.io.mesh import read_ply
from blendvoca.synthetic.corpus import _SPEAKER, ORACLE_DIR, speaker_name
from blendvoca.synthetic.groundtruth import read_npz
from blendvoca.synthetic.identity import speaker_neutral
from blendvoca.synthetic.motion import animate_face
from blendvoca.synthetic.regions import face_regions
from blendvoca.vocaset.base import SIDECAR, read_sidecar

_SUBJECT = re.compile(r"^Synth_(\d{3,})_TA$")


def oracle_count(meta: dict | None) -> int:
    """K, the oracle samples per sentence a sidecar (``synthetic.json``) declares (0: none or not synthetic)."""
    if not isinstance(meta, dict):
        return 0
    oracle = meta.get("oracle_samples")
    if not isinstance(oracle, dict):
        return 0
    count = oracle.get("count")
    return int(count) if isinstance(count, int) and not isinstance(count, bool) and count > 0 else 0


class OracleSamples:
    """Render the oracle samples of the synthetic corpus at ``root``.

    Parameters
    ----------
    root : path
        The corpus (its ``synthetic.json`` and ``oracle/``).
    meta : dict, optional
        Its parsed ``synthetic.json`` (read from ``root`` when not given).
    """

    def __init__(self, root, meta: dict | None = None):
        self.root = Path(root)
        self.meta = read_sidecar(self.root / SIDECAR) if meta is None else meta
        self.count = oracle_count(self.meta)
        if not self.count:
            raise DataError(f"{self.root}: the corpus has no oracle samples (generate it with --oracle-samples K)")
        self.seed = int(self.meta["seed"])

    def path(self, subject: str, sentence: str) -> Path:
        """``<root>/oracle/<subject>/<sentence>.npz``."""
        return self.root / ORACLE_DIR / subject / f"{sentence}.npz"

    def arrays(self, subject: str, sentence: str) -> dict[str, np.ndarray]:
        """The stored draws of a sentence (signals ``(K, T)``, ``lag_frames (K,)``, ...)."""
        path = self.path(subject, sentence)
        if not path.is_file():
            raise DataError(f"{path}: missing; the corpus declares {self.count} oracle samples per sentence")
        return read_npz(path)

    @functools.cache  # noqa: B019 - one speaker at a time is typical; a handful at most
    def speaker(self, subject: str):
        """``(neutral (V, 3) float64, regions, faces)`` of a synthetic speaker, recomputed from the seed."""
        match = _SUBJECT.match(subject)
        if not match or speaker_name(int(match.group(1))) != subject:
            raise DataError(f"{self.root}: {subject!r} is not a synthetic speaker name (Synth_NNN_TA)")
        template, faces = read_ply(resolve("flame-sample"))
        neutral = speaker_neutral(template, np.random.default_rng([self.seed, _SPEAKER, int(match.group(1))]))
        regions = face_regions(neutral, faces, load_index_list("flame-landmarks"))
        return neutral, regions, faces

    def asymmetry(self, subject: str) -> float:
        style = self.meta.get("subjects", {}).get(subject, {}).get("style")
        return float(style["asymmetry"]) if isinstance(style, dict) else 0.0

    def frames(self, subject: str, sentence: str, *, template: np.ndarray | None = None):
        """Yield the K samples' frames ``(T, V, 3) float32``, in sample order.

        Parameters
        ----------
        template : (V, 3) ndarray, optional
            The corpus's neutral of the speaker: checked against the recomputed
            one (a different ``flame-sample`` asset would render other meshes).
        """
        neutral, regions, _ = self.speaker(subject)
        if template is not None and (np.shape(template) != neutral.shape
                                     or np.abs(np.asarray(template) - neutral).max() > 1e-6):
            raise DataError(f"{self.root}: the neutral of {subject} recomputed from the seed differs from the "
                            "corpus's template (another flame-sample asset?); its oracle samples cannot be rendered")
        arrays = self.arrays(subject, sentence)
        names = [k for k in ("jaw", "round", "closure", "labiodental", "blink", "brow",
                             "smile", "corner_left", "corner_right", "press") if k in arrays]
        if any(arrays[k].ndim != 2 or arrays[k].shape[0] != self.count for k in names):
            raise DataError(f"{self.path(subject, sentence)}: expected ({self.count}, T) signals")
        asymmetry = self.asymmetry(subject)
        for k in range(self.count):
            signals = {name: arrays[name][k] for name in names}
            frames = animate_face(neutral, regions, signals, asymmetry=asymmetry) if len(names) > 6 or asymmetry \
                else animate_face(neutral, regions, signals)
            yield frames.astype(np.float32)
