"""``build_dataset``: every speaker's rig, every sentence's coefficients, report, manifest.

Stages (each a pure function; this module only reads and writes files):

1. speakers (parallel): :func:`blendvoca.build.speaker.speaker_rig` ->
   ``rigs/<subject>.npz``, ``templates_head/<subject>.obj``,
   ``blendshapes_head/<subject>/<name>.obj``;
2. sentences (parallel): :func:`blendvoca.build.sentence.sentence_fit` ->
   ``blendshape_coeffs/<subject>/<sentence>.csv``, ``audio/<subject>/<sentence>.wav``;
3. summary: ``coeffs_std.csv``, ``splits.json``, ``report/``, ``manifest.json``.

Every stage has a record in ``.buildstate/`` keyed by a digest of its inputs
and parameters, written after its outputs (which are written atomically): a
rerun skips what is up to date, redoes what an interruption cut short or what
a changed input or parameter touches, and writes byte-identical files.
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import blendvoca
from blendvoca.io.atomic import atomic_write

from .hashing import array_digest, file_digest, stage_key
from .state import is_up_to_date, read_record, record_path, remove_stale_temporaries, write_record

#: Bumped when a stage's algorithm changes its outputs (invalidates records).
RIG_STAGE_VERSION = "1"
FIT_STAGE_VERSION = "1"
AUDIO_RATE = 16000
#: Inner-lip landmarks (0-based) of the 68-point scheme: upper and lower lip middle.
LIP_LANDMARKS = (62, 66)


@dataclass
class BuildSummary:
    """What a build did.

    Attributes
    ----------
    out : Path
    built, skipped : dict
        ``{"speakers": n, "sentences": n}`` redone / already up to date.
    failures : list of dict
        ``{"subject", "sentence", "stage", "reason"}`` per failed item.
    """

    out: Path
    built: dict = field(default_factory=lambda: {"speakers": 0, "sentences": 0})
    skipped: dict = field(default_factory=lambda: {"speakers": 0, "sentences": 0})
    failures: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.failures


# ----------------------------------------------------------------------------- context


def _static_inputs(shapes):
    """Asset-derived inputs shared by all workers (digests go into stage keys)."""
    from blendvoca.assets import load_index_list, resolve
    from blendvoca.rig import shape_names

    return {
        "shapes": list(shape_names(shapes)),
        "reference_landmarks": load_index_list("arkit-landmarks"),
        "flame_landmarks": load_index_list("flame-landmarks"),
        "head_index": load_index_list("flame-head-idx"),
        "assets": {
            asset: file_digest(resolve(asset))
            for asset in ("arkit-reference-rig", "arkit-landmarks", "flame-landmarks", "flame-head-idx")
        },
    }


_WORKER: dict = {}


def _worker_init(corpus_root, out, params):
    """Per-process state: the corpus, static inputs, one BLAS thread."""
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover
        pass
    from blendvoca.vocaset import open_vocaset

    _WORKER.clear()
    _WORKER.update(
        corpus=open_vocaset(corpus_root),
        out=Path(out),
        params=params,
        static=_static_inputs(params["shapes"]),
        rigs={},
    )


def _rig_key(template_digest, faces_digest, static, params):
    return stage_key({
        "stage": "rig", "version": RIG_STAGE_VERSION, "shapes": static["shapes"],
        "template": template_digest, "faces": faces_digest, "assets": static["assets"],
        "params": {k: params[k] for k in ("shapes",)},
    })


# ----------------------------------------------------------------------------- speaker stage


def _speaker_task(subject):
    """Build (or confirm) one speaker's rig; returns a status dict."""
    from blendvoca.io.mesh import write_obj
    from blendvoca.rig import Rig

    from .speaker import head_faces, speaker_rig

    corpus, out, params, static = (_WORKER[k] for k in ("corpus", "out", "params", "static"))
    path = record_path(out, "rigs", subject)
    try:
        template = corpus.template(subject)
        faces = corpus.faces
        inputs = {"template": array_digest(template), "faces": array_digest(faces)}
        key = _rig_key(inputs["template"], inputs["faces"], static, params)
        record = read_record(path)
        if is_up_to_date(out, record, key):
            return {"subject": subject, "status": "skipped", "key": key}
        if "reference" not in static:  # parsed only when a rig is (re)built
            from blendvoca.rig import load_arkit_reference

            static["reference"] = load_arkit_reference(params["shapes"])
        rig = speaker_rig(static["reference"], template, faces, static["reference_landmarks"],
                          static["flame_landmarks"], static["head_index"])
        head = static["head_index"]
        hfaces = head_faces(rig.faces, head, rig.num_vertices)
        files = [f"rigs/{subject}.npz", f"templates_head/{subject}.obj"]
        rig.save(out / files[0])
        write_obj(out / files[1], rig.neutral[head], hfaces)
        for name, delta in zip(rig.names, rig.deltas):
            rel = f"blendshapes_head/{subject}/{name}.obj"
            write_obj(out / rel, (rig.neutral + delta)[head], hfaces)
            files.append(rel)
        write_record(path, {"key": key, "status": "ok", "subject": subject, "inputs": inputs,
                            "files": {rel: file_digest(out / rel) for rel in sorted(files)}})
        assert isinstance(rig, Rig)
        return {"subject": subject, "status": "built", "key": key}
    except Exception as error:  # recorded, the build carries on
        write_record(path, {"status": "failed", "subject": subject, "reason": _reason(error)})
        return {"subject": subject, "status": "failed", "reason": _reason(error)}


# ----------------------------------------------------------------------------- sentence stage


def _load_rig(subject):
    from blendvoca.rig import Rig

    rigs = _WORKER["rigs"]
    if subject not in rigs:
        rigs.clear()  # one speaker at a time per worker is enough; bounds memory
        rigs[subject] = Rig.load(_WORKER["out"] / "rigs" / f"{subject}.npz")
    return rigs[subject]


def _sentence_task(item):
    """Fit (or confirm) one sentence; returns a status dict."""
    from blendvoca.io.audio import resample_audio, to_mono, write_wav
    from blendvoca.io.coeffs import write_coeffs_csv

    from .sentence import lip_aperture, sentence_fit

    subject, sentence, rig_key = item
    corpus, out, params, static = (_WORKER[k] for k in ("corpus", "out", "params", "static"))
    path = record_path(out, "sentences", subject, sentence)
    base = {"subject": subject, "sentence": sentence}
    try:
        frames = corpus.frames(subject, sentence)
        samples, rate = corpus.audio(subject, sentence)
        inputs = {"frames": array_digest(frames), "audio": array_digest(samples), "audio_rate": int(rate)}
        key = stage_key({
            "stage": "sentence", "version": FIT_STAGE_VERSION, "rig": rig_key,
            "frames": inputs["frames"], "audio": inputs["audio"], "rate": int(rate),
            "delta": params["delta"], "audio_rate": AUDIO_RATE,
        })
        record = read_record(path)
        if is_up_to_date(out, record, key):
            return {**base, "status": "skipped"}
        rig = _load_rig(subject)
        coeffs, stats = sentence_fit(rig, frames, static["head_index"], delta=params["delta"])
        lips = static["flame_landmarks"][list(LIP_LANDMARKS)]
        stats["lip_aperture_mm"] = [round(float(v) * 1000.0, 6) for v in lip_aperture(frames, *lips)]
        files = [f"blendshape_coeffs/{subject}/{sentence}.csv", f"audio/{subject}/{sentence}.wav"]
        write_coeffs_csv(out / files[0], coeffs, rig.names)
        write_wav(out / files[1], resample_audio(to_mono(samples), rate, AUDIO_RATE), AUDIO_RATE)
        write_record(path, {**base, "key": key, "status": "ok", "stats": stats, "inputs": inputs,
                            "files": {rel: file_digest(out / rel) for rel in files}})
        return {**base, "status": "built"}
    except Exception as error:  # recorded, the build carries on
        write_record(path, {**base, "status": "failed", "reason": _reason(error)})
        return {**base, "status": "failed", "reason": _reason(error)}


def _reason(error: BaseException) -> str:
    return f"{type(error).__name__}: {error}"


# ----------------------------------------------------------------------------- driver


def _run(tasks, function, *, workers, initargs, desc, progress):
    """Run ``function`` over ``tasks`` in ``workers`` processes (inline for 1), in order."""
    from tqdm.auto import tqdm

    bar = tqdm(total=len(tasks), desc=desc, unit="item", disable=not progress, file=sys.stderr)
    results = []
    try:
        if workers <= 1 or len(tasks) <= 1:
            _worker_init(*initargs)
            for task in tasks:
                results.append(function(task))
                bar.update()
        else:
            import multiprocessing

            context = multiprocessing.get_context("fork" if sys.platform.startswith("linux") else "spawn")
            with context.Pool(min(workers, len(tasks)), initializer=_worker_init, initargs=initargs) as pool:
                for result in pool.imap(function, tasks, chunksize=1):
                    results.append(result)
                    bar.update()
    finally:
        bar.close()
    return results


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

    Returns
    -------
    BuildSummary
    """
    from blendvoca.vocaset import open_vocaset

    if vocaset is None:
        from blendvoca.synthetic import default_corpus

        vocaset = default_corpus(progress=progress)
    if shapes not in ("speech", "all"):
        raise ValueError(f"build_dataset: shapes must be 'speech' or 'all', got {shapes!r}")
    out = Path(out).expanduser().resolve()
    vocaset = Path(vocaset).expanduser().resolve()
    workers = max(1, int(workers or os.cpu_count() or 1))
    out.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(out)

    params = {"shapes": shapes, "delta": float(delta)}
    corpus = open_vocaset(vocaset)
    summary = BuildSummary(out)
    initargs = (str(vocaset), str(out), params)

    import time

    clock = time.perf_counter()
    subjects = list(corpus.subjects)
    speaker_results = _run(subjects, _speaker_task, workers=workers, initargs=initargs,
                           desc="speaker rigs", progress=progress)
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
    clock = time.perf_counter()
    items = [(s, q, rig_keys[s]) for s in subjects if s in rig_keys for q in corpus.sentences(s)]
    for subject in subjects:
        if subject not in rig_keys:
            for sentence in corpus.sentences(subject):
                summary.failures.append({"subject": subject, "sentence": sentence, "stage": "fit",
                                         "reason": "no rig for this speaker (see the rig failure)"})
    sentence_results = _run(items, _sentence_task, workers=workers, initargs=initargs,
                            desc="sentences", progress=progress)
    for result in sentence_results:
        if result["status"] == "failed":
            summary.failures.append({"subject": result["subject"], "sentence": result["sentence"],
                                     "stage": "fit", "reason": result["reason"]})
        else:
            key = "built" if result["status"] == "built" else "skipped"
            getattr(summary, key)["sentences"] += 1

    summary.seconds["sentences"] = time.perf_counter() - clock
    clock = time.perf_counter()
    _write_summary_files(out, corpus, vocaset, subjects, params, summary, report=report)
    summary.seconds["summary"] = time.perf_counter() - clock
    return summary


def _write_summary_files(out, corpus, vocaset, subjects, params, summary, *, report):
    from blendvoca.io.coeffs import read_coeffs_csv

    from .manifest import write_manifest
    from .report import coeffs_std, write_coeffs_std, write_report

    records = {}
    names = None
    summary_path = record_path(out, "summary", "summary")
    keys = {f"{s}/{q}": (read_record(record_path(out, "sentences", s, q)) or {}).get("key")
            for s in subjects for q in corpus.sentences(s)}
    keys.update({s: (read_record(record_path(out, "rigs", s)) or {}).get("key") for s in subjects})
    summary_key = stage_key({"stage": "summary", "keys": keys, "failures": summary.failures, "params": params,
                             "report": report, "version": blendvoca.__version__, "splits": corpus.splits})
    if is_up_to_date(out, read_record(summary_path), summary_key):
        return
    tracks = []
    for subject in subjects:
        for sentence in corpus.sentences(subject):
            rec = read_record(record_path(out, "sentences", subject, sentence))
            if rec and rec.get("status") == "ok":
                records[(subject, sentence)] = rec
                coeffs, names = read_coeffs_csv(out / "blendshape_coeffs" / subject / f"{sentence}.csv")
                tracks.append(coeffs)
    if tracks:
        write_coeffs_std(out / "coeffs_std.csv", coeffs_std(tracks), names)
    from .said_residuals import write_blendshape_residuals
    write_blendshape_residuals(out, subjects)
    with atomic_write(out / "splits.json", "w", encoding="utf-8") as f:
        f.write(json.dumps(corpus.splits, indent=2, sort_keys=True) + "\n")
    if report:
        write_report(out, records, names or (), summary.failures, params)
    manifest = write_manifest(out, vocaset=vocaset, corpus=corpus, params=params, records=records,
                              failures=summary.failures, version=blendvoca.__version__)
    listed = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    listed["manifest.json"] = file_digest(manifest)
    write_record(summary_path, {"key": summary_key, "status": "ok", "files": listed})
