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

This module drives them; the stages are :mod:`.rig_stage` (1), :mod:`.fit_stage` (2,
2b) and :mod:`.summary_stage` (3), their tasks run in the worker processes of
:mod:`.worker` (:func:`blendvoca.runtime.processes.process_map`).

The build's recipe id (:func:`blendvoca.format.make_recipe`: every corpus file's
digest, the assets', the data-format version and the parameters) is computed
before any output is written and stored in the manifest: it is the dataset's
identity on every machine, whatever BLAS kernel rounds the fits.

Every stage has a record in ``.buildstate/`` keyed by a digest of its inputs
and parameters, written after its outputs (which are written atomically): a
rerun skips what is up to date, redoes what an interruption cut short or what
a changed input or parameter touches, and writes byte-identical files. The
manifest is removed before the first output changes and rewritten at the end, so
an interrupted or failed build never leaves one claiming partial outputs.
The names and formats of what it writes are :mod:`blendvoca.format`'s.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from blendvoca import format as fmt
from blendvoca.assets import cache_dir
from blendvoca.errors import OutputDirError, UserError
from blendvoca.format.hashing import array_digest
from blendvoca.format.manifest import remove_manifest
from blendvoca.runtime.processes import WorkerStartError, process_map
from blendvoca.runtime.threads import limited_threads
from blendvoca.synthetic import default_corpus
from blendvoca.synthetic.oracle import oracle_count

from . import fit_stage, rig_stage, worker
from .fit_stage import FIT_STAGE_VERSION, ORACLE_STAGE_VERSION
from .outdir import (build_lock, check_output_dir, claim_output_dir, is_fatal_write_error, remove_stale_temporaries,
                     unwritable)
from .report import TIMINGS, write_timings
from .rig_stage import RIG_STAGE_VERSION, shared_correspondence
from .sentence import POSE_FITS
from .state import STATE_DIR, read_record, record_path, write_record
from .summary_stage import write_summary_files
from .worker import OPENED, open_corpus, retire, static_inputs

__all__ = ["BuildInputError", "BuildSummary", "WorkerStartError", "build_dataset", "build_recipe", "check_corpus",
           "check_delta", "check_workers", "default_output_dir", "open_corpus"]


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


def _run(tasks, function, *, workers, initargs, desc):
    """``function`` over ``tasks`` in ``workers`` processes (here for 1), each set up by
    :func:`.worker.worker_init`; the results in order. One BLAS thread while it runs (a
    worker process keeps it for its life); this process's counts are restored after."""
    with limited_threads(1):
        return list(process_map(function, tasks, workers=workers, initializer=worker.worker_init,
                                initargs=initargs, desc=desc))


def default_output_dir() -> Path:
    """Where the bundled-default BlendVOCA is built: ``<user cache>/blendvoca-default``.

    ``python -m blendvoca.build`` without ``--out`` writes here, and the benchmark
    runner reads from here when it is given no ``--data``.
    """
    return cache_dir() / "blendvoca-default"


def build_dataset(
    out,
    vocaset=None,
    *,
    workers: int | None = None,
    shapes: str = "speech",
    delta: float = 0.1,
    report: bool = True,
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
    # Everything a user can get wrong is checked before any work (and before --out is touched).
    if shapes not in ("speech", "all"):
        raise BuildInputError(f"--shapes: expected 'speech' or 'all', got {shapes!r}")
    if pose_fit not in POSE_FITS:
        raise BuildInputError(f"--pose-fit: expected one of {', '.join(POSE_FITS)}, got {pose_fit!r}")
    workers = check_workers(workers)
    delta = check_delta(delta)
    if vocaset is None:
        vocaset = default_corpus()
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
    static = static_inputs(shapes, corpus)  # every asset resolved and verified here, once, before any worker starts
    corpus.faces  # noqa: B018 - the topology (or the flame-sample asset it falls back to), checked here too
    # The identity, known before any output; the topology is read from the corpus or an asset.
    recipe = build_recipe(vocaset, params, {**static["assets"], "topology": array_digest(corpus.faces)})
    claim_output_dir(out)
    with build_lock(out):
        try:
            OPENED.clear()
            OPENED[str(vocaset)] = (os.getpid(), corpus)  # the workers forked here reuse it
            return _build_stages(out, vocaset, corpus, params, workers=workers, report=report, recipe=recipe)
        except OutputDirError:
            remove_manifest(out)
            raise
        except OSError as error:
            if is_fatal_write_error(error):
                remove_manifest(out)
                raise unwritable(error, out) from None
            raise
        finally:
            OPENED.clear()


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
        remove_manifest(out)
        note = retire(out, record)
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


def _tally(summary: BuildSummary, results, count: str, stage: str) -> list[dict]:
    """Count ``results`` into ``summary``: failures under ``stage``, the others as ``count`` built or skipped;
    return the others."""
    done = []
    for result in results:
        if result["status"] == "failed":
            summary.failures.append({"subject": result["subject"], "sentence": result.get("sentence"),
                                     "stage": stage, "reason": result["reason"]})
        else:
            (summary.built if result["status"] == "built" else summary.skipped)[count] += 1
            done.append(result)
    return done


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
    shared = shared_correspondence(corpus, subjects, out, params)
    shared_s = time.perf_counter() - shared_clock
    speaker_results = _run(subjects, rig_stage.speaker_task, workers=workers, initargs=initargs + (shared,),
                           desc="speaker rigs")
    rig_keys = {result["subject"]: result["key"] for result in _tally(summary, speaker_results, "speakers", "rig")}

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
                reason = "no rig for this speaker (see the rig failure)" + retire(out, read_record(path))
                if path.exists():
                    write_record(path, {"subject": subject, "sentence": sentence, "status": "failed", "reason": reason})
                summary.failures.append({"subject": subject, "sentence": sentence, "stage": "fit", "reason": reason})
    sentence_results = _run(items, fit_stage.sentence_task, workers=workers, initargs=initargs,
                            desc="sentences")
    summary.warnings += [{"subject": result["subject"], "sentence": result["sentence"], "message": message}
                         for result in sentence_results for message in result.get("warnings", ())]
    _tally(summary, sentence_results, "sentences", "fit")
    for (subject, sentence), problem in sorted(problems.items()):
        summary.failures.append({"subject": subject, "sentence": sentence, "stage": "input",
                                 "reason": problem.message})

    summary.seconds["sentences"] = time.perf_counter() - clock
    stages["fits"] = {**_task_seconds(sentence_results), "wall": summary.seconds["sentences"],
                      "built": summary.built["sentences"]}
    oracle_items = _oracle_stage(out, corpus, subjects, sentence_results, rig_keys, summary, stages,
                                 workers=workers, initargs=initargs)
    clock = time.perf_counter()
    report_s = write_summary_files(out, corpus, vocaset, subjects, params, summary, report=report,
                                    oracle_items=oracle_items, recipe=recipe)
    summary.seconds["summary"] = time.perf_counter() - clock
    if report_s is not None or summary.built["speakers"] or summary.built["sentences"]:
        # Something was done: the timings of this build (a no-op rerun leaves them as they are).
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
    count = oracle_count(corpus.synthetic)
    fitted = {(r["subject"], r["sentence"]) for r in sentence_results if r["status"] != "failed"}
    items = [(s, q) for s in subjects for q in corpus.sentences(s) if (s, q) in fitted] if count else []
    for item, path in _stale_records(out, "oracle", set(items)):
        remove_manifest(out)
        retire(out, read_record(path))
        path.unlink()
    if not items:
        return []
    clock = time.perf_counter()
    results = _run([(s, q, rig_keys[s]) for s, q in items], fit_stage.oracle_task, workers=workers, initargs=initargs,
                   desc="oracle samples")
    summary.built["oracle"] = summary.skipped["oracle"] = 0
    done = [(result["subject"], result["sentence"]) for result in _tally(summary, results, "oracle", "oracle")]
    summary.seconds["oracle"] = time.perf_counter() - clock
    stages["oracle"] = {**_task_seconds(results), "wall": summary.seconds["oracle"],
                        "built": sum(r["status"] == "built" for r in results)}
    return done

