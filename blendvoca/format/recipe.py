"""A dataset's identity: the recipe id, and the per-file tolerances two builds of one recipe are compared within.

Three things identify and check a BlendVOCA folder, each for its own purpose:

recipe id (:func:`recipe_id`)
    sha256 over what the build was asked to do: the digest of every input file it
    reads (the corpus's files, the rig and landmark assets), the tool's data-format
    version (:data:`FORMAT_VERSION`) and the build parameters. It is known before
    any output is written, stored in ``manifest.json`` (``recipe.id``), and it names
    results and keys leaderboard sections: two machines that build the same corpus
    with the same tool and parameters get the same id, whichever BLAS kernel
    rounded their fits.
content hash (:func:`blendvoca.format.manifest.manifest_hash`)
    sha256 over the written data files' digests. It verifies a build's own files
    (exact, against its own manifest) and is recorded in results for information;
    it differs between kernels (the fitted floats round differently).
tolerances (:func:`default_tolerances`, :func:`blendvoca.format.compare.compare_builds`)
    per listed array file, the largest absolute difference by which two builds of
    one recipe may differ in that file's numbers and still be the same dataset.

An adapter that writes the layout from another corpus gives its own input files
and parameters to :func:`make_recipe` (a list of files and a dict), so its builds get an
id by the same rule.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Iterable, Mapping

from .hashing import file_digest, stage_key
from .layout import (
    BLENDSHAPES_DIR,
    COEFFS_DIR,
    COEFFS_STD_FILE,
    ORACLE_COEFFS_DIR,
    RESIDUALS_FILE,
    RIGS_DIR,
    STATE_DIR,
    TEMPLATES_DIR,
)

__all__ = [
    "FORMAT_VERSION",
    "RECIPE_KEY_LENGTH",
    "corpus_files",
    "default_tolerances",
    "file_tolerance",
    "make_recipe",
    "recipe_id",
    "recipe_key",
]

#: Version of what a build writes from its inputs (file formats, precision, the stages'
#: algorithms as far as they change the data): bumped when the same inputs and parameters
#: would give another dataset, so builds of an older tool get another recipe id.
FORMAT_VERSION = "1"
#: Hex digits of the recipe id that name result files and head leaderboard sections.
RECIPE_KEY_LENGTH = 12

#: Largest absolute difference of two builds of one recipe, by kind of file. The kernels'
#: rounding is not confined to the last digits: the deformation transfer amplifies it, so
#: the bundled default built under OpenBLAS's Haswell and Sandybridge kernels differs by
#: up to 0.6 mm in rig deltas (of up to 34 mm) and by up to 0.0056 in coefficients (RMS
#: 0.0004; docs/build.md, "Dataset identity"). The tolerances are about 3.5x those
#: figures: loose enough for any kernel, tight enough to catch a fit or rig that went
#: elsewhere (a wrong asset, a broken solver moves them by centimetres and tenths).
_TOLERANCES = (
    (f"{COEFFS_DIR}/", ".csv", 2e-2),
    (f"{ORACLE_COEFFS_DIR}/", ".csv", 2e-2),
    (COEFFS_STD_FILE, "", 2e-3),
    (f"{RIGS_DIR}/", ".npz", 2e-3),
    (f"{TEMPLATES_DIR}/", ".obj", 2e-3),
    (f"{BLENDSHAPES_DIR}/", ".obj", 2e-3),
    (RESIDUALS_FILE, "", 2e-3),
)


def file_tolerance(relpath: str) -> float | None:
    """The default tolerance of a layout file (``None``: compared byte for byte, e.g. audio, splits)."""
    for prefix, suffix, atol in _TOLERANCES:
        matches = (relpath.startswith(prefix) and relpath.endswith(suffix)) if suffix else relpath == prefix
        if matches:
            return atol
    return None


def default_tolerances(relpaths: Iterable[str]) -> dict[str, float]:
    """``{relpath: atol}`` for the array files among ``relpaths`` (:func:`file_tolerance`); others are left out."""
    return {rel: atol for rel in sorted(relpaths) if (atol := file_tolerance(rel)) is not None}


def corpus_files(root) -> list[Path]:
    """Every regular file of a corpus folder, sorted: what a build of it reads.

    Hidden files and folders (``.git``, editors' files) and a build's state folder are
    left out: they are not the corpus.
    """
    root = Path(os.fspath(root))
    found = []
    for path in root.rglob("*"):
        rel = path.relative_to(root)
        if any(part.startswith(".") for part in rel.parts) or STATE_DIR in rel.parts:
            continue
        if path.is_file():
            found.append(path)
    return sorted(found, key=lambda p: p.relative_to(root).as_posix())


def _input_digests(files, root) -> dict[str, str]:
    """``{name: sha256}``: names relative to ``root`` (so the id does not depend on where the
    corpus lies), or the file's own name without one; ``(name, path)`` pairs name themselves."""
    digests = {}
    items = files.items() if isinstance(files, Mapping) else files
    for item in items:
        if isinstance(item, tuple):
            name, path = item
        else:
            path = Path(os.fspath(item))
            name = path.relative_to(root).as_posix() if root is not None else path.name
        if name in digests:
            raise ValueError(f"recipe: input {name!r} given twice; name the files with (name, path) pairs")
        digests[str(name)] = file_digest(path)
    return dict(sorted(digests.items()))


def _listing_digest(digests: dict) -> str:
    """sha256 over ``name\tsha256`` lines: one digest for any number of input files (a corpus
    of per-frame meshes has a hundred thousand; the manifest stores this, not the list)."""
    h = hashlib.sha256()
    for name, digest in digests.items():
        h.update(f"{name}\t{digest}\n".encode("utf-8"))
    return h.hexdigest()


def make_recipe(files, params: dict, *, root=None, assets: Mapping[str, str] | None = None,
                format_version: str = FORMAT_VERSION) -> dict:
    """The record a recipe id is the digest of, as stored in ``manifest.json`` (``recipe``).

    Parameters
    ----------
    files : iterable of path-like or of ``(name, path)``, or mapping name -> path
        The input files the build reads (e.g. :func:`corpus_files`).
    params : dict
        The build parameters (JSON-serialisable).
    root : path-like, optional
        Names of ``files`` are taken relative to it.
    assets : mapping of str to str, optional
        ``{asset id: sha256}`` of the assets the build reads (already digested).
    format_version : str
        :data:`FORMAT_VERSION` unless an adapter writes its own format version.

    Returns
    -------
    dict
        ``{"id", "format_version", "parameters", "inputs": {"files": {"count", "sha256"},
        "assets": {asset: sha256}}}``: ``inputs.files.sha256`` is the digest of the sorted
        ``name<TAB>sha256`` lines of the input files. ``id`` (64 hex digits) is
        :func:`~blendvoca.format.hashing.stage_key` of the rest.
    """
    root = None if root is None else Path(os.fspath(root))
    digests = _input_digests(files, root)
    record = {"format_version": str(format_version), "parameters": dict(params),
              "inputs": {"files": {"count": len(digests), "sha256": _listing_digest(digests)},
                         "assets": dict(sorted((assets or {}).items()))}}
    return {"id": stage_key(record), **record}


def recipe_id(files, params: dict, **kwargs) -> str:
    """The recipe id (64 hex digits) of building ``files`` with ``params``; see :func:`make_recipe`."""
    return make_recipe(files, params, **kwargs)["id"]


def recipe_key(identity: str) -> str:
    """The short form that names result files and heads leaderboard sections (first 12 hex digits)."""
    return str(identity)[:RECIPE_KEY_LENGTH]
