"""``manifest.json``: the truth about a BlendVOCA folder.

It lists exactly the outputs of the current build of the current inputs, each
with its sha256, plus the inputs' checksums, the tool version, the parameters
and the failures, and the BLAS kernels the build ran on (:func:`blas_kernels`: the
outputs depend on them) (no timestamps: identical builds, identical bytes). Readers
(``benchmark.data.open_blendvoca``) use only the files it lists
(:func:`listed_files`); a folder without one is refused with the command that
builds it.

A hand-made SAiD-layout folder (``blendshape_coeffs/``, ``audio/``,
``blendshapes_head/``, ``templates_head/``) is made readable by listing its
files once: ``python -m blendvoca.build.manifest DIR`` (:func:`write_folder_manifest`).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from blendvoca.errors import BlendVOCAError
from blendvoca.io.atomic import atomic_write

from .hashing import file_digest
from .state import STATE_DIR, read_record, record_path

MANIFEST_NAME = "manifest.json"
#: Folders and files of the SAiD layout (plus BlendVOCA's additions) a folder manifest lists.
DATA_DIRS = ("blendshape_coeffs", "audio", "rigs", "templates_head", "blendshapes_head")
DATA_FILES = ("coeffs_std.csv", "splits.json")


class ManifestError(BlendVOCAError):
    """A dataset folder without a usable ``manifest.json``; the message says how to make one."""


def _how_to_make(root: Path) -> str:
    return (f"Build it with `python -m blendvoca.build --vocaset <VOCASET folder> --out {root}` (or "
            f"`python -m blendvoca.build` for the bundled default); for a hand-made SAiD-layout folder, list its "
            f"files with `python -m blendvoca.build.manifest {root}`")


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
    path = root / MANIFEST_NAME
    if not path.is_file():
        raise ManifestError(f"{root} has no {MANIFEST_NAME}, so which of its files are current is unknown "
                            f"(a build that was interrupted or failed to write leaves none). {_how_to_make(root)}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise ManifestError(f"{path}: not readable JSON ({error}). {_how_to_make(root)}") from None
    files = data.get("files") if isinstance(data, dict) else None
    if not isinstance(files, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in files.items()):
        raise ManifestError(f"{path}: expected an object with \"files\": {{path: sha256}}, as blendvoca.build "
                            f"writes. {_how_to_make(root)}")
    for rel in files:
        parts = Path(rel).parts
        if Path(rel).is_absolute() or ".." in parts or not parts:
            raise ManifestError(f"{path}: listed file {rel!r} is not a relative path inside the folder")
    return dict(files)


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


def manifest_dict(out, *, files, vocaset, corpus, params, records, failures, version) -> dict:
    """Return the manifest of the build in ``out`` as a JSON-ready dict.

    Parameters
    ----------
    files : iterable of str
        The current build's outputs (relative paths); each is listed with its sha256.
    """
    inputs = {"vocaset": {"root_name": Path(vocaset).name, "path": str(Path(vocaset).resolve()),
                          "layout": getattr(corpus, "layout", "")},
              "speakers": {}}
    for subject in corpus.subjects:
        rig_rec = read_record(record_path(out, "rigs", subject)) or {}
        sentences = {
            sentence: rec.get("inputs", {})
            for (subj, sentence), rec in sorted(records.items()) if subj == subject
        }
        inputs["speakers"][subject] = {"template": rig_rec.get("inputs", {}), "sentences": sentences}
    from blendvoca.assets import resolve

    inputs["assets"] = {asset: file_digest(resolve(asset)) for asset in
                        ("arkit-reference-rig", "arkit-landmarks", "flame-landmarks", "flame-head-idx")}
    synthetic = getattr(corpus, "synthetic", None)
    if synthetic:
        inputs["synthetic"] = {"seed": synthetic.get("seed"), "version": synthetic.get("version")}
    return {
        "tool": "blendvoca.build",
        "version": version,
        "parameters": params,
        "inputs": inputs,
        "failures": failures,
        "blas": blas_kernels(),
        "files": {rel: file_digest(Path(out) / rel) for rel in sorted(set(files))},
    }


def _write(path: Path, data: dict) -> Path:
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(json.dumps(data, indent=1, sort_keys=True) + "\n")
    return path


def write_manifest(out, **kwargs) -> Path:
    """Write ``<out>/manifest.json`` atomically (see :func:`manifest_dict`) and return its path."""
    return _write(Path(out) / MANIFEST_NAME, manifest_dict(out, **kwargs))


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
    """
    root = Path(root)
    if (root / STATE_DIR).is_dir():
        raise ManifestError(f"{root} is a blendvoca.build output: rerun the build to refresh its {MANIFEST_NAME}")
    files = folder_files(root)
    if not any(rel.startswith("blendshape_coeffs/") for rel in files):
        raise ManifestError(f"{root}: no blendshape_coeffs/<subject>/<sentence>.csv found; not a SAiD-layout folder")
    data = {"tool": "blendvoca.build.manifest", "files": {rel: file_digest(root / rel) for rel in files}}
    return _write(root / MANIFEST_NAME, data)


def main(argv: list[str] | None = None) -> int:
    """``python -m blendvoca.build.manifest DIR``: list a hand-made SAiD-layout folder's files."""
    import argparse

    from blendvoca.errors import error_line

    parser = argparse.ArgumentParser(prog="python -m blendvoca.build.manifest",
                                     description="Write manifest.json for a hand-made SAiD-layout folder.")
    parser.add_argument("folder")
    args = parser.parse_args(argv)
    try:
        path = write_folder_manifest(args.folder)
    except (BlendVOCAError, OSError) as error:
        print(error_line(error), file=sys.stderr)
        return 2
    print(f"{path}: {len(json.loads(path.read_text())['files'])} files listed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
