"""The BlendVOCA build: ``python -m blendvoca.build [--vocaset DIR] [--out DIR]``.

:func:`build_dataset` runs rig construction for every speaker and the
coefficient fit for every sentence (in parallel, resumable, atomic writes) and
writes a BlendVOCA folder: SAiD's layout plus ``rigs/``, ``splits.json``,
``manifest.json`` and ``report/``, named and formatted by :mod:`blendvoca.format`.
It refuses bad arguments and unusable output folders before any work
(:class:`BuildInputError`, ``blendvoca.errors.OutputDirError``). See ``docs/build.md``.
"""

from .pipeline import BuildInputError, BuildSummary, WorkerStartError, build_dataset, default_output_dir
from .report import coeffs_std
from .sentence import lip_aperture, sentence_fit
from .speaker import head_faces, speaker_rig

__all__ = ["BuildInputError", "BuildSummary", "WorkerStartError", "build_dataset", "coeffs_std", "default_output_dir",
           "head_faces", "lip_aperture", "sentence_fit", "speaker_rig"]
