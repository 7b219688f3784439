"""The protocol's last step: the result JSON (:mod:`benchmark.results`) and, next to
it, the folder of the tracks that were scored (:mod:`benchmark.runs`)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from benchmark.methods.base import Budget
from benchmark.methods.contract import COEFFICIENT_NAMES
from benchmark.protocol.isolation import evaluation_threads
from benchmark.protocol.limits import generate_limit
from benchmark.results import Result, build_result, check, read, result_filename, write
from benchmark.runs import TrackWriter, seed_folder_name, tracks_folder_name
from blendvoca.errors import DataError, MethodError, UserError
from blendvoca.format import content_digest
from blendvoca.runtime.locks import LockHeld, held_lock

__all__ = ["ResultExistsError", "dataset_identity", "is_plain", "lipsync_models_provenance", "result_name", "store",
           "store_seeds", "track_writer", "write_run"]

#: Seconds a writer waits for another process writing the same result file.
RESULT_LOCK_WAIT_S = 600.0


class ResultExistsError(UserError):
    """The results folder holds, under the name a run would write, a result of other
    settings (or a file that is no result); nothing was written (``--overwrite`` replaces it)."""


def dataset_identity(dataset) -> dict:
    """``{"manifest_hash", "recipe_id"}`` of an opened build: the recipe id names results and
    leaderboard sections (the same on every processor, docs/build.md "Dataset identity"),
    the content hash is kept for information; a dataset without a recipe (a build made
    before recipes, a test double) is named by its content hash."""
    manifest_hash = str(dataset.manifest_hash)
    return {"manifest_hash": manifest_hash, "recipe_id": str(getattr(dataset, "recipe_id", None) or manifest_hash)}


def is_plain(spec) -> bool:
    """True for a run asked for with nothing but its method, seed(s) and samples (a plain
    ``benchmark.run --method NAME``): its result is named without a settings digest."""
    return (not spec.config and (spec.budget or Budget()) == Budget() and spec.checkpoint is None
            and getattr(spec, "vae", None) is None and spec.syncnet is None and spec.sync_expert is None
            and not spec.clip and spec.split == "test" and spec.sentence_batch == 1
            and getattr(spec, "device", None) in (None, "cpu"))


def result_name(spec, dataset, trained, settings: str | None = None) -> str:
    """The result file's name: one per method label, build, samples and seed, or seeds
    (:func:`benchmark.results.result_filename`: ``__seed0``, ``__seeds0-1-2``), and for a
    run that is not :func:`is_plain`, the digest of its settings ``settings``
    (:meth:`benchmark.results.Result.settings_digest`; ``__c<digest>``). A spec's ``name``
    (a caller that names its own results: the leaderboard's rows) wins."""
    if getattr(spec, "name", None):
        return str(spec.name)
    identity = dataset_identity(dataset)
    return result_filename(trained.label or spec.method, identity["recipe_id"],
                           spec.samples if trained.stochastic else 1, int(spec.seed), spec.seeds,
                           None if is_plain(spec) else settings)


def track_writer(spec, inputs, trained) -> TrackWriter:
    """A staging folder for the run's tracks, moved to its final name by :func:`store`
    (``discard()`` it when a step fails)."""
    names = tuple(getattr(inputs.dataset, "names", ()) or COEFFICIENT_NAMES)
    # a provisional folder name: store() names the folder after the result, once its settings are known
    filename = result_name(spec, inputs.dataset, trained, "pending")
    return TrackWriter(Path(inputs.results_dir) / tracks_folder_name(filename), names)


def lipsync_models_provenance(syncnet=None, sync_expert=None) -> dict:
    """What a result records of the lip-sync models it was scored with: the files and,
    for the learned expert, the digest of its weights (the same for the same training
    on another machine or path, which the file's is not) and the data it was trained on."""

    def model_file(model) -> dict:
        """``{"path", "sha256"}`` of a model given as a path; ``{"path": None}`` for a loaded one."""
        if not isinstance(model, (str, os.PathLike)):
            return {"path": None}
        return {"path": str(Path(model).resolve()), "sha256": content_digest(model)}

    out = {}
    if syncnet is not None:
        out["syncnet"] = model_file(syncnet)
    if sync_expert is not None:
        from benchmark.lipsync.expert import load_expert

        expert = load_expert(sync_expert) if isinstance(sync_expert, (str, os.PathLike)) else sync_expert
        weights = {"weights_sha256": expert.weights_digest()} if hasattr(expert, "weights_digest") else {}
        out["sync_expert"] = {**model_file(sync_expert), **weights,
                              "trained_on": dict(getattr(expert, "trained_on", {}) or {})}
        from benchmark.lipsync.default_expert import REAL_SPEECH_EXPERT

        if isinstance(sync_expert, (str, os.PathLike)) and Path(sync_expert).resolve() == REAL_SPEECH_EXPERT.resolve():
            out["sync_expert"]["project_expert"] = REAL_SPEECH_EXPERT.stem  # the default for recorded speech
    return out


def _method_section(spec, trained) -> dict:
    """The ``method`` section, with the method's ``config()`` (which a result file must be able to hold)."""
    try:
        config = trained.method.config()
        json.dumps(config)
    except Exception as exc:
        raise MethodError(f"method {trained.name!r}: config() must return a JSON-serialisable dict ({exc})") from exc
    cls = type(trained.method)
    return {
        "name": spec.method,
        "label": trained.label,
        "class": f"{cls.__module__}:{cls.__qualname__}",
        "stochastic": trained.stochastic,
        "reference": bool(getattr(trained.method, "reference", False)),
        "output": trained.output,
        "config": config,
    }


def _dataset_section(spec, inputs, *, num_subjects: int, num_sentences: int) -> dict:
    data_root = inputs.data_root
    section = {
        **dataset_identity(inputs.dataset),
        "path": str(Path(data_root).resolve()) if isinstance(data_root, (str, os.PathLike)) else str(data_root),
        "split": spec.split,
        "num_subjects": int(num_subjects),
        "num_sentences": int(num_sentences),
    }
    name = getattr(inputs.dataset, "dataset_name", "vocaset")
    if name != "vocaset":
        # another corpus than the one the published VAE was trained on (BlendVOCA, from VOCASET):
        # its latent metrics are out of domain unless the run was given a VAE trained on it
        section.update(name=name, title=getattr(inputs.dataset, "dataset_title", name),
                       latent_out_of_domain=getattr(spec, "vae", None) is None)
    return section


def _protocol_section(spec, inputs, trained, *, n_clipped: int, evaluation: dict | None = None,
                      convergence_check: str | None = None, motionless: int = 0) -> dict:
    """The ``protocol`` section; ``evaluation``: what the evaluation attached
    (``Scores.protocol``, e.g. ``fd_floor_probe``), merged in."""
    checkpoint, limit = spec.checkpoint, generate_limit(spec.generate_time_limit)
    protocol = {
        "samples": spec.samples if trained.stochastic else 1,
        "seed": int(spec.seed),
        **({"seeds": [int(s) for s in spec.seeds]} if spec.seeds is not None else {}),
        "budget": spec.budget.to_dict(),
        "clip": bool(spec.clip),
        "n_clipped": int(n_clipped),
        "checkpoint": None if checkpoint is None else str(checkpoint),
        **({"checkpoint_sha256": content_digest(checkpoint)}
           if checkpoint is not None and Path(checkpoint).exists() else {}),
        "deterministic": spec.budget.max_seconds is None,
        "generate_time_limit": None if limit is None else limit.to_dict(),
        "verified": inputs.verified is not None,
        # sentences the method did not move at all (benchmark.protocol.generation.motionless_sentences)
        **({"motionless_sentences": int(motionless)} if motionless else {}),
        **({"sentence_batch": spec.sentence_batch} if spec.sentence_batch > 1 else {}),
        **({"lipsync_models": lipsync_models_provenance(spec.syncnet, spec.sync_expert)}
           if spec.evaluates_lipsync_models else {}),
        **({"convergence_check": convergence_check} if convergence_check is not None else {}),
        **({"vae": {"path": str(spec.vae), "sha256": content_digest(spec.vae)}}
           if getattr(spec, "vae", None) is not None else {}),
        # the threads the evaluation computed with (a plug-in's change is put back: benchmark.protocol.isolation)
        **({"threads": threads} if (threads := evaluation_threads()) else {}),
        # a GPU's results differ from the CPU's by float rounding: say where it ran (absent: the CPU)
        **({"device": spec.device} if getattr(spec, "device", None) not in (None, "cpu") else {}),
    }
    protocol.update(dict(evaluation or {}))
    return protocol


def store(spec, inputs, trained, generated, scored, *, writer: TrackWriter, timings: dict,
          provenance: dict, convergence: dict | None = None, convergence_check: str | None = None) -> Path:
    """Write the run: its tracks folder (``writer`` committed) and its result JSON.

    Parameters
    ----------
    spec : RunSpec
    inputs : Inputs
    trained : Trained
    generated : Generated
    scored : Scored
        Its ``metrics.protocol`` (a dict the evaluation attaches, e.g.
        ``{"fd_floor_probe": ...}``) is merged into the result's ``protocol``.
    writer : benchmark.runs.TrackWriter
        From :func:`track_writer`, holding the generated tracks.
    timings : dict
        Seconds per step: ``train_s``, ``load_s``, ``generate_s``, ``evaluate_s``,
        ``convergence_s``, ``total_s``.
    provenance : dict
        ``benchmark.results.current_provenance()`` taken when the run started.
    convergence : dict, optional
        The half-budget check (:func:`benchmark.protocol.convergence.convergence_record`).
    convergence_check : str, optional
        ``protocol.convergence_check``: ``"checked"`` or why not.

    Returns
    -------
    Path
        The result file.

    Raises
    ------
    MethodError
        The method's ``config()`` is not a JSON-serialisable dict (nothing written).
    """
    method = _method_section(spec, trained)  # first: a config() a file cannot hold writes nothing
    filename = result_name(spec, inputs.dataset, trained, "pending")
    result = build_result(
        method=method,
        dataset=_dataset_section(spec, inputs, num_subjects=len({s for s, _ in generated.tracks}),
                                 num_sentences=len(generated.tracks)),
        protocol=_protocol_section(spec, inputs, trained, n_clipped=generated.n_clipped,
                                   evaluation=getattr(scored.metrics, "protocol", {}),
                                   convergence_check=convergence_check,
                                   motionless=getattr(generated, "motionless", 0)),
        metrics=dict(scored.metrics),
        timings=timings,
        tracks=tracks_folder_name(filename),
        per_sentence=scored.per_sentence,
        provenance=provenance,
        latency=getattr(generated, "latency", None),
        convergence=convergence,
    )
    return _write_named(spec, inputs, trained, result, writer)


def _write_named(spec, inputs, trained, result: Result, writer: TrackWriter) -> Path:
    """``result`` written under its final name (:func:`result_name` with its settings
    digest), its ``tracks`` naming the folder of that name."""
    filename = result_name(spec, inputs.dataset, trained, result.settings_digest())
    folder = tracks_folder_name(filename)
    record = result.to_json()
    if record.get("tracks"):
        record["tracks"] = folder + record["tracks"][len(tracks_folder_name(record["tracks"].split("/")[0])):]
    for entry in record.get("per_seed") or ():
        if entry.get("tracks"):
            entry["tracks"] = folder + entry["tracks"][len(entry["tracks"].split("/")[0]):]
    writer.folder = Path(inputs.results_dir) / folder
    return write_run(check(record), inputs.results_dir, filename, writer=writer,
                     overwrite=bool(getattr(spec, "overwrite", False)))


def store_seeds(spec, inputs, trained, runs, combined, *, writer: TrackWriter, timings: dict, provenance: dict,
                convergence_check: str | None = None) -> Path:
    """Write a run over several training seeds as one result (``spec.seeds``).

    Parameters
    ----------
    spec : RunSpec
        With ``seeds``.
    inputs : Inputs
    trained : Trained
        The first seed's method (its name, label, class and config stand for all).
    runs : list of benchmark.protocol.seeds.SeedRun
        One per seed, in ``spec.seeds`` order.
    combined : benchmark.protocol.seeds.CombinedScores
        From :func:`benchmark.protocol.seeds.combined_seed_scores`.
    writer : benchmark.runs.TrackWriter
        The run's writer (each seed's tracks in its ``for_seed`` subfolder).
    timings : dict
        Seconds per step, summed over the seeds, and ``total_s``.
    provenance : dict
    convergence_check : str, optional

    Returns
    -------
    Path
        The result file: ``seeds``, ``per_seed`` and the combined ``metrics``,
        ``per_sentence`` and ``convergence`` (docs/methods.md, "Training seeds").
    """
    method = _method_section(spec, trained)  # first: a config() a file cannot hold writes nothing
    filename = result_name(spec, inputs.dataset, trained, "pending")
    first = runs[0]
    folder = tracks_folder_name(filename)
    per_seed = []
    for record, run in zip(combined.per_seed, runs):
        per_seed.append({**record, "tracks": f"{folder}/{seed_folder_name(run.seed)}",
                         "n_clipped": int(run.n_clipped),
                         "timings": {k: (None if v is None else round(float(v), 3)) for k, v in run.timings.items()}})
    protocol = _protocol_section(spec, inputs, trained, n_clipped=sum(int(r.n_clipped) for r in runs),
                                 evaluation=first.evaluation, convergence_check=convergence_check)
    protocol["seed_bootstrap"] = dict(combined.bootstrap)
    result = build_result(
        method=method,
        dataset=_dataset_section(spec, inputs, num_subjects=first.num_subjects, num_sentences=first.num_sentences),
        protocol=protocol,
        metrics=combined.metrics,
        timings=timings,
        tracks=f"{folder}/{seed_folder_name(first.seed)}",
        per_sentence=combined.per_sentence,
        provenance=provenance,
        # the first seed's: the chunked configuration and the machine are the same for every seed
        latency=first.latency,
        seeds=[int(s) for s in spec.seeds],
        per_seed=per_seed,
        convergence=combined.convergence,
    )
    return _write_named(spec, inputs, trained, result, writer)


def _existing_conflict(path: Path, result: Result) -> str | None:
    """Why the file ``path`` may not be replaced by ``result`` without ``--overwrite``
    (another run's settings, or no result at all), or None (absent, or the same settings)."""
    if not path.exists() and not path.is_symlink():
        return None
    try:
        existing = read(path)
    except (DataError, OSError) as exc:
        return f"it holds no readable result ({exc})"
    if existing.settings_digest() == result.settings_digest():
        return None
    theirs, ours = existing.settings(), result.settings()
    differ = sorted(k for k in set(theirs) | set(ours) if theirs.get(k) != ours.get(k))
    return (f"it holds a result of other settings (differing: {', '.join(differ)}; its settings digest "
            f"{existing.settings_digest()}, this run's {result.settings_digest()})")


def write_run(result: Result, results_dir, filename: str | None = None, *, writer: TrackWriter | None = None,
              overwrite: bool = False) -> Path:
    """Commit ``writer``'s tracks folder (when given), then write ``result`` atomically
    into ``results_dir`` as ``filename`` (default :meth:`Result.filename`;
    :func:`benchmark.results.write`), with its ``protocol.record_sha256``
    (:meth:`Result.record_digest`).

    Both happen under an ``flock`` of ``results_dir`` itself (held for those two renames):
    runs writing into one folder at once never leave one's result beside another's tracks. An
    existing file of other settings (or one that is no result) is replaced only with
    ``overwrite``.

    Returns
    -------
    Path
        The result file.

    Raises
    ------
    ResultExistsError
        ``filename`` holds a result of other settings and not ``overwrite`` (nothing written).
    """
    results_dir = Path(results_dir)
    filename = filename or result.filename()
    path = results_dir / filename
    record = result.to_json()
    record["protocol"]["record_sha256"] = result.record_digest()
    result = check(record, str(path))
    try:
        with held_lock(results_dir, wait=RESULT_LOCK_WAIT_S):
            why = None if overwrite else _existing_conflict(path, result)
            if why is not None:
                raise ResultExistsError(
                    f"--results {results_dir}: {filename} exists and {why}; nothing was written. Pass --overwrite "
                    "to replace it, or write into another --results folder")
            if writer is not None:
                writer.commit()
            return write(path, result)
    except LockHeld:
        raise UserError(f"--results {results_dir}: another process has held the folder's lock for "
                        f"{RESULT_LOCK_WAIT_S:g} s while {filename} was to be written; nothing was written") from None
