"""Synthetic VOCASET: procedural speakers, formant speech and lip-synced facial motion.

``python -m blendvoca.synthetic --out DIR --speakers N --sentences M --seed S``
writes a corpus in the official VOCASET layout (or ``--layout processed``) with a
ground-truth sidecar (``synthetic.json``, ``groundtruth/<subject>/<sentence>.npz``).
See ``docs/vocaset.md``.
"""

from blendvoca.synthetic.corpus import (
    DEFAULT_CORPUS,
    GENERATOR_VERSION,
    default_corpus,
    generate_corpus,
    sentence_lengths,
    speaker_name,
    synthesize_sentence,
)
from blendvoca.synthetic.groundtruth import read_npz

__all__ = [
    "DEFAULT_CORPUS", "GENERATOR_VERSION", "default_corpus", "generate_corpus", "read_npz",
    "sentence_lengths", "speaker_name", "synthesize_sentence",
]
