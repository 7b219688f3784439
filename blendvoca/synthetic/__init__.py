"""Synthetic VOCASET: procedural speakers, formant speech and lip-synced facial motion.

``python -m blendvoca.synthetic --out DIR --speakers N --sentences M --seed S``
writes a corpus in the official VOCASET layout (or ``--layout processed``) with a
ground-truth sidecar (``synthetic.json``, ``groundtruth/<subject>/<sentence>.npz``);
``--audio-determined F`` sets the share of the speech motion that the audio and the
speaker determine and ``--oracle-samples K`` adds K conditional samples of every
sentence (``oracle/``). See ``docs/vocaset.md`` and ``docs/synthetic.md``.
"""

from blendvoca.synthetic.corpus import (DEFAULT_AUDIO_DETERMINED, DEFAULT_CORPUS, GENERATOR_VERSION, default_corpus,
                                        generate_corpus, sentence_lengths, speaker_name, synthesize_sentence)
from blendvoca.synthetic.groundtruth import read_npz

__all__ = [
    "DEFAULT_AUDIO_DETERMINED", "DEFAULT_CORPUS", "GENERATOR_VERSION", "default_corpus", "generate_corpus", "read_npz",
    "sentence_lengths", "speaker_name", "synthesize_sentence",
]
