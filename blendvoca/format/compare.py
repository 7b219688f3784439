"""Are two builds the same dataset? (``python -m blendvoca.format compare A B``)

Two folders are the same dataset when their manifests record the same recipe id
(:mod:`blendvoca.format.recipe`), list the same data files (the build report left
out, as from the content hash), and every listed data file is
either byte-identical or an array file whose numbers differ by at most the
tolerance the manifest stores for it (the smaller of the two manifests'). Builds
of one recipe on machines whose BLAS kernels round differently pass; a build of
another corpus, tool or parameter set, or one whose numbers moved further, does not.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.io.mesh import read_obj
from blendvoca.io.pickle_file import load_data_pickle

from .layout import is_report_file
from .manifest import listed_files, read_manifest

__all__ = ["Comparison", "compare_builds", "file_difference"]


@dataclass
class Comparison:
    """What :func:`compare_builds` found.

    Attributes
    ----------
    same : bool
        Same recipe, same files, every file within its tolerance.
    recipe : tuple of (str or None, str or None)
        Each folder's recipe id.
    problem : str or None
        The first difference that rules out "same dataset", in words.
    identical, within : int
        Files byte-identical, and array files that differ within their tolerance.
    max_difference : dict
        ``{relpath: largest absolute difference}`` of the files that are not byte-identical.
    """

    same: bool
    recipe: tuple
    problem: str | None = None
    identical: int = 0
    within: int = 0
    max_difference: dict = field(default_factory=dict)


def _flatten(value, prefix="") -> dict:
    """``{path: leaf}`` of nested dicts and lists (the structure must match exactly, the leaves are compared)."""
    if isinstance(value, dict):
        out = {}
        for key in sorted(value, key=str):
            out.update(_flatten(value[key], f"{prefix}/{key}"))
        return out
    if isinstance(value, (list, tuple)):
        out = {}
        for index, item in enumerate(value):
            out.update(_flatten(item, f"{prefix}[{index}]"))
        return out
    return {prefix: value}


def _read_arrays(path: Path) -> dict:
    """A file's numbers as ``{part: ndarray}`` and its other content as ``{part: str}``, by suffix."""
    suffix = path.suffix.lower()
    if suffix == ".csv":
        lines = path.read_text(encoding="utf-8").splitlines()
        header, rows = (lines[:1], lines[1:])
        values = np.array([[float(v) for v in row.split(",")] for row in rows if row], dtype=np.float64)
        return {"header": "\n".join(header), "values": values}
    if suffix == ".npz":
        with np.load(path, allow_pickle=False) as data:
            return {name: data[name] for name in data.files}
    if suffix == ".obj":
        vertices, faces = read_obj(path)
        return {"vertices": vertices, "faces": faces}
    if suffix in (".pickle", ".pkl"):
        return _flatten(load_data_pickle(path))
    raise DataError(f"{path}: no reader for {suffix!r} files; such files are compared byte for byte")


def file_difference(a, b) -> float:
    """Largest absolute difference of the numbers of two files of one kind.

    Returns
    -------
    float
        0.0 for equal content; ``inf`` when their structure differs (other shapes,
        another header, other integer content such as faces or names).

    Raises
    ------
    DataError
        A file that cannot be read as its suffix says.
    """
    try:
        parts_a, parts_b = _read_arrays(Path(a)), _read_arrays(Path(b))
    except (ValueError, OSError, EOFError) as error:
        raise DataError(f"compare {a} / {b}: cannot read as arrays ({error})") from None
    if sorted(parts_a) != sorted(parts_b):
        return float("inf")
    worst = 0.0
    for key, value_a in parts_a.items():
        value_a, value_b = np.asarray(value_a), np.asarray(parts_b[key])
        if value_a.shape != value_b.shape:
            return float("inf")
        floating = np.issubdtype(value_a.dtype, np.floating) and np.issubdtype(value_b.dtype, np.floating)
        if not floating:
            if not np.array_equal(value_a, value_b):
                return float("inf")
            continue
        if value_a.size:
            diff = np.abs(value_a.astype(np.float64) - value_b.astype(np.float64))
            same_nan = np.isnan(value_a) & np.isnan(value_b)
            diff = np.where(same_nan, 0.0, diff)
            worst = max(worst, float(np.nan_to_num(diff, nan=np.inf).max()))
    return worst


def _recipe_of(manifest: dict) -> str | None:
    recipe = manifest.get("recipe")
    identity = recipe.get("id") if isinstance(recipe, dict) else None
    return identity if isinstance(identity, str) else None


def _tolerances(manifest: dict) -> dict:
    stored = manifest.get("tolerances")
    if not isinstance(stored, dict):
        return {}
    return {k: float(v) for k, v in stored.items()
            if isinstance(v, (int, float)) and not isinstance(v, bool) and v >= 0}


def compare_builds(a, b) -> Comparison:
    """Compare two BlendVOCA folders: same recipe id, same files, each within its tolerance.

    Parameters
    ----------
    a, b : path-like
        Two folders with a ``manifest.json`` (a build's: they record a recipe).

    Returns
    -------
    Comparison
        ``problem`` names the first difference that rules out "same dataset": the
        recipes, the listed files, or the first file (sorted by path) that differs
        beyond its tolerance, with its largest difference.
    """
    a, b = Path(os.fspath(a)), Path(os.fspath(b))
    manifest_a, manifest_b = read_manifest(a), read_manifest(b)
    # The build report describes the build (its timings, its kernel's figures), not the data.
    files_a = {rel: sha for rel, sha in listed_files(a).items() if not is_report_file(rel)}
    files_b = {rel: sha for rel, sha in listed_files(b).items() if not is_report_file(rel)}
    recipes = (_recipe_of(manifest_a), _recipe_of(manifest_b))
    result = Comparison(same=False, recipe=recipes)
    if recipes[0] is None or recipes[1] is None:
        missing = a if recipes[0] is None else b
        result.problem = f"{missing}: its manifest records no recipe id (a build of an older tool: rebuild it)"
        return result
    if recipes[0] != recipes[1]:
        result.problem = f"different recipes: {recipes[0][:12]} ({a}) and {recipes[1][:12]} ({b})"
        return result
    only = sorted(set(files_a) ^ set(files_b))
    if only:
        where = a if only[0] in files_a else b
        result.problem = f"{only[0]}: listed only in {where} ({len(only)} file(s) listed in one folder only)"
        return result
    tol_a, tol_b = _tolerances(manifest_a), _tolerances(manifest_b)
    for rel in sorted(files_a):
        if files_a[rel] == files_b[rel]:
            result.identical += 1
            continue
        atol = min(tol_a.get(rel, 0.0), tol_b.get(rel, 0.0)) if rel in tol_a and rel in tol_b else None
        if atol is None:
            result.problem = f"{rel}: differs, and it is compared byte for byte (no tolerance stored for it)"
            return result
        difference = file_difference(a / rel, b / rel)
        result.max_difference[rel] = difference
        if not difference <= atol:
            result.problem = f"{rel}: max difference {difference:.3g} exceeds its tolerance {atol:.3g}"
            return result
        result.within += 1
    result.same = True
    return result
