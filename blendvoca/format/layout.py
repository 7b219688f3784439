"""Names and paths of a BlendVOCA folder: the one module that spells them.

A BlendVOCA folder is SAiD's layout plus BlendVOCA's additions::

    blendshape_coeffs/<subject>/<sentence>.csv       ground truth, 60 fps, one column per blendshape
    blendshape_coeffs/<subject>/<sentence>-<k>.csv   optional extra samples k = 0, 1, ...
    oracle_coeffs/<subject>/<sentence>-<k>.csv       synthetic corpora: fitted oracle sample k = 0, 1, ...
    audio/<subject>/<sentence>.wav                   mono speech at 16 kHz
    pose/<subject>/<sentence>.csv                    optional: the capture's head and eye rotations, 60 fps
    rigs/<subject>.npz                               the speaker's full-topology rig (blendvoca.rig.Rig)
    templates_head/<subject>.obj                     the neutral head (SAiD's layout)
    blendshapes_head/<subject>/<name>.obj            each blendshape's head (SAiD's layout)
    coeffs_std.csv                                   per-blendshape standard deviation (SAiD's asset)
    blendshape_residuals.pickle                      per-speaker blendshape offsets (SAiD's training)
    splits.json                                      {"train": [...], "val": [...], "test": [...]}
    manifest.json                                    the files that make up the dataset, with their sha256
    report/                                          the build report (not part of the data's identity)
    .buildstate/                                     the build's own stage records (never listed)

Every other module takes these names from here. Two spellings of each item are
given: ``*_relpath(...)``, the ``/``-separated path relative to the folder, which is
how ``manifest.json`` lists a file; and ``*_path(root, ...)``, the
:class:`~pathlib.Path` of the file under ``root``. The ``listed_*`` functions read
the dataset's structure (subjects, sentences, samples) off a manifest's listing.
"""

from __future__ import annotations

import re
from pathlib import Path

from blendvoca.names import LIVELINK_ROTATION_COLUMNS

__all__ = [
    "AUDIO_DIR",
    "AUDIO_RATE",
    "BLENDSHAPES_DIR",
    "COEFFS_DIR",
    "COEFFS_STD_FILE",
    "DATA_DIRS",
    "DATA_FILES",
    "FPS",
    "MANIFEST_FILE",
    "ORACLE_COEFFS_DIR",
    "POSE_COLUMNS",
    "POSE_DIR",
    "REPORT_DIR",
    "RESIDUALS_FILE",
    "RIGS_DIR",
    "SPLITS_FILE",
    "STATE_DIR",
    "TEMPLATES_DIR",
    "audio_path",
    "audio_relpath",
    "blendshape_path",
    "blendshape_relpath",
    "blendshapes_dir",
    "blendshapes_relpath",
    "coeffs_dir",
    "coeffs_path",
    "coeffs_relpath",
    "coeffs_std_path",
    "is_report_file",
    "listed_samples",
    "listed_sentences",
    "listed_oracle_samples",
    "listed_subjects",
    "manifest_path",
    "oracle_coeffs_relpath",
    "pose_path",
    "pose_relpath",
    "report_dir",
    "residuals_path",
    "rig_path",
    "rig_relpath",
    "splits_path",
    "template_path",
    "template_relpath",
]

#: Coefficient tracks, ``<subject>/<sentence>.csv`` (SAiD's name).
COEFFS_DIR = "blendshape_coeffs"
#: Fitted oracle samples of a synthetic corpus, ``<subject>/<sentence>-<k>.csv``: conditional
#: draws of the motion given the audio and the speaker (``--oracle-samples``), not ground truth.
ORACLE_COEFFS_DIR = "oracle_coeffs"
#: Speech, ``<subject>/<sentence>.wav``.
AUDIO_DIR = "audio"
#: A captured sentence's head and eye rotations, ``<subject>/<sentence>.csv``: optional (a
#: Live Link Face take has them), one row per frame of its coefficient track (60 fps),
#: columns :data:`POSE_COLUMNS`. The rig has no head: the rotations are the capture's
#: record, kept beside the track, never blendshapes.
POSE_DIR = "pose"
#: The columns of a pose file: Live Link Face's rotations, values as the app wrote them.
POSE_COLUMNS: tuple[str, ...] = LIVELINK_ROTATION_COLUMNS
#: Full-topology speaker rigs, ``<subject>.npz``.
RIGS_DIR = "rigs"
#: Neutral heads, ``<subject>.obj`` (SAiD's name).
TEMPLATES_DIR = "templates_head"
#: Blendshape heads, ``<subject>/<name>.obj`` (SAiD's name).
BLENDSHAPES_DIR = "blendshapes_head"
#: The build report (Markdown and figures).
REPORT_DIR = "report"
#: The build's stage records; never part of the data.
STATE_DIR = ".buildstate"
#: Per-blendshape standard deviation of the tracks (SAiD's asset).
COEFFS_STD_FILE = "coeffs_std.csv"
#: Per-speaker blendshape offsets in the layout SAiD's training reads.
RESIDUALS_FILE = "blendshape_residuals.pickle"
#: Split name -> subjects.
SPLITS_FILE = "splits.json"
#: The files that make up the dataset, with their sha256.
MANIFEST_FILE = "manifest.json"
#: Folders of data files (what a hand-made folder's manifest lists, with :data:`DATA_FILES`).
DATA_DIRS = (COEFFS_DIR, AUDIO_DIR, POSE_DIR, RIGS_DIR, TEMPLATES_DIR, BLENDSHAPES_DIR)
#: Top-level data files.
DATA_FILES = (COEFFS_STD_FILE, SPLITS_FILE)
#: Frame rate of every coefficient track.
FPS = 60
#: Sample rate of every audio file (mono).
AUDIO_RATE = 16000

#: A ground-truth track's file name: ``sentenceNN.csv``.
_SENTENCE_NAME = re.compile(r"^(sentence\d+)\.csv$")
#: An extra sample's file name: ``sentenceNN-<k>.csv``.
_SAMPLE_NAME = re.compile(r"^(sentence\d+)-(\d+)\.csv$")


# ----------------------------------------------------------------------------- relative paths (manifest keys)


def coeffs_relpath(subject: str, sentence: str, sample: int | None = None) -> str:
    """``blendshape_coeffs/<subject>/<sentence>.csv``, or ``.../<sentence>-<sample>.csv``."""
    name = sentence if sample is None else f"{sentence}-{int(sample)}"
    return f"{COEFFS_DIR}/{subject}/{name}.csv"


def oracle_coeffs_relpath(subject: str, sentence: str, sample: int) -> str:
    """``oracle_coeffs/<subject>/<sentence>-<sample>.csv``: a fitted oracle sample (0-based)."""
    return f"{ORACLE_COEFFS_DIR}/{subject}/{sentence}-{int(sample)}.csv"


def audio_relpath(subject: str, sentence: str) -> str:
    """``audio/<subject>/<sentence>.wav``."""
    return f"{AUDIO_DIR}/{subject}/{sentence}.wav"


def pose_relpath(subject: str, sentence: str) -> str:
    """``pose/<subject>/<sentence>.csv``."""
    return f"{POSE_DIR}/{subject}/{sentence}.csv"


def rig_relpath(subject: str) -> str:
    """``rigs/<subject>.npz``."""
    return f"{RIGS_DIR}/{subject}.npz"


def template_relpath(subject: str) -> str:
    """``templates_head/<subject>.obj``."""
    return f"{TEMPLATES_DIR}/{subject}.obj"


def blendshapes_relpath(subject: str) -> str:
    """``blendshapes_head/<subject>``: the folder of a speaker's blendshape heads."""
    return f"{BLENDSHAPES_DIR}/{subject}"


def blendshape_relpath(subject: str, name: str) -> str:
    """``blendshapes_head/<subject>/<name>.obj``."""
    return f"{BLENDSHAPES_DIR}/{subject}/{name}.obj"


def is_report_file(relpath: str) -> bool:
    """True for a file of the build report (``report/...``), which is not part of the data."""
    return relpath.startswith(f"{REPORT_DIR}/")


# ----------------------------------------------------------------------------- paths under a root


def coeffs_dir(root, subject: str) -> Path:
    """``<root>/blendshape_coeffs/<subject>``."""
    return Path(root) / COEFFS_DIR / subject


def coeffs_path(root, subject: str, sentence: str, sample: int | None = None) -> Path:
    """``<root>/blendshape_coeffs/<subject>/<sentence>.csv`` (or ``<sentence>-<sample>.csv``)."""
    return Path(root) / coeffs_relpath(subject, sentence, sample)


def audio_path(root, subject: str, sentence: str) -> Path:
    """``<root>/audio/<subject>/<sentence>.wav``."""
    return Path(root) / audio_relpath(subject, sentence)


def pose_path(root, subject: str, sentence: str) -> Path:
    """``<root>/pose/<subject>/<sentence>.csv``."""
    return Path(root) / pose_relpath(subject, sentence)


def rig_path(root, subject: str) -> Path:
    """``<root>/rigs/<subject>.npz``."""
    return Path(root) / rig_relpath(subject)


def template_path(root, subject: str) -> Path:
    """``<root>/templates_head/<subject>.obj``."""
    return Path(root) / template_relpath(subject)


def blendshapes_dir(root, subject: str) -> Path:
    """``<root>/blendshapes_head/<subject>``."""
    return Path(root) / blendshapes_relpath(subject)


def blendshape_path(root, subject: str, name: str) -> Path:
    """``<root>/blendshapes_head/<subject>/<name>.obj``."""
    return Path(root) / blendshape_relpath(subject, name)


def manifest_path(root) -> Path:
    """``<root>/manifest.json``."""
    return Path(root) / MANIFEST_FILE


def splits_path(root) -> Path:
    """``<root>/splits.json``."""
    return Path(root) / SPLITS_FILE


def coeffs_std_path(root) -> Path:
    """``<root>/coeffs_std.csv``."""
    return Path(root) / COEFFS_STD_FILE


def residuals_path(root) -> Path:
    """``<root>/blendshape_residuals.pickle``."""
    return Path(root) / RESIDUALS_FILE


def report_dir(root) -> Path:
    """``<root>/report``."""
    return Path(root) / REPORT_DIR


# ----------------------------------------------------------------------------- structure of a listing


def _names_in(listed, folder: str) -> list[str]:
    """Names of the files of ``listed`` directly in ``folder`` (relative paths), sorted."""
    prefix = folder.rstrip("/") + "/"
    return sorted(rel[len(prefix):] for rel in listed if rel.startswith(prefix) and "/" not in rel[len(prefix):])


def listed_subjects(listed) -> list[str]:
    """Subjects with a file directly in ``blendshape_coeffs/<subject>/``, sorted.

    Parameters
    ----------
    listed : iterable of str
        Relative paths, as ``manifest.json`` lists them.
    """
    prefix = f"{COEFFS_DIR}/"
    return sorted({rel.split("/")[1] for rel in listed if rel.startswith(prefix) and rel.count("/") == 2})


def listed_sentences(listed, subject: str) -> list[str]:
    """Sentences (``sentenceNN``) of ``subject`` with a listed ground-truth track, sorted."""
    return sorted(m.group(1) for name in _names_in(listed, f"{COEFFS_DIR}/{subject}")
                  if (m := _SENTENCE_NAME.match(name)))


def listed_samples(listed, subject: str, sentence: str) -> list[str]:
    """Relative paths of the listed extra samples ``<sentence>-<k>.csv`` of a sentence, in ``k`` order
    (empty when the sentence has only its ground truth)."""
    return _listed_samples(listed, f"{COEFFS_DIR}/{subject}", sentence)


def listed_oracle_samples(listed, subject: str, sentence: str) -> list[str]:
    """Relative paths of the listed oracle samples ``oracle_coeffs/<subject>/<sentence>-<k>.csv``
    of a sentence, in ``k`` order (empty when the build has none)."""
    return _listed_samples(listed, f"{ORACLE_COEFFS_DIR}/{subject}", sentence)


def _listed_samples(listed, folder: str, sentence: str) -> list[str]:
    """Relative paths of the listed ``<folder>/<sentence>-<k>.csv``, in ``k`` order."""
    found = sorted((int(m.group(2)), name) for name in _names_in(listed, folder)
                   if (m := _SAMPLE_NAME.match(name)) and m.group(1) == sentence)
    return [f"{folder}/{name}" for _, name in found]
