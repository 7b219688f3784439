"""The build's summary stage: ``coeffs_std.csv``, the residuals, ``splits.json``, ``report/``
and the manifest, written when any item or parameter changed."""

from __future__ import annotations

import time

from blendvoca.runtime.version import blendvoca_version
from blendvoca import format as fmt
from blendvoca.format.hashing import file_digest, stage_key
from blendvoca.format.manifest import remove_manifest, write_manifest
from blendvoca.synthetic.oracle import oracle_count

from .outdir import remove_own_outputs
from .report import REPORT_FILES, coeffs_std, measured_share, write_report
from .said_residuals import write_blendshape_residuals
from .state import is_up_to_date, read_record, record_path, write_record


def declared_share(corpus) -> dict | None:
    """The synthetic corpus's declared audio-determined share and oracle sample count, when it
    declares either (None for VOCASET and for corpora made before they existed)."""
    meta = corpus.synthetic
    if not isinstance(meta, dict) or not ("audio_determined" in meta or "oracle_samples" in meta):
        return None
    declared = meta.get("audio_determined")
    return {"declared": declared.get("declared") if isinstance(declared, dict) else 1.0,
            "oracle_samples": oracle_count(meta)}


#: What the summary stage writes (besides the manifest), relative to ``out``.
SUMMARY_OUTPUTS = (fmt.COEFFS_STD_FILE, fmt.RESIDUALS_FILE, fmt.SPLITS_FILE,
                   *(f"{fmt.REPORT_DIR}/{name}" for name in REPORT_FILES))


def write_summary_files(out, corpus, vocaset, subjects, params, summary, *, report, oracle_items=(), recipe=None):
    """Write the summary outputs unless up to date; return the seconds spent on the report (None: up to date)."""
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
    share = declared_share(corpus)
    if share is not None:
        extra["share"] = share
    if recipe is not None:  # the manifest records it: another recipe, another manifest
        extra["recipe"] = recipe["id"]
    summary_key = stage_key({"stage": "summary", "keys": keys, "failures": summary.failures, "params": params,
                             "report": report, "version": blendvoca_version(), "splits": corpus.splits,
                             **extra})
    previous = read_record(summary_path)
    if is_up_to_date(out, previous, summary_key):
        return None
    remove_manifest(out)
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
    write_blendshape_residuals(out, subjects)
    fmt.write_splits(out, corpus.splits)
    report_s = 0.0
    if report:
        clock = time.perf_counter()
        measured = None
        if share is not None:
            measured = measured_share(out, corpus.splits, sorted(oracle_records), names or (),
                                      count=share["oracle_samples"], declared=share)
        write_report(out, records, names or (), summary.failures, params, warnings=summary.warnings,
                     share=measured, corpus=corpus)
        report_s = time.perf_counter() - clock
    files += [rel for rel in SUMMARY_OUTPUTS if (out / rel).is_file()]
    manifest = write_manifest(out, files=files, vocaset=vocaset, corpus=corpus, params=params, records=records,
                              rig_records=rig_records, failures=summary.failures, version=blendvoca_version(),
                              recipe=recipe)
    listed = fmt.listed_files(out)
    listed[fmt.MANIFEST_FILE] = file_digest(manifest)
    write_record(summary_path, {"key": summary_key, "status": "ok", "files": listed})
    return report_s
