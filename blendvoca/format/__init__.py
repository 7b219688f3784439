"""The BlendVOCA folder format: the one owner of what a BlendVOCA dataset is on disk.

A BlendVOCA folder is SAiD's layout (``blendshape_coeffs/``, ``audio/``,
``templates_head/``, ``blendshapes_head/``, ``coeffs_std.csv``) plus BlendVOCA's
additions (``rigs/``, ``splits.json``, ``blendshape_residuals.pickle``, ``report/``)
and ``manifest.json``, which lists the files that make up the dataset. The build
(:mod:`blendvoca.builder`) writes such a folder and the benchmark
(:mod:`benchmark.data`) reads it, both through this package only:

:mod:`~blendvoca.format.layout`
    The folder and file names (the only module that spells them), the functions
    that turn ``(root, subject, sentence[, sample])`` into paths
    (``coeffs_path``, ``audio_path``, ``rig_path``, ...; ``*_relpath`` for the keys
    a manifest lists), and the dataset's structure read off a manifest's listing
    (``listed_subjects``, ``listed_sentences``, ``listed_samples``).
:mod:`~blendvoca.format.items`
    Reading and writing the items: coefficient tracks (CSV, 60 fps), audio (WAV,
    mono 16 kHz), a capture's head and eye rotations (``pose/``, optional), rigs (``.npz`` and SAiD's OBJ heads), ``coeffs_std.csv`` and
    ``splits.json``.
:mod:`~blendvoca.format.manifest`
    ``manifest.json``: reading (``listed_files``, ``read_manifest``), writing
    (``write_manifest`` for a build, ``write_folder_manifest`` for a hand-made
    SAiD-layout folder, also ``python -m blendvoca.format manifest DIR``), the
    dataset's identity (``manifest_hash``) and the BLAS kernels a build ran on
    (``blas_kernels``).
:mod:`~blendvoca.format.recipe`
    The dataset's identity across machines: the recipe id (``make_recipe``,
    ``recipe_id``: the inputs' digests, the data-format version, the parameters; the
    manifest stores it, :func:`~blendvoca.format.manifest.dataset_id` reads it) and
    the per-file tolerances two builds of one recipe are compared within
    (:mod:`~blendvoca.format.compare`, ``python -m blendvoca.format compare A B``).
:mod:`~blendvoca.format.hashing`
    The sha256 digests of files, folders and arrays that manifests list and stage
    keys are made of.

Only the files ``manifest.json`` lists belong to the dataset: a reader never
looks at anything else in the folder.
"""

import types as _types

from .hashing import array_digest, content_digest, file_digest, files_digests, stage_key
from .items import (
    read_audio,
    read_coeffs,
    read_coeffs_file,
    read_pose,
    read_rig,
    read_said_rig,
    read_splits,
    write_audio,
    write_coeffs,
    write_coeffs_std,
    write_pose,
    write_rig,
    write_said_rig,
    write_splits,
)
from .layout import (
    AUDIO_DIR,
    AUDIO_RATE,
    BLENDSHAPES_DIR,
    COEFFS_DIR,
    COEFFS_STD_FILE,
    DATA_DIRS,
    DATA_FILES,
    FPS,
    MANIFEST_FILE,
    ORACLE_COEFFS_DIR,
    POSE_COLUMNS,
    POSE_DIR,
    REPORT_DIR,
    RESIDUALS_FILE,
    RIGS_DIR,
    SPLITS_FILE,
    STATE_DIR,
    TEMPLATES_DIR,
    audio_path,
    audio_relpath,
    blendshape_path,
    blendshape_relpath,
    blendshapes_dir,
    blendshapes_relpath,
    coeffs_dir,
    coeffs_path,
    coeffs_relpath,
    coeffs_std_path,
    is_report_file,
    listed_oracle_samples,
    listed_samples,
    listed_sentences,
    listed_subjects,
    manifest_path,
    pose_path,
    pose_relpath,
    report_dir,
    residuals_path,
    rig_path,
    rig_relpath,
    splits_path,
    template_path,
    template_relpath,
)
from .recipe import (
    FORMAT_VERSION,
    corpus_files,
    default_tolerances,
    file_tolerance,
    make_recipe,
    recipe_id,
    recipe_key,
)
from .manifest import (
    ManifestError,
    blas_kernels,
    dataset_id,
    listed_files,
    manifest_hash,
    read_manifest,
    read_utterances,
    recorded_vocaset,
    remove_manifest,
    utterance_record,
    write_dataset_manifest,
    write_folder_manifest,
    write_manifest,
    written_by_build,
)

# Every name imported above is public; the submodules themselves are not listed.
__all__ = sorted(name for name, value in globals().items()
                 if not name.startswith("_") and not isinstance(value, _types.ModuleType))
