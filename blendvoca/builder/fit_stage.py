"""The build's fit stages, one task per sentence in the worker processes: the sentence's
coefficients, and the fits of its oracle samples (synthetic corpora that have them)."""

from __future__ import annotations

import time

import numpy as np

from blendvoca import format as fmt
from blendvoca.errors import DataError
from blendvoca.format.hashing import array_digest, file_digest, stage_key
from blendvoca.format.items import write_oracle_coeffs
from blendvoca.format.manifest import remove_manifest
from blendvoca.synthetic.oracle import OracleSamples
from blendvoca.vocaset.checks import duration_mismatch

from .sentence import lip_aperture, sentence_fit
from .state import is_up_to_date, read_record, record_path
from .worker import WORKER, record_built, recorded_failure

#: Bumped when a stage's algorithm changes its outputs (invalidates records).
FIT_STAGE_VERSION = "1"
ORACLE_STAGE_VERSION = "1"
AUDIO_RATE = fmt.AUDIO_RATE
#: Inner-lip landmarks (0-based) of the 68-point scheme: upper and lower lip middle.
LIP_LANDMARKS = (62, 66)


def load_rig(subject):
    rigs = WORKER["rigs"]
    if subject not in rigs:
        rigs.clear()  # one speaker at a time per worker is enough; bounds memory
        rigs[subject] = fmt.read_rig(WORKER["out"], subject)
    return rigs[subject]


def _stage_item(item, stage: str):
    """A task's ``(subject, sentence, rig key, record path, summary base)`` in ``stage``'s records."""
    subject, sentence, rig_key = item
    return subject, sentence, rig_key, record_path(WORKER["out"], stage, subject, sentence), \
        {"subject": subject, "sentence": sentence}


def sentence_task(item):
    """Fit (or confirm) one sentence; returns a status dict."""
    subject, sentence, rig_key, path, base = _stage_item(item, "sentences")
    corpus, out, params, static = (WORKER[k] for k in ("corpus", "out", "params", "static"))
    clock = time.perf_counter()
    try:
        # the frames as stored (float32 in VOCASET), digested as the float64 frames they stand for
        frames = corpus.frames(subject, sentence, dtype=None)
        samples, rate = corpus.audio(subject, sentence)
        inputs = {"frames": array_digest(frames, dtype=np.float64), "audio": array_digest(samples),
                  "audio_rate": int(rate)}
        # what is implausible about the sentence but built all the same
        mismatch = duration_mismatch(len(frames), corpus.fps, len(samples), rate)
        warnings = [mismatch] if mismatch else []
        key = {
            "stage": "sentence", "version": FIT_STAGE_VERSION, "rig": rig_key,
            "frames": inputs["frames"], "audio": inputs["audio"], "rate": int(rate),
            "delta": params["delta"], "audio_rate": AUDIO_RATE,
        }
        if corpus.posed:  # how the pose was taken out decides the coefficients
            key["pose_fit"] = params["pose_fit"]
        key = stage_key(key)
        if is_up_to_date(out, read_record(path), key):
            return {**base, "status": "skipped", "warnings": warnings}
        remove_manifest(out)
        rig = load_rig(subject)
        read_s, clock = time.perf_counter() - clock, time.perf_counter()
        coeffs, stats = sentence_fit(rig, frames, static["head_index"], delta=params["delta"], posed=corpus.posed,
                                     pose_fit=params.get("pose_fit", "joint"))
        lips = static["landmarks"][list(LIP_LANDMARKS)]
        stats["lip_aperture_mm"] = [round(float(v) * 1000.0, 6) for v in lip_aperture(frames, *lips)]
        compute_s, clock = time.perf_counter() - clock, time.perf_counter()
        files = [fmt.write_coeffs(out, subject, sentence, coeffs, rig.names),
                 fmt.write_audio(out, subject, sentence, samples, rate)]
        seconds = record_built(path, {**base, "key": key, "stats": stats, "inputs": inputs}, files, read_s=read_s,
                               compute_s=compute_s, clock=clock)
        return {**base, "status": "built", "warnings": warnings, "seconds": seconds}
    except Exception as error:  # recorded, the build carries on
        return recorded_failure(out, path, error, base)


def oracle_inputs(corpus, subject: str, sentence: str) -> dict:
    """What an oracle sample's meshes are made from: its stored draws, the seed and the speaker's style."""
    meta = corpus.synthetic or {}
    oracle = WORKER.get("oracle")
    if oracle is None:
        oracle = WORKER["oracle"] = OracleSamples(corpus.root, meta)
    path = oracle.path(subject, sentence)
    if not path.is_file():
        raise DataError(f"{path}: missing; the corpus declares {oracle.count} oracle samples per sentence")
    return {"samples": file_digest(path), "count": oracle.count, "seed": meta.get("seed"),
            "generator": meta.get("version"), "style": (meta.get("subjects", {}).get(subject) or {}).get("style")}


def oracle_task(item):
    """Render and fit (or confirm) the oracle samples of one sentence; returns a status dict."""
    subject, sentence, rig_key, path, base = _stage_item(item, "oracle")
    corpus, out, params, static = (WORKER[k] for k in ("corpus", "out", "params", "static"))
    clock = time.perf_counter()
    try:
        inputs = oracle_inputs(corpus, subject, sentence)
        key = stage_key({"stage": "oracle", "version": ORACLE_STAGE_VERSION, "rig": rig_key,
                         "inputs": inputs, "delta": params["delta"]})
        if is_up_to_date(out, read_record(path), key):
            return {**base, "status": "skipped", "key": key}
        remove_manifest(out)
        rig = load_rig(subject)
        oracle = WORKER["oracle"]
        read_s, clock = time.perf_counter() - clock, time.perf_counter()
        files, rmse = [], []
        for k, frames in enumerate(oracle.frames(subject, sentence, template=corpus.template(subject))):
            coeffs, stats = sentence_fit(rig, frames, static["head_index"], delta=params["delta"])
            files.append(write_oracle_coeffs(out, subject, sentence, k, coeffs, rig.names))
            rmse.append(stats["rmse_mm"])
        compute_s, clock = time.perf_counter() - clock, time.perf_counter()
        seconds = record_built(path, {**base, "key": key, "inputs": inputs, "stats": {"rmse_mm": rmse}}, files,
                               read_s=read_s, compute_s=compute_s, clock=clock)
        return {**base, "status": "built", "key": key, "seconds": seconds}
    except Exception as error:  # recorded, the build carries on
        return recorded_failure(out, path, error, base)
