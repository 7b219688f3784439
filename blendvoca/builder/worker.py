"""The build's worker processes: what each holds (the corpus, the static inputs, the shared
correspondence) and how a failed item is recorded.

The build runs its stages on :func:`blendvoca.runtime.processes.process_map` with
:func:`worker_init` as the initializer; a task reads its process's state from :data:`WORKER`.
"""

from __future__ import annotations

import importlib
import os
import time
from pathlib import Path

from blendvoca.assets import load_index_list, resolve
from blendvoca.format.hashing import array_digest, file_digest
from blendvoca.format.manifest import remove_manifest
from blendvoca.rig import shape_names
from blendvoca.runtime.processes import failure_reason, is_worker_process
from blendvoca.runtime.threads import limit_threads
from blendvoca.vocaset import open_vocaset
from blendvoca.vocaset.splits import NUM_VERTICES

from .outdir import drop_inherited_locks, is_fatal_write_error, remove_own_outputs, unwritable
from .state import read_record, write_record


def static_inputs(shapes, corpus=None):
    """Asset-derived inputs shared by all workers (digests go into stage keys).

    The 68 landmarks and the fitted vertices come from the corpus reader
    (``landmarks()``, ``head_index()``: FLAME's assets for VOCASET-like corpora,
    the user's landmark file for BIWI and Multiface).
    """
    flame = corpus is None or corpus.num_vertices == NUM_VERTICES
    assets = ("arkit-reference-rig", "arkit-landmarks") + (("flame-landmarks", "flame-head-idx") if flame else ())
    static = {
        "shapes": list(shape_names(shapes)),
        "reference_landmarks": load_index_list("arkit-landmarks"),
        "landmarks": load_index_list("flame-landmarks") if corpus is None else corpus.landmarks(),
        "head_index": load_index_list("flame-head-idx") if corpus is None else corpus.head_index(),
        "assets": {asset: file_digest(resolve(asset)) for asset in assets},
    }
    if not flame:  # another topology: the user's landmark file and the fitted vertices take part in every rig
        static["assets"]["landmarks"] = array_digest(static["landmarks"])
        static["assets"]["head_index"] = array_digest(static["head_index"])
    return static


def open_corpus(root, reader=None):
    """The corpus at ``root`` read by ``reader`` (``"module:callable"``; default VOCASET's ``open_vocaset``)."""
    if reader is None:
        return open_vocaset(root)
    module, _, name = reader.partition(":")
    return getattr(importlib.import_module(module), name)(root)


WORKER: dict = {}
#: The corpus the build process opened, by root, with that process's id: a worker
#: forked from it uses the same object (opening the processed layout unpickles all
#: of its audio) instead of opening the corpus again.
OPENED: dict = {}


def retire(out: Path, record: dict | None) -> str:
    """Remove a failed or vanished item's previous outputs (the build's own); a note for its reason."""
    removed = remove_own_outputs(out, record)
    return f" (its previous outputs were removed: {', '.join(removed)})" if removed else ""


def keep_freed_memory() -> bool:
    """Ask glibc's malloc to serve large blocks from its heap and to keep freed ones.

    Every sentence allocates the same few arrays of tens of MB (its frames, their
    crop, the fit's products).  By default glibc maps each such block afresh and
    unmaps it when freed, so the kernel zeroes every page again for the next
    sentence: about a sixth of a worker's time.  Kept, the blocks are reused.
    Returns False where the C library is not glibc (nothing changes there).
    """
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3
    return bool(mallopt(m_mmap_threshold, 512 << 20)) and bool(mallopt(m_trim_threshold, 1 << 30))


def worker_init(corpus_root, out, params, shared=None):
    """Per-process state: the corpus, static inputs, the shared correspondence, one BLAS thread, kept memory.

    In a worker process it first closes its copies of the build lock
    (:func:`blendvoca.builder.outdir.drop_inherited_locks`).
    """
    if is_worker_process():  # the build process itself limits its threads for the run (pipeline._run)
        drop_inherited_locks()
        limit_threads(1)
    keep_freed_memory()
    opened = OPENED.get(str(corpus_root))
    forked = opened is not None and opened[0] != os.getpid()
    corpus = opened[1] if forked else open_corpus(corpus_root, params.get("reader"))
    WORKER.clear()
    WORKER.update(corpus=corpus, out=Path(out), params=params, static=static_inputs(params["shapes"], corpus),
                  rigs={}, shared=shared or {})


def record_built(path: Path, record: dict, files, *, read_s: float, compute_s: float, clock: float) -> dict:
    """Write an item's "ok" ``record`` with the sha256 of its ``files`` (relative to the build); return the
    seconds it took: ``compute``, and ``io`` (``read_s`` before the computation plus the writing since ``clock``)."""
    out = WORKER["out"]
    write_record(path, {**record, "status": "ok", "files": {rel: file_digest(out / rel) for rel in files}})
    return {"compute": compute_s, "io": read_s + time.perf_counter() - clock}


def recorded_failure(out: Path, path: Path, error: BaseException, base: dict) -> dict:
    """Record a failed item (speaker or sentence, named by ``base``) and return its summary
    entry; its previous outputs are removed. A write that cannot succeed anywhere (disk
    full, read-only folder) is not an item's failure: it ends the build."""
    if is_fatal_write_error(error):
        raise unwritable(error, out) from None
    remove_manifest(out)
    reason = failure_reason(error) + retire(out, read_record(path))
    write_record(path, {**base, "status": "failed", "reason": reason})
    return {**base, "status": "failed", "reason": reason}
