"""VOCASET readers: the official download layout and the processed layout, one interface.

>>> corpus = open_vocaset("~/data/VOCASET")            # doctest: +SKIP
>>> corpus.frames("FaceTalk_170725_00137_TA", "sentence01").shape   # doctest: +SKIP
(T, 5023, 3)
"""

from blendvoca.vocaset.corpus import VocasetCorpus, detect_layout, open_vocaset
from blendvoca.vocaset.errors import PROBLEM_KINDS, SAFE_NAME, Problem, UnsafeNameError, VocasetError, check_safe_name
from blendvoca.vocaset.splits import (FPS, NUM_VERTICES, VOCASET_SENTENCES, VOCASET_SPLITS, VOCASET_SUBJECTS,
                                      corpus_splits, proportional_split)
from blendvoca.vocaset.write import OfficialWriter, ProcessedWriter, convert_corpus

__all__ = [
    "FPS", "NUM_VERTICES", "PROBLEM_KINDS", "VOCASET_SENTENCES", "VOCASET_SPLITS", "VOCASET_SUBJECTS",
    "OfficialWriter", "Problem", "SAFE_NAME", "UnsafeNameError", "check_safe_name", "ProcessedWriter", "VocasetCorpus",
    "VocasetError", "convert_corpus",
    "corpus_splits", "detect_layout", "open_vocaset", "proportional_split",
]
