"""``build_dataset``: every speaker's rig, every sentence's coefficients, report, manifest.

Stages (each a pure function; this module only reads and writes files):

1. speakers (parallel): :func:`blendvoca.builder.speaker.speaker_rig` ->
   ``rigs/<subject>.npz``, ``templates_head/<subject>.obj``,
   ``blendshapes_head/<subject>/<name>.obj``;
2. sentences (parallel): :func:`blendvoca.builder.sentence.sentence_fit` ->
   ``blendshape_coeffs/<subject>/<sentence>.csv``, ``audio/<subject>/<sentence>.wav``;
2b. oracle samples (synthetic corpora generated with ``--oracle-samples K`` only;
   parallel): each of a sentence's K conditional samples rendered
   (:class:`blendvoca.synthetic.oracle.OracleSamples`) and fitted like the ground
   truth -> ``oracle_coeffs/<subject>/<sentence>-<k>.csv``;
3. summary: ``coeffs_std.csv``, ``splits.json``, ``report/``, ``manifest.json``.

The build's recipe id (:func:`blendvoca.format.make_recipe`: every corpus file's
digest, the assets', the data-format version and the parameters) is computed
before any output is written and stored in the manifest: it is the dataset's
identity on every machine, whatever BLAS kernel rounds the fits.

Every stage has a record in ``.buildstate/`` keyed by a digest of its inputs
and parameters, written after its outputs (which are written atomically): a
rerun skips what is up to date, redoes what an interruption cut short or what
a changed input or parameter touches, and writes byte-identical files.
The names and formats of what it writes are :mod:`blendvoca.format`'s.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import blendvoca
from blendvoca import format as fmt
from blendvoca.errors import BlendVOCAError, DataError, OutputDirError, UserError
from blendvoca.format.hashing import array_digest, file_digest, stage_key
from blendvoca.format.manifest import remove_manifest
from blendvoca.runtime.processes import WorkerStartError, is_worker_process, process_map
from blendvoca.runtime.progress import progress_bars, show_progress
from blendvoca.runtime.threads import limit_threads, limited_threads

from .outdir import (
    build_lock,
    check_output_dir,
    claim_output_dir,
    drop_inherited_locks,
    is_fatal_write_error,
    remove_own_outputs,
    remove_stale_temporaries,
    unwritable,
)
from .report import REPORT_FILES
from .state import STATE_DIR, is_up_to_date, read_record, record_path, write_record

#: Bumped when a stage's algorithm changes its outputs (invalidates records).
RIG_STAGE_VERSION = "2"  # 2: one triangle correspondence per build, on the reference speaker
FIT_STAGE_VERSION = "1"
ORACLE_STAGE_VERSION = "1"
AUDIO_RATE = fmt.AUDIO_RATE
#: Inner-lip landmarks (0-based) of the 68-point scheme: upper and lower lip middle.
LIP_LANDMARKS = (62, 66)
FLAME_VERTICES = 5023


class BuildInputError(UserError):
    """A build argument or a corpus-level condition that rules the build out (checked before any work)."""


@dataclass
class BuildSummary:
    """What a build did.

    Attributes
    ----------
    out : Path
    built, skipped : dict
        ``{"speakers": n, "sentences": n}`` redone / already up to date (and
        ``"oracle": n`` sentences' oracle samples, for a corpus that has them).
    failures : list of dict
        ``{"subject", "sentence", "stage", "reason"}`` per failed item; ``stage`` is
        ``"rig"``, ``"fit"`` or ``"input"`` (a sentence the corpus lacks, or one
        built before that is no longer in it).
    warnings : list of dict
        ``{"subject", "sentence", "message"}`` per implausible input that was
        built all the same (audio and motion of different lengths); in the report too.
    """

    out: Path
    built: dict = field(default_factory=lambda: {"speakers": 0, "sentences": 0})
    skipped: dict = field(default_factory=lambda: {"speakers": 0, "sentences": 0})
    failures: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.failures


# ----------------------------------------------------------------------------- context


def _static_inputs(shapes, corpus=None):
    """Asset-derived inputs shared by all workers (digests go into stage keys).

    The 68 landmarks and the fitted vertices come from the corpus reader
    (``landmarks()``, ``head_index()``: FLAME's assets for VOCASET-like corpora,
    the user's landmark file for BIWI and Multiface).
    """
    from blendvoca.assets import load_index_list, resolve
    from blendvoca.rig import shape_names

    flame = corpus is None or corpus.num_vertices == FLAME_VERTICES
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
        from blendvoca.vocaset import open_vocaset

        return open_vocaset(root)
    import importlib

    module, _, name = reader.partition(":")
    return getattr(importlib.import_module(module), name)(root)


_WORKER: dict = {}
#: The corpus the build process opened, by root, with that process's id: a worker
#: forked from it uses the same object (opening the processed layout unpickles all
#: of its audio) instead of opening the corpus again.
_OPENED: dict = {}


def _invalidate_manifest(out: Path) -> None:
    """Remove ``manifest.json`` before the first output changes: it is rewritten at the end,
    so an interrupted or failed build never leaves a manifest claiming partial outputs."""
    remove_manifest(out)


def _retire(out: Path, record: dict | None) -> str:
    """Remove a failed or vanished item's previous outputs (the build's own); a note for its reason."""
    removed = remove_own_outputs(out, record)
    return f" (its previous outputs were removed: {', '.join(removed)})" if removed else ""


def _keep_freed_memory() -> bool:
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


def _worker_init(corpus_root, out, params, shared=None):
    """Per-process state: the corpus, static inputs, the shared correspondence, one BLAS thread, kept memory.

    In a worker process it first closes its copies of the build lock
    (:func:`blendvoca.builder.outdir.drop_inherited_locks`).
    """
    if is_worker_process():
        drop_inherited_locks()
    limit_threads(1)
    _keep_freed_memory()
    opened = _OPENED.get(str(corpus_root))
    forked = opened is not None and opened[0] != os.getpid()
    corpus = opened[1] if forked else open_corpus(corpus_root, params.get("reader"))
    _WORKER.clear()
    _WORKER.update(
        corpus=corpus,
        out=Path(out),
        params=params,
        static=_static_inputs(params["shapes"], corpus),
        rigs={},
        shared=shared or {},
    )


def _rig_key(template_digest, faces_digest, static, params, correspondence_template):
    # The rig depends on the template the shared correspondence was computed on
    # (the reference speaker's) as well as on the speaker's own template.
    return stage_key({
        "stage": "rig", "version": RIG_STAGE_VERSION, "shapes": static["shapes"],
        "template": template_digest, "faces": faces_digest, "assets": static["assets"],
        "correspondence_template": correspondence_template,
        "params": {k: params[k] for k in ("shapes",)},
    })


def _reference_rig(static, params):
    """The ARKit reference rig, parsed once per process and only when a rig is (re)built."""
    if "reference" not in static:
        from blendvoca.rig import load_arkit_reference

        static["reference"] = load_arkit_reference(params["shapes"])
    return static["reference"]


def _shared_correspondence(corpus, subjects, out, params):
    """One triangle correspondence for the whole build, computed in the parent process.

    It is computed on the first speaker (corpus order) whose template can be
    read and reused for every speaker (one topology). Returns
    ``{"template": digest, "correspondence": Correspondence or None}``; the
    correspondence is computed only when some rig is out of date (a rerun with
    nothing to do pays only for reading and hashing the templates). ``{}``
    when no template can be read (every rig fails on its own then).
    """
    from blendvoca.retarget import correspondence_for_target
    from blendvoca.vocaset.checks import template_scale_problem

    static = _static_inputs(params["shapes"], corpus)
    faces = corpus.faces
    faces_digest = array_digest(faces)
    reference_template = reference_digest = None
    stale = False
    for subject in subjects:
        try:
            template = corpus.template(subject)
        except Exception:  # that speaker's rig task reports it
            stale = True
            continue
        if template_scale_problem(template):  # that speaker's rig task refuses it
            stale = True
            continue
        digest = array_digest(template)
        if reference_template is None:
            reference_template, reference_digest = template, digest
        key = _rig_key(digest, faces_digest, static, params, reference_digest)
        if not is_up_to_date(out, read_record(record_path(out, "rigs", subject)), key):
            stale = True
        if stale and reference_template is not None:
            break
    if reference_template is None:
        return {}
    shared = {"template": reference_digest, "correspondence": None}
    if stale:
        try:
            with limited_threads(1):  # as in the workers, so shared results match theirs bit for bit
                reference = _reference_rig(static, params)
                shared["correspondence"] = correspondence_for_target(
                    reference.neutral, reference.faces, reference_template, faces,
                    static["reference_landmarks"], static["landmarks"], crop=static["head_index"])
        except Exception:  # each rig task computes (and reports) its own then
            shared["correspondence"] = None
    return shared


# ----------------------------------------------------------------------------- speaker stage


def _speaker_task(subject):
    """Build (or confirm) one speaker's rig; returns a status dict."""
    from blendvoca.rig import Rig

    from .speaker import head_faces, speaker_rig

    corpus, out, params, static, shared = (_WORKER[k] for k in ("corpus", "out", "params", "static", "shared"))
    path = record_path(out, "rigs", subject)
    clock = time.perf_counter()
    try:
        template = corpus.template(subject)
        _check_template_scale(subject, template)
        faces = corpus.faces
        inputs = {"template": array_digest(template), "faces": array_digest(faces)}
        # Without a shared correspondence (no readable reference template) each rig uses its own.
        reference_digest = shared.get("template", inputs["template"])
        key = _rig_key(inputs["template"], inputs["faces"], static, params, reference_digest)
        record = read_record(path)
        if is_up_to_date(out, record, key):
            return {"subject": subject, "status": "skipped", "key": key}
        correspondence = shared.get("correspondence")
        if correspondence is None and reference_digest != inputs["template"]:
            raise DataError(f"{subject}: the correspondence shared by all speakers could not be computed "
                                 "on the reference speaker's template (see that speaker's rig failure)")
        reference = _reference_rig(static, params)
        read_s, clock = time.perf_counter() - clock, time.perf_counter()
        rig = speaker_rig(reference, template, faces, static["reference_landmarks"],
                          static["landmarks"], static["head_index"], correspondence=correspondence)
        compute_s, clock = time.perf_counter() - clock, time.perf_counter()
        _invalidate_manifest(out)
        head = static["head_index"]
        hfaces = head_faces(rig.faces, head, rig.num_vertices)
        files = [fmt.write_rig(out, subject, rig)]
        # SAiD's layout: the head crop of the neutral and of every blendshape
        files += fmt.write_said_rig(out, subject, rig.neutral[head], rig.deltas[:, head], rig.names, hfaces)
        write_record(path, {"key": key, "status": "ok", "subject": subject, "inputs": inputs,
                            "files": {rel: file_digest(out / rel) for rel in sorted(files)}})
        assert isinstance(rig, Rig)
        return {"subject": subject, "status": "built", "key": key,
                "seconds": {"compute": compute_s, "io": read_s + time.perf_counter() - clock}}
    except Exception as error:  # recorded, the build carries on
        return _recorded_failure(out, path, error, {"subject": subject})


def _check_template_scale(subject, template):
    """Refuse a template in another unit than metres: its rig and every fit would be nonsense (errors in metres)."""
    from blendvoca.vocaset.checks import template_scale_problem

    problem = template_scale_problem(template)
    if problem:
        raise DataError(f"{subject}: {problem}")


# ----------------------------------------------------------------------------- sentence stage


def _load_rig(subject):
    rigs = _WORKER["rigs"]
    if subject not in rigs:
        rigs.clear()  # one speaker at a time per worker is enough; bounds memory
        rigs[subject] = fmt.read_rig(_WORKER["out"], subject)
    return rigs[subject]


def _sentence_task(item):
    """Fit (or confirm) one sentence; returns a status dict."""
    from .sentence import lip_aperture, sentence_fit

    subject, sentence, rig_key = item
    corpus, out, params, static = (_WORKER[k] for k in ("corpus", "out", "params", "static"))
    path = record_path(out, "sentences", subject, sentence)
    base = {"subject": subject, "sentence": sentence}
    clock = time.perf_counter()
    try:
        # the frames as stored (float32 in VOCASET), digested as the float64 frames they stand for
        frames = corpus.frames(subject, sentence, dtype=None)
        samples, rate = corpus.audio(subject, sentence)
        inputs = {"frames": array_digest(frames, dtype=np.float64), "audio": array_digest(samples),
                  "audio_rate": int(rate)}
        warnings = _sentence_warnings(corpus, frames, samples, rate)
        key = {
            "stage": "sentence", "version": FIT_STAGE_VERSION, "rig": rig_key,
            "frames": inputs["frames"], "audio": inputs["audio"], "rate": int(rate),
            "delta": params["delta"], "audio_rate": AUDIO_RATE,
        }
        if corpus.posed:  # how the pose was taken out decides the coefficients
            key["pose_fit"] = params["pose_fit"]
        key = stage_key(key)
        record = read_record(path)
        if is_up_to_date(out, record, key):
            return {**base, "status": "skipped", "warnings": warnings}
        _invalidate_manifest(out)
        rig = _load_rig(subject)
        read_s, clock = time.perf_counter() - clock, time.perf_counter()
        coeffs, stats = sentence_fit(rig, frames, static["head_index"], delta=params["delta"], posed=corpus.posed,
                                     pose_fit=params.get("pose_fit", "joint"))
        lips = static["landmarks"][list(LIP_LANDMARKS)]
        stats["lip_aperture_mm"] = [round(float(v) * 1000.0, 6) for v in lip_aperture(frames, *lips)]
        compute_s, clock = time.perf_counter() - clock, time.perf_counter()
        files = [fmt.write_coeffs(out, subject, sentence, coeffs, rig.names),
                 fmt.write_audio(out, subject, sentence, samples, rate)]
        write_record(path, {**base, "key": key, "status": "ok", "stats": stats, "inputs": inputs,
                            "files": {rel: file_digest(out / rel) for rel in files}})
        return {**base, "status": "built", "warnings": warnings,
                "seconds": {"compute": compute_s, "io": read_s + time.perf_counter() - clock}}
    except Exception as error:  # recorded, the build carries on
        return _recorded_failure(out, path, error, base)


def _oracle_inputs(corpus, subject: str, sentence: str) -> dict:
    """What an oracle sample's meshes are made from: its stored draws, the seed and the speaker's style."""
    from blendvoca.synthetic.oracle import OracleSamples

    meta = corpus.synthetic or {}
    oracle = _WORKER.get("oracle")
    if oracle is None:
        oracle = _WORKER["oracle"] = OracleSamples(corpus.root, meta)
    path = oracle.path(subject, sentence)
    if not path.is_file():
        raise DataError(f"{path}: missing; the corpus declares {oracle.count} oracle samples per sentence")
    return {"samples": file_digest(path), "count": oracle.count, "seed": meta.get("seed"),
            "generator": meta.get("version"), "style": (meta.get("subjects", {}).get(subject) or {}).get("style")}


def _oracle_task(item):
    """Render and fit (or confirm) the oracle samples of one sentence; returns a status dict."""
    from blendvoca.format.items import write_oracle_coeffs

    from .sentence import sentence_fit

    subject, sentence, rig_key = item
    corpus, out, params, static = (_WORKER[k] for k in ("corpus", "out", "params", "static"))
    path = record_path(out, "oracle", subject, sentence)
    base = {"subject": subject, "sentence": sentence}
    clock = time.perf_counter()
    try:
        inputs = _oracle_inputs(corpus, subject, sentence)
        key = stage_key({"stage": "oracle", "version": ORACLE_STAGE_VERSION, "rig": rig_key,
                         "inputs": inputs, "delta": params["delta"]})
        record = read_record(path)
        if is_up_to_date(out, record, key):
            return {**base, "status": "skipped", "key": key}
        _invalidate_manifest(out)
        rig = _load_rig(subject)
        oracle = _WORKER["oracle"]
        read_s, clock = time.perf_counter() - clock, time.perf_counter()
        files, rmse = [], []
        for k, frames in enumerate(oracle.frames(subject, sentence, template=corpus.template(subject))):
            coeffs, stats = sentence_fit(rig, frames, static["head_index"], delta=params["delta"])
            files.append(write_oracle_coeffs(out, subject, sentence, k, coeffs, rig.names))
            rmse.append(stats["rmse_mm"])
        compute_s, clock = time.perf_counter() - clock, time.perf_counter()
        write_record(path, {**base, "key": key, "status": "ok", "inputs": inputs, "stats": {"rmse_mm": rmse},
                            "files": {rel: file_digest(out / rel) for rel in files}})
        return {**base, "status": "built", "key": key,
                "seconds": {"compute": compute_s, "io": read_s + time.perf_counter() - clock}}
    except Exception as error:  # recorded, the build carries on
        return _recorded_failure(out, path, error, base)


def _sentence_warnings(corpus, frames, samples, rate) -> list[str]:
    """What is implausible about a sentence that is built all the same (audio and motion durations)."""
    from blendvoca.vocaset.checks import duration_mismatch

    mismatch = duration_mismatch(len(frames), corpus.fps, len(samples), rate)
    return [mismatch] if mismatch else []


def _recorded_failure(out: Path, path: Path, error: BaseException, base: dict) -> dict:
    """Record a failed item (speaker or sentence, named by ``base``) and return its summary
    entry; its previous outputs are removed. A write that cannot succeed anywhere (disk
    full, read-only folder) is not an item's failure: it ends the build."""
    if is_fatal_write_error(error):
        raise unwritable(error, out) from None
    _invalidate_manifest(out)
    reason = _reason(error) + _retire(out, read_record(path))
    write_record(path, {**base, "status": "failed", "reason": reason})
    return {**base, "status": "failed", "reason": reason}


def _reason(error: BaseException) -> str:
    if isinstance(error, BlendVOCAError):  # its message already says what and where
        return str(error)
    return f"{type(error).__name__}: {error}"


# ----------------------------------------------------------------------------- driver


def _run(tasks, function, *, workers, initargs, desc):
    """``function`` over ``tasks`` in ``workers`` processes (here for 1), set up by `_worker_init`; the results in order."""
    return list(process_map(function, tasks, workers=workers, initializer=_worker_init, initargs=initargs, desc=desc))


def default_output_dir() -> Path:
    """Where the bundled-default BlendVOCA is built: ``<user cache>/blendvoca-default``.

    ``python -m blendvoca.build`` without ``--out`` writes here, and the benchmark
    runner reads from here when it is given no ``--data``.
    """
    from blendvoca.assets import cache_dir

    return cache_dir() / "blendvoca-default"


def build_dataset(
    out,
    vocaset=None,
    *,
    workers: int | None = None,
    shapes: str = "speech",
    delta: float = 0.1,
    report: bool = True,
    progress: bool = True,
    reader: str | None = None,
    pose_fit: str = "joint",
) -> BuildSummary:
    """Build BlendVOCA from a VOCASET corpus into ``out`` (resumable).

    Parameters
    ----------
    out : path
        Output folder (SAiD's layout plus ``rigs/``, ``splits.json``,
        ``manifest.json``, ``report/``).
    vocaset : path, optional
        VOCASET root (official or processed layout); default: the bundled
        synthetic corpus, generated once into the user cache.
    workers : int, optional
        Processes (default: all cores).
    shapes : {"speech", "all"}
        The 32 BlendVOCA shapes or all ARKit shapes of the reference rig.
    delta : float
        Rate bound of the fit.
    report : bool
        Write ``report/`` (Markdown + PNG figures).
    progress : bool
        Progress bars on stderr.
    reader : str, optional
        ``"module:callable"`` opening the corpus at ``vocaset`` (the readers of
        :mod:`blendvoca.datasets`, e.g. ``"blendvoca.datasets.biwi:open_biwi"``);
        default VOCASET's (official or processed layout).
    pose_fit : {"joint", "remove"}
        How the frames of a posed corpus (its reader's ``posed``) are unposed:
        the joint pose and expression fit, or the pose removal then the fit
        (:func:`blendvoca.builder.sentence.sentence_fit`).

    Returns
    -------
    BuildSummary
        Failed items (unreadable or empty inputs, templates of implausible
        scale, fits that failed, sentences that left the corpus) are listed in
        ``failures``, the report and the manifest; implausible inputs built all
        the same (audio and motion durations more than 5 % apart) in
        ``warnings`` and the report.

    Raises
    ------
    BlendVOCAError
        Before any work: bad arguments (``workers < 1``, ``delta <= 0``), a
        corpus that cannot be read or split (fewer than 3 speakers), unsafe
        names, missing or corrupted assets, an ``out`` that is a file, the
        corpus, inside it, not empty and not a previous build, holding a
        symbolic link among the build's folders and files, or locked by
        another build (:class:`OutputDirError`). During the build: output that
        cannot be written (disk full, read-only; no manifest is left) and
        worker processes that cannot start (``WorkerStartError``) or die (``WorkerDied``).
    """
    from .sentence import POSE_FITS

    # Everything a user can get wrong is checked before any work (and before --out is touched).
    if shapes not in ("speech", "all"):
        raise BuildInputError(f"--shapes: expected 'speech' or 'all', got {shapes!r}")
    if pose_fit not in POSE_FITS:
        raise BuildInputError(f"--pose-fit: expected one of {', '.join(POSE_FITS)}, got {pose_fit!r}")
    workers = check_workers(workers)
    delta = check_delta(delta)
    if vocaset is None:
        from blendvoca.synthetic import default_corpus

        vocaset = default_corpus(progress=progress)
    out = Path(out).expanduser().resolve()
    vocaset = Path(vocaset).expanduser().resolve()
    check_output_dir(out, vocaset)
    corpus = open_corpus(vocaset, reader)
    check_corpus(corpus)
    params = {"shapes": shapes, "delta": float(delta)}
    if reader is not None:  # recorded in the manifest's parameters: how the corpus was read
        params["reader"] = reader
    if corpus.posed:
        params["pose_fit"] = pose_fit
    static = _static_inputs(shapes, corpus)  # every asset resolved and verified here, once, before any worker starts
    corpus.faces  # noqa: B018 - the topology (or the flame-sample asset it falls back to), checked here too
    # The identity, known before any output; the topology is read from the corpus or an asset.
    recipe = build_recipe(vocaset, params, {**static["assets"], "topology": array_digest(corpus.faces)})
    claim_output_dir(out)
    with build_lock(out):
        try:
            with progress_bars(progress and show_progress()):
                return _build(out, vocaset, corpus, params, workers=workers, report=report, recipe=recipe)
        except OutputDirError:
            remove_manifest(out)
            raise
        except OSError as error:
            if is_fatal_write_error(error):
                remove_manifest(out)
                raise unwritable(error, out) from None
            raise


def check_workers(workers) -> int:
    """``workers`` as an int >= 1 (None: all cores); anything else raises `BuildInputError`."""
    if workers is None:
        return max(1, os.cpu_count() or 1)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise BuildInputError(f"--workers: expected an integer >= 1, got {workers!r}")
    return int(workers)


def check_delta(delta) -> float:
    """``delta`` as a finite float > 0; anything else raises `BuildInputError`."""
    try:
        value = float(delta)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value) or value <= 0:
        raise BuildInputError(f"--delta: expected a rate bound > 0 per 60 fps frame (e.g. 0.1), got {delta!r}")
    return value


def check_corpus(corpus) -> dict:
    """Corpus-level conditions checked before any work: speakers, sentences, the split.

    Returns
    -------
    dict
        The corpus splits.
    """
    where = corpus.root
    if not corpus.subjects:
        raise BuildInputError(f"{where}: the corpus has no speakers")
    if not corpus.items():
        raise BuildInputError(f"{where}: the corpus has no sentence with mesh frames")
    try:
        return corpus.splits
    except ValueError as error:
        raise BuildInputError(f"{where}: cannot split the speakers into train/val/test: {error}") from None


def _stale_records(out: Path, stage: str, current: set) -> list[tuple[tuple, Path]]:
    """Records of ``stage`` whose item (``(subject,)`` or ``(subject, sentence)``) is not in ``current``."""
    root = out / STATE_DIR / stage
    found = []
    for path in sorted(root.rglob("*.json")) if root.is_dir() else []:
        item = tuple(path.relative_to(root).with_suffix("").parts)
        if item not in current:
            found.append((item, path))
    return found


def _retire_vanished(out: Path, stage: str, current: set, summary, problems: dict) -> None:
    """Items built before that the corpus no longer has: remove their outputs and records, report them."""
    for item, path in _stale_records(out, stage, current):
        record = read_record(path)
        _invalidate_manifest(out)
        note = _retire(out, record)
        path.unlink()
        subject, sentence = (item + (None,))[:2]
        problem = problems.pop((subject, sentence), None)
        why = str(problem.message) if problem is not None else "no longer in the corpus"
        summary.failures.append({"subject": subject, "sentence": sentence, "stage": "input",
                                 "reason": f"{why}; built before{note or ' (no outputs left)'}"})


def _task_seconds(results) -> dict:
    """``{"compute": s, "io": s}`` summed over the built items' task results."""
    seconds = {"compute": 0.0, "io": 0.0}
    for result in results:
        for kind, value in result.get("seconds", {}).items():
            seconds[kind] += value
    return seconds


#: The data-format version of a build's recipe: the folder format's and the stages' algorithm
#: versions, so that a stage whose outputs change gives its builds another identity.
RECIPE_FORMAT = f"{fmt.FORMAT_VERSION}/rig{RIG_STAGE_VERSION}/fit{FIT_STAGE_VERSION}/oracle{ORACLE_STAGE_VERSION}"


def build_recipe(vocaset, params: dict, assets: dict) -> dict:
    """The recipe of building the corpus at ``vocaset`` with ``params`` (``assets``: ``{asset id: sha256}``)."""
    return fmt.make_recipe(fmt.corpus_files(vocaset), params, root=vocaset, assets=assets,
                           format_version=RECIPE_FORMAT)


def _build(out, vocaset, corpus, params, *, workers, report, recipe=None):
    _OPENED.clear()
    _OPENED[str(vocaset)] = (os.getpid(), corpus)
    try:
        return _build_stages(out, vocaset, corpus, params, workers=workers, report=report,
                             recipe=recipe)
    finally:
        _OPENED.clear()


def _declared_share(corpus) -> dict | None:
    """The synthetic corpus's declared audio-determined share and oracle sample count, when it
    declares either (None for VOCASET and for corpora made before they existed)."""
    meta = corpus.synthetic
    if not isinstance(meta, dict) or not ("audio_determined" in meta or "oracle_samples" in meta):
        return None
    from blendvoca.synthetic.oracle import oracle_count

    declared = meta.get("audio_determined")
    return {"declared": declared.get("declared") if isinstance(declared, dict) else 1.0,
            "oracle_samples": oracle_count(meta)}


def _build_stages(out, vocaset, corpus, params, *, workers, report, recipe=None):
    remove_stale_temporaries(out)
    summary = BuildSummary(out)
    initargs = (str(vocaset), str(out), params)
    # Problems the corpus found when it was opened for sentences that get no task (missing, unreadable index).
    problems = {(p.subject, p.sentence): p for p in corpus.problems
                if p.sentence is not None and p.sentence not in corpus.sentences(p.subject)}

    clock = time.perf_counter()
    subjects = list(corpus.subjects)
    _retire_vanished(out, "rigs", {(s,) for s in subjects}, summary, {})
    shared_clock = time.perf_counter()
    shared = _shared_correspondence(corpus, subjects, out, params)
    shared_s = time.perf_counter() - shared_clock
    speaker_results = _run(subjects, _speaker_task, workers=workers, initargs=initargs + (shared,),
                           desc="speaker rigs")
    rig_keys = {}
    for result in speaker_results:
        if result["status"] == "failed":
            summary.failures.append({"subject": result["subject"], "sentence": None, "stage": "rig",
                                     "reason": result["reason"]})
            continue
        key = "built" if result["status"] == "built" else "skipped"
        getattr(summary, key)["speakers"] += 1
        rig_keys[result["subject"]] = result["key"]

    summary.seconds["rigs"] = time.perf_counter() - clock
    stages = {"rigs": {**_task_seconds(speaker_results), "wall": summary.seconds["rigs"],
                       "built": summary.built["speakers"]}}
    stages["rigs"]["compute"] += shared_s  # the shared correspondence (reading the templates included)
    clock = time.perf_counter()
    items = [(s, q, rig_keys[s]) for s in subjects if s in rig_keys for q in corpus.sentences(s)]
    _retire_vanished(out, "sentences", {(s, q) for s in subjects for q in corpus.sentences(s)}, summary, problems)
    for subject in subjects:
        if subject not in rig_keys:
            for sentence in corpus.sentences(subject):
                path = record_path(out, "sentences", subject, sentence)
                reason = "no rig for this speaker (see the rig failure)" + _retire(out, read_record(path))
                if path.exists():
                    write_record(path, {"subject": subject, "sentence": sentence, "status": "failed", "reason": reason})
                summary.failures.append({"subject": subject, "sentence": sentence, "stage": "fit", "reason": reason})
    sentence_results = _run(items, _sentence_task, workers=workers, initargs=initargs,
                            desc="sentences")
    for result in sentence_results:
        for message in result.get("warnings", ()):
            summary.warnings.append({"subject": result["subject"], "sentence": result["sentence"],
                                     "message": message})
        if result["status"] == "failed":
            summary.failures.append({"subject": result["subject"], "sentence": result["sentence"],
                                     "stage": "fit", "reason": result["reason"]})
        else:
            key = "built" if result["status"] == "built" else "skipped"
            getattr(summary, key)["sentences"] += 1
    for (subject, sentence), problem in sorted(problems.items()):
        summary.failures.append({"subject": subject, "sentence": sentence, "stage": "input",
                                 "reason": problem.message})

    summary.seconds["sentences"] = time.perf_counter() - clock
    stages["fits"] = {**_task_seconds(sentence_results), "wall": summary.seconds["sentences"],
                      "built": summary.built["sentences"]}
    oracle_items = _oracle_stage(out, corpus, subjects, sentence_results, rig_keys, summary, stages,
                                 workers=workers, initargs=initargs)
    clock = time.perf_counter()
    report_s = _write_summary_files(out, corpus, vocaset, subjects, params, summary, report=report,
                                    oracle_items=oracle_items, recipe=recipe)
    summary.seconds["summary"] = time.perf_counter() - clock
    if report_s is not None or summary.built["speakers"] or summary.built["sentences"]:
        # Something was done: the timings of this build (a no-op rerun leaves them as they are).
        from .report import TIMINGS, write_timings

        if report:
            stages["summary"] = {"wall": summary.seconds["summary"], "report": report_s or 0.0}
            write_timings(out, stages, workers=workers)
        elif (out / TIMINGS).is_file():
            (out / TIMINGS).unlink()  # this build writes no report; older timings would look current
    return summary


def _oracle_stage(out, corpus, subjects, sentence_results, rig_keys, summary, stages, *, workers,
                  initargs) -> list[tuple[str, str]]:
    """Fit the oracle samples of every fitted sentence of a corpus that has them; return those sentences.

    A corpus without oracle samples runs nothing here (and a build of one is what it was
    before oracle samples existed); the oracle outputs of a previous build of a corpus
    that no longer has them (or of sentences it no longer has) are removed.
    """
    from blendvoca.synthetic.oracle import oracle_count

    count = oracle_count(corpus.synthetic)
    fitted = {(r["subject"], r["sentence"]) for r in sentence_results if r["status"] != "failed"}
    items = [(s, q) for s in subjects for q in corpus.sentences(s) if (s, q) in fitted] if count else []
    for item, path in _stale_records(out, "oracle", set(items)):
        _invalidate_manifest(out)
        _retire(out, read_record(path))
        path.unlink()
    if not items:
        return []
    clock = time.perf_counter()
    results = _run([(s, q, rig_keys[s]) for s, q in items], _oracle_task, workers=workers, initargs=initargs,
                   desc="oracle samples")
    done = []
    summary.built["oracle"] = summary.skipped["oracle"] = 0
    for result in results:
        if result["status"] == "failed":
            summary.failures.append({"subject": result["subject"], "sentence": result["sentence"],
                                     "stage": "oracle", "reason": result["reason"]})
        else:
            done.append((result["subject"], result["sentence"]))
            (summary.built if result["status"] == "built" else summary.skipped)["oracle"] += 1
    summary.seconds["oracle"] = time.perf_counter() - clock
    stages["oracle"] = {**_task_seconds(results), "wall": summary.seconds["oracle"],
                        "built": sum(r["status"] == "built" for r in results)}
    return done


#: What the summary stage writes (besides the manifest), relative to ``out``.
SUMMARY_OUTPUTS = (fmt.COEFFS_STD_FILE, fmt.RESIDUALS_FILE, fmt.SPLITS_FILE,
                   *(f"{fmt.REPORT_DIR}/{name}" for name in REPORT_FILES))


def _write_summary_files(out, corpus, vocaset, subjects, params, summary, *, report, oracle_items=(), recipe=None):
    """Write the summary outputs unless up to date; return the seconds spent on the report (None: up to date)."""
    from blendvoca.format.manifest import write_manifest

    from .report import coeffs_std, write_report

    records = {}
    names = None
    summary_path = record_path(out, "summary", "summary")
    keys = {f"{s}/{q}": (read_record(record_path(out, "sentences", s, q)) or {}).get("key")
            for s in subjects for q in corpus.sentences(s)}
    keys.update({s: (read_record(record_path(out, "rigs", s)) or {}).get("key") for s in subjects})
    oracle_records = {(s, q): read_record(record_path(out, "oracle", s, q)) or {} for s, q in oracle_items}
    extra = {}
    if summary.warnings:
        extra["warnings"] = summary.warnings
    if oracle_records:  # only then: the summary of a build without oracle samples is keyed as before
        extra["oracle"] = {f"{s}/{q}": rec.get("key") for (s, q), rec in sorted(oracle_records.items())}
    share = _declared_share(corpus)
    if share is not None:
        extra["share"] = share
    if recipe is not None:  # the manifest records it: another recipe, another manifest
        extra["recipe"] = recipe["id"]
    summary_key = stage_key({"stage": "summary", "keys": keys, "failures": summary.failures, "params": params,
                             "report": report, "version": blendvoca.__version__, "splits": corpus.splits,
                             **extra})
    previous = read_record(summary_path)
    if is_up_to_date(out, previous, summary_key):
        return None
    _invalidate_manifest(out)
    # The previous summary's own files go first: a report or coeffs_std.csv this build does not
    # write again must not stay behind looking current.
    remove_own_outputs(out, {"files": {rel: d for rel, d in ((previous or {}).get("files") or {}).items()
                                       if rel in SUMMARY_OUTPUTS}})
    files = []
    rig_records = {}
    for subject in subjects:
        rig_record = rig_records[subject] = read_record(record_path(out, "rigs", subject))
        if rig_record and rig_record.get("status") == "ok":
            files += list(rig_record.get("files", {}))
    tracks = []
    for subject in subjects:
        for sentence in corpus.sentences(subject):
            rec = read_record(record_path(out, "sentences", subject, sentence))
            if rec and rec.get("status") == "ok":
                records[(subject, sentence)] = rec
                files += list(rec.get("files", {}))
                coeffs, names = fmt.read_coeffs(out, subject, sentence)
                tracks.append(coeffs)
    for rec in oracle_records.values():
        files += list(rec.get("files", {}))
    if tracks:
        fmt.write_coeffs_std(out, coeffs_std(tracks), names)
    from .said_residuals import write_blendshape_residuals
    write_blendshape_residuals(out, subjects)
    fmt.write_splits(out, corpus.splits)
    report_s = 0.0
    if report:
        clock = time.perf_counter()
        measured = None
        if share is not None:
            from .report import measured_share

            measured = measured_share(out, corpus.splits, sorted(oracle_records), names or (),
                                      count=share["oracle_samples"], declared=share)
        write_report(out, records, names or (), summary.failures, params, warnings=summary.warnings,
                     share=measured)
        report_s = time.perf_counter() - clock
    files += [rel for rel in SUMMARY_OUTPUTS if (out / rel).is_file()]
    manifest = write_manifest(out, files=files, vocaset=vocaset, corpus=corpus, params=params, records=records,
                              rig_records=rig_records, failures=summary.failures, version=blendvoca.__version__,
                              recipe=recipe)
    listed = fmt.listed_files(out)
    listed[fmt.MANIFEST_FILE] = file_digest(manifest)
    write_record(summary_path, {"key": summary_key, "status": "ok", "files": listed})
    return report_s
