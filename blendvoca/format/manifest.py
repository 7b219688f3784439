"""``manifest.json``: the truth about a BlendVOCA folder.

It lists exactly the outputs of the current build of the current inputs, each
with its sha256, plus the inputs' checksums, the tool version, the parameters
and the failures, and the BLAS kernels the build ran on (:func:`blas_kernels`: the
outputs depend on them) (no timestamps: identical builds, identical bytes). Readers
(``benchmark.data.open_blendvoca``) use only the files it lists
(:func:`listed_files`); a folder without one is refused with the command that
builds it.

The dataset's identity, which names result files and leaderboard sections, is its
recipe id (``recipe.id``, :func:`dataset_id`; :mod:`blendvoca.format.recipe`): the
digests of the build's inputs, the data-format version and the parameters, the same
on every machine. The content hash (:func:`manifest_hash`: the listed data files and
their sha256, the report left out) verifies a build's own files and differs between
BLAS kernels; ``tolerances`` stores, per array file, how far two builds of one
recipe may differ (``python -m blendvoca.format compare A B``).

A hand-made SAiD-layout folder (``blendshape_coeffs/``, ``audio/``,
``blendshapes_head/``, ``templates_head/``) is made readable by listing its
files once: ``python -m blendvoca.format manifest DIR`` (:func:`write_folder_manifest`).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from blendvoca.runtime.version import blendvoca_version
from blendvoca.assets import resolve
from blendvoca.errors import DataError
from blendvoca.io.json_file import read_json
from blendvoca.io.atomic import atomic_write

from .hashing import file_digest, files_digests
from .recipe import default_tolerances, make_recipe
from .layout import COEFFS_DIR, DATA_DIRS, DATA_FILES, MANIFEST_FILE, STATE_DIR, is_report_file, manifest_path

__all__ = [
    "BUILD_TOOL",
    "DATA_DIRS",
    "DATA_FILES",
    "FOLDER_TOOL",
    "MANIFEST_NAME",
    "ManifestError",
    "blas_kernels",
    "dataset_id",
    "folder_files",
    "listed_files",
    "manifest_dict",
    "manifest_hash",
    "read_manifest",
    "read_utterances",
    "recorded_vocaset",
    "remove_manifest",
    "write_folder_manifest",
    "write_manifest",
    "write_dataset_manifest",
    "utterance_record",
    "written_by_build",
]

MANIFEST_NAME = MANIFEST_FILE
#: ``tool`` of a manifest a build wrote (and of the marker in a build's state folder).
BUILD_TOOL = "blendvoca.build"
#: ``tool`` of a manifest :func:`write_folder_manifest` wrote for a hand-made folder (the
#: command's former name, kept: it is recorded in those manifests and their recipe ids).
FOLDER_TOOL = "blendvoca.build.manifest"


class ManifestError(DataError):
    """A dataset folder without a usable ``manifest.json``; the message says how to make one."""


def _how_to_make(root: Path) -> str:
    return (f"Build it with `python -m blendvoca.build --vocaset <VOCASET folder> --out {root}` (or "
            f"`python -m blendvoca.build` for the bundled default); for a hand-made SAiD-layout folder, list its "
            f"files with `python -m blendvoca.format manifest {root}`")


def read_manifest(root) -> dict:
    """The parsed ``<root>/manifest.json``.

    Raises
    ------
    ManifestError
        No manifest, one that is not readable JSON, or not a JSON object; the
        message gives the command that (re)makes it.
    """
    root = Path(root)
    path = manifest_path(root)
    if not path.is_file():
        raise ManifestError(f"{root} has no {MANIFEST_NAME}, so which of its files are current is unknown "
                            f"(a build that was interrupted or failed to write leaves none). {_how_to_make(root)}")
    try:
        data = read_json(path, what="readable JSON")
    except OSError as error:
        raise ManifestError(f"{path}: not readable ({error.strerror or error}). {_how_to_make(root)}") from None
    except DataError as error:
        raise ManifestError(f"{error}. {_how_to_make(root)}") from None
    if not isinstance(data, dict):
        raise ManifestError(f"{path}: expected an object with \"files\": {{path: sha256}}, as blendvoca.build "
                            f"writes. {_how_to_make(root)}")
    return data


def listed_files(root) -> dict[str, str]:
    """``{relative path: sha256}`` of the files ``<root>/manifest.json`` lists.

    Raises
    ------
    ManifestError
        No manifest, or one that is not a BlendVOCA manifest (no ``files``
        object of path -> sha256, or paths leaving the folder); the message
        gives the command that (re)makes it.
    """
    root = Path(root)
    path = manifest_path(root)
    files = read_manifest(root).get("files")
    if not isinstance(files, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in files.items()):
        raise ManifestError(f"{path}: expected an object with \"files\": {{path: sha256}}, as blendvoca.build "
                            f"writes. {_how_to_make(root)}")
    for rel in files:
        parts = Path(rel).parts
        if Path(rel).is_absolute() or ".." in parts or not parts:
            raise ManifestError(f"{path}: listed file {rel!r} is not a relative path inside the folder")
    return dict(files)


def manifest_hash(root) -> str:
    """The dataset's identity: sha256 over the data files ``manifest.json`` lists with their sha256.

    The build report, the tool version, the parameters and the BLAS kernels do not
    change what a method is scored on, so builds that differ only in those have one
    hash (and their results land in one leaderboard table). A manifest without a
    ``files`` object is its own identity (the whole file); a folder without a
    manifest is identified by its sorted file listing (paths and sizes).

    Returns
    -------
    str
        64 hex digits.
    """
    root = Path(root)
    path = manifest_path(root)
    digest = hashlib.sha256()
    if path.exists():
        try:
            manifest = json.loads(path.read_bytes().decode("utf-8"))
        except (ValueError, RecursionError):  # not JSON (UnicodeDecodeError is a ValueError): hashed whole below
            manifest = None
        if isinstance(manifest, dict) and isinstance(manifest.get("files"), dict):
            for name, sha in sorted(manifest["files"].items()):
                if not is_report_file(name):
                    digest.update(f"{name}\t{sha}\n".encode())
        else:  # not written by blendvoca.build: the whole file is its identity
            digest.update(path.read_bytes())
    else:
        for p in sorted(root.rglob("*")):
            if p.is_file():
                digest.update(f"{p.relative_to(root).as_posix()}\t{p.stat().st_size}\n".encode())
    return digest.hexdigest()


def dataset_id(root) -> str:
    """The dataset's identity: the recipe id its manifest records (64 hex digits).

    A folder whose manifest records none (a build or hand-made folder listed by an
    older tool) is identified by its content hash (:func:`manifest_hash`), the
    identity such folders had: it still matches the results made on it.
    """
    try:
        recipe = read_manifest(root).get("recipe")
    except ManifestError:
        recipe = None
    identity = recipe.get("id") if isinstance(recipe, dict) else None
    if isinstance(identity, str) and len(identity) == 64 and all(c in "0123456789abcdef" for c in identity):
        return identity
    return manifest_hash(root)


def recorded_vocaset(root) -> str | None:
    """The VOCASET folder a build recorded (``inputs.vocaset.path``), or None (no manifest,
    an unreadable one, one that records no path as a string, or a hand-made folder's)."""
    try:
        inputs = read_manifest(root).get("inputs", {})
        path = inputs.get("vocaset", {}).get("path")
    except (ManifestError, AttributeError):
        return None
    return path if isinstance(path, str) and path else None


def utterance_record(take: str, start: int, end: int, fps: float, *, cut: str) -> dict:
    """Where a sentence of a coefficient build comes from: take ``take``'s frames ``[start, end)``
    at ``fps`` (the folder's rate) and the seconds they span; ``cut`` says how its end was decided
    (``pause``, ``forced``, ``user`` or ``end``, :mod:`blendvoca.datasets.utterances`). The
    manifest's ``dataset.utterances`` maps ``"subject/sentence"`` to these records."""
    return {"take": str(take), "start_frame": int(start), "end_frame": int(end),
            "start_s": round(start / fps, 6), "end_s": round(end / fps, 6), "cut": str(cut)}


def read_utterances(root) -> dict[str, dict]:
    """``{"subject/sentence": utterance record}`` of a coefficient build (:func:`utterance_record`);
    empty for a folder whose manifest records none (a mesh build, an older coefficient build).

    Raises
    ------
    ManifestError
        No readable manifest.
    """
    dataset = read_manifest(root).get("dataset")
    utterances = dataset.get("utterances") if isinstance(dataset, dict) else None
    return dict(utterances) if isinstance(utterances, dict) else {}


def written_by_build(root) -> bool:
    """True when ``<root>/manifest.json`` is readable and a build wrote it (``tool``)."""
    try:
        return read_manifest(root).get("tool") == BUILD_TOOL
    except ManifestError:
        return False


def remove_manifest(root) -> None:
    """Remove ``<root>/manifest.json`` if there is one: its files are about to change."""
    manifest_path(root).unlink(missing_ok=True)


def blas_kernels() -> list[str]:
    """Return ``"<library> <version> <kernel>"`` for each BLAS loaded in this process (numpy's and scipy's at least), sorted.

    OpenBLAS picks its kernel for the CPU it runs on (``OPENBLAS_CORETYPE`` overrides
    it), and a build's outputs depend on it: the same code and inputs give other rigs
    and fits under the ``Haswell`` kernel than under ``SkylakeX`` (docs/build.md).
    """
    import scipy.linalg  # noqa: F401 - loads scipy's BLAS too, so the list does not depend on what ran before
    from threadpoolctl import threadpool_info

    return sorted({f"{i.get('internal_api', '?')} {i.get('version', '?')} {i.get('architecture', '?')}"
                   for i in threadpool_info() if i.get("user_api") == "blas"})


def manifest_dict(out, *, files, vocaset, corpus, params, records, rig_records, failures, version,
                  recipe: dict | None = None, tolerances: dict | None = None) -> dict:
    """Return the manifest of the build in ``out`` as a JSON-ready dict.

    Parameters
    ----------
    out : path-like
        The build folder.
    files : iterable of str
        The current build's outputs (relative paths); each is listed with its sha256.
    vocaset : path-like
        The corpus the build read.
    corpus : blendvoca.vocaset.VocasetCorpus
        Its subjects (in order), layout and, for the synthetic corpus, its seed and version.
    params : dict
        The build parameters.
    records : dict
        ``{(subject, sentence): stage record}`` of the fitted sentences (their ``inputs``).
    rig_records : dict
        ``{subject: stage record or None}`` of the speakers' rigs (their ``inputs``).
    failures : list of dict
    version : str
        The tool version.
    recipe : dict, optional
        The build's recipe (:func:`blendvoca.format.recipe.recipe`), computed before any
        output was written; stored as ``recipe``. Without it none is stored (and
        :func:`dataset_id` falls back on the content hash).
    tolerances : dict, optional
        ``{relpath: atol}`` for the array files; default
        :func:`blendvoca.format.recipe.default_tolerances` of ``files``.
    """
    inputs = {"vocaset": {"root_name": Path(vocaset).name, "path": str(Path(vocaset).resolve()),
                          "layout": getattr(corpus, "layout", "")},
              "speakers": {}}
    for subject in corpus.subjects:
        rig_rec = rig_records.get(subject) or {}
        sentences = {
            sentence: rec.get("inputs", {})
            for (subj, sentence), rec in sorted(records.items()) if subj == subject
        }
        inputs["speakers"][subject] = {"template": rig_rec.get("inputs", {}), "sentences": sentences}
    inputs["assets"] = {asset: file_digest(resolve(asset)) for asset in
                        ("arkit-reference-rig", "arkit-landmarks", "flame-landmarks", "flame-head-idx")}
    synthetic = getattr(corpus, "synthetic", None)
    if synthetic:
        inputs["synthetic"] = {"seed": synthetic.get("seed"), "version": synthetic.get("version")}
    return _build_record(out, files, version=version, params=params, failures=failures, recipe=recipe,
                         tolerances=tolerances, inputs=inputs, blas=blas_kernels())


def _build_record(out, files, *, version, params, failures, recipe, tolerances, **parts) -> dict:
    """A build's manifest: ``parts`` (its inputs or dataset record) with what every build's records."""
    listed = sorted(set(files))
    data = {"tool": BUILD_TOOL, "version": version, "parameters": params, "failures": failures, **parts,
            "files": files_digests(out, listed),
            "tolerances": default_tolerances(listed) if tolerances is None else dict(sorted(tolerances.items()))}
    if recipe is not None:
        data["recipe"] = recipe
    return data


def _write(path: Path, data: dict) -> Path:
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(json.dumps(data, indent=1, sort_keys=True) + "\n")
    return path


def write_manifest(out, **kwargs) -> Path:
    """Write ``<out>/manifest.json`` atomically (see :func:`manifest_dict`) and return its path."""
    return _write(manifest_path(out), manifest_dict(out, **kwargs))


def write_dataset_manifest(out, *, files, dataset: dict, params: dict, failures: list,
                           recipe: dict | None = None) -> Path:
    """Write ``<out>/manifest.json`` of a build from a coefficient corpus (``blendvoca.datasets``:
    BEAT, UniTalker, 3D-ETF) atomically: the files with their sha256, the dataset record, the
    recipe (the dataset's identity) and the per-file tolerances; return its path."""
    return _write(manifest_path(out), _build_record(out, files, version=blendvoca_version(), params=params,
                                                    failures=failures, recipe=recipe, tolerances=None,
                                                    dataset=dataset))


def folder_files(root) -> list[str]:
    """Data files of a hand-made SAiD-layout folder: everything under :data:`DATA_DIRS` and
    the top-level :data:`DATA_FILES` (hidden files and temporaries skipped)."""
    root = Path(root)
    found = [name for name in DATA_FILES if (root / name).is_file()]
    for folder in DATA_DIRS:
        for path in sorted((root / folder).rglob("*")):
            rel = path.relative_to(root)
            if path.is_file() and not any(part.startswith(".") for part in rel.parts):
                found.append(rel.as_posix())
    return sorted(found)


def write_folder_manifest(root) -> Path:
    """List the data files of a hand-made SAiD-layout folder in ``<root>/manifest.json``.

    Refuses a folder a build wrote (it has its own manifest: rebuild it instead).

    Raises
    ------
    ManifestError
        A build's folder, or no ``blendshape_coeffs/<subject>/<sentence>.csv`` in it.
    """
    root = Path(root)
    if (root / STATE_DIR).is_dir():
        raise ManifestError(f"{root} is a blendvoca.build output: rerun the build to refresh its {MANIFEST_NAME}")
    files = folder_files(root)
    if not any(rel.startswith(f"{COEFFS_DIR}/") for rel in files):
        raise ManifestError(f"{root}: no {COEFFS_DIR}/<subject>/<sentence>.csv found; not a SAiD-layout folder")
    # A hand-made folder is its own input: its recipe is its files (by name and digest).
    data = {"tool": FOLDER_TOOL, "files": files_digests(root, files),
            "recipe": make_recipe([(rel, root / rel) for rel in files], {"tool": FOLDER_TOOL}),
            "tolerances": default_tolerances(files)}
    return _write(manifest_path(root), data)
