"""``manifest.json``: every output file with its sha256, the inputs' checksums,
the tool version and the parameters (no timestamps: identical builds, identical bytes)."""

from __future__ import annotations

import json
from pathlib import Path

from blendvoca.io.atomic import atomic_write

from .hashing import file_digest
from .state import STATE_DIR, read_record, record_path

MANIFEST_NAME = "manifest.json"


def output_files(out) -> list[str]:
    """Relative paths of every build output under ``out`` (not the state, not the manifest)."""
    out = Path(out)
    files = []
    for path in sorted(out.rglob("*")):
        rel = path.relative_to(out).as_posix()
        if not path.is_file() or rel == MANIFEST_NAME or rel.startswith(STATE_DIR + "/"):
            continue
        if path.name.startswith(".") and path.name.endswith(".tmp"):
            continue
        files.append(rel)
    return files


def manifest_dict(out, *, vocaset, corpus, params, records, failures, version) -> dict:
    """Return the manifest of the build in ``out`` as a JSON-ready dict."""
    inputs = {"vocaset": {"root_name": Path(vocaset).name, "path": str(Path(vocaset).resolve()),
                          "layout": getattr(corpus, "layout", "")},
              "speakers": {}}
    assets = None
    for subject in corpus.subjects:
        rig_rec = read_record(record_path(out, "rigs", subject)) or {}
        sentences = {
            sentence: rec.get("inputs", {})
            for (subj, sentence), rec in sorted(records.items()) if subj == subject
        }
        inputs["speakers"][subject] = {"template": rig_rec.get("inputs", {}), "sentences": sentences}
    from blendvoca.assets import resolve

    assets = {asset: file_digest(resolve(asset)) for asset in
              ("arkit-reference-rig", "arkit-landmarks", "flame-landmarks", "flame-head-idx")}
    inputs["assets"] = assets
    synthetic = getattr(corpus, "synthetic", None)
    if synthetic:
        inputs["synthetic"] = {"seed": synthetic.get("seed"), "version": synthetic.get("version")}
    return {
        "tool": "blendvoca.build",
        "version": version,
        "parameters": params,
        "inputs": inputs,
        "failures": failures,
        "files": {rel: file_digest(Path(out) / rel) for rel in output_files(out)},
    }


def write_manifest(out, **kwargs) -> Path:
    """Write ``<out>/manifest.json`` atomically and return its path."""
    data = manifest_dict(out, **kwargs)
    path = Path(out) / MANIFEST_NAME
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(json.dumps(data, indent=1, sort_keys=True) + "\n")
    return path
