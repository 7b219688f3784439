"""The stages of the leaderboard's plan, as functions of plain data.

Each function takes the stage's ``spec`` (a dict of paths and settings made by
:func:`leaderboard.reproduce.plan_tasks`) and its dependencies' values, and returns
``(value, details)`` (:class:`~leaderboard.executors.Task`). Each writes its outputs
atomically (a temporary name renamed into place) and returns ``details=None`` when
they are already there, so a stage cut short leaves nothing that a rerun would take
for done. The work folder holds::

    <work>/trained/<training>/seed<k>/          a trained method (its save())
    <work>/stages/train/<training>-seed<k>.json  the training's timings and half-budget values
    <work>/stages/rows/<row>/seed<k>.json        one seed's scores: a result file (benchmark.results)
    <work>/stages/rows/<row>/tracks-seed<k>/     the tracks those scores were computed on
    <work>/stages/timings/<task>.json           wall time of every stage that ran

A trained row's result is what ``benchmark.run --seeds`` writes for it: the seeds'
scores combined by :func:`benchmark.protocol.seeds.combined_seed_scores` and stored
by :func:`benchmark.protocol.storing.store_seeds` (only the timings, the provenance
and where the checkpoints were differ). The half-budget check runs during training
and its values travel in the training's record to the row that owns the training;
a row that reuses another's training (``shared_training``) scores it as loaded from a
checkpoint, as a run with ``--checkpoint`` would, and its result carries the owner's
verdict (``convergence.shared_with``), read from the owner's result file.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import socket
import time
from pathlib import Path
from types import SimpleNamespace

from benchmark.data import open_blendvoca
from benchmark.methods import get_method
from benchmark.methods.base import Budget
from benchmark.methods.contract import COEFFICIENT_NAMES
from benchmark.protocol import (
    CHECKED,
    RunSpec,
    SeedRun,
    check_inputs,
    generate,
    half_budget_check,
    run,
    score,
    train,
)
from benchmark.protocol.convergence import NOT_CHECKED, HalfBudget, checked_convergence, shared_convergence
from benchmark.protocol.seeds import combined_seed_scores, seed_stream, summed_timings
from benchmark.protocol.storing import dataset_identity, store_seeds, track_writer
from benchmark.results import Result, build_result, current_provenance, read, result_filename, write
from benchmark.runs import TrackWriter
from blendvoca.builder import build_dataset
from blendvoca.errors import DataError, UserError
from blendvoca.format import manifest_path
from blendvoca.io.atomic import atomic_write
from blendvoca.io.json_file import read_json
from blendvoca.runtime.staging import move_into_place, process_staging
from leaderboard.executors.core import log_progress

__all__ = ["built_corpus", "data_stage", "expert_stage", "row_result_path", "score_stage", "single_stage",
           "store_stage", "train_stage"]


def _write_json(path: Path, record: dict) -> None:
    with atomic_write(path, "w") as handle:
        json.dump(record, handle, indent=1)


# --------------------------------------------------------------------------- data


def data_stage(spec):
    """The build the rows are scored on: ``spec["data"]`` when given, else the plan's
    corpus generated and built under ``spec["work"]`` (each made when missing)."""
    if spec.get("data"):
        root = Path(spec["data"]).expanduser().resolve()
        if not manifest_path(root).is_file():
            raise UserError(f"--data {root}: not a BlendVOCA build (no manifest.json)")
        return str(root), None
    work = Path(spec["work"])
    done = manifest_path(work / spec["build_name"]).is_file()
    root = built_corpus(work, spec["corpus"], corpus_name=spec["corpus_name"], build_name=spec["build_name"])
    return str(root), (None if done else {})


def built_corpus(work, corpus: dict, *, corpus_name: str, build_name: str, workers: int = 2) -> Path:
    """The synthetic corpus ``generate_corpus(**corpus)`` in ``<work>/<corpus_name>`` and
    its BlendVOCA build in ``<work>/<build_name>``, each made when missing (both resumable)."""
    from blendvoca.synthetic import generate_corpus  # igl: loaded only when the corpus is made

    work = Path(work)
    source = work / corpus_name
    if not (source / "synthetic.json").is_file():
        log_progress(f"generating the synthetic corpus into {source}")
        generate_corpus(source, **corpus)
    root = work / build_name
    summary = build_dataset(root, source, workers=workers)
    if summary.failures:
        raise RuntimeError(f"build of {root} had {len(summary.failures)} failure(s), e.g. {summary.failures[0]}")
    return root


def expert_stage(spec, root):
    """The learned lip-sync expert scoring every row, trained once on the build's
    training split (a step budget: deterministic) and cached; its checkpoint path."""
    from benchmark.lipsync.expert_training import cached_expert  # torch: loaded only when the expert is trained

    started = time.time()
    _, path = cached_expert(root, max_seconds=None, max_steps=int(spec["expert_steps"]))
    # trained now (a new checkpoint), or loaded from the cache: then nothing to time
    return str(path), ({} if Path(path).stat().st_mtime >= started - 1.0 else None)


# --------------------------------------------------------------------------- rows


def _method_and_config(spec):
    """The registered method and config a row runs (``corpus-meshes``: the mesh adapter
    on the corpus's exported meshes)."""
    name, config = spec["method"], dict(spec["config"])
    if name == "corpus-meshes":
        meshes = Path(spec["work"]) / "corpus-meshes-60fps"
        name, config = "mesh-adapter", {"config": str(meshes / "adapter.yaml")}
    return name, config


def row_result_path(spec, root) -> Path:
    """Where the row's result file goes (its name: method label, build, samples, seeds)."""
    name, config = _method_and_config(spec)
    cls = get_method(name)
    method = cls(**config)
    # the label may depend on the config (mesh-adapter's source, cdface's control)
    label = getattr(method, "label", None) or name
    samples = spec["samples"] if cls.stochastic else 1
    seeds = spec.get("seeds")
    dataset = dataset_identity(open_blendvoca(root))["recipe_id"]
    return Path(spec["results"]) / result_filename(label, dataset, samples, int(seeds[0]) if seeds else 0, seeds)


def _source_corpus(spec, root) -> str | None:
    """The corpus whose meshes the mesh-space metrics read: the plan's own corpus when
    ``root`` is the plan's build under ``--work`` (so a work folder that was moved or
    copied still finds it), else None (the corpus the build recorded)."""
    corpus = Path(spec["work"]) / spec["corpus_name"]
    if Path(root).resolve().parent == Path(spec["work"]).resolve() and (corpus / "synthetic.json").is_file():
        return str(corpus)
    return None


def _row_done(spec, root) -> Path | None:
    path = row_result_path(spec, root)
    return path if path.is_file() and not spec["force"] else None


def single_stage(spec, root, expert):
    """A row scored in one run (a reference row, or one without training seeds):
    :func:`benchmark.protocol.run` with seed 0, as ``benchmark.run`` does."""
    if spec["method"] == "corpus-meshes":
        _exported_meshes(spec)  # first: the row's label (and so its file name) names the exported meshes
    done = _row_done(spec, root)
    if done is not None:
        log_progress(f"{spec['row']}: {done} exists, kept (--force rescores)")
        return str(done), None
    log_progress(f"{spec['row']}: {spec['note']}")
    path = run(_run_spec(spec, root, seed=0, checkpoint=None, expert=expert, stores=True))
    timings = read(path).timings
    return str(path), {k: timings.get(k) for k in ("train_s", "load_s", "generate_s", "evaluate_s")}


def _exported_meshes(spec) -> None:
    """The corpus's meshes at 60 fps for the ``corpus-meshes`` row (made when missing)."""
    from baselines.mesh_adapter.export import exported_corpus_meshes  # a plug-in's own tool: loaded for this row only

    work = Path(spec["work"])
    meshes = work / "corpus-meshes-60fps"
    if (meshes / "adapter.yaml").is_file():
        return
    corpus = work / spec["corpus_name"]
    if not (corpus / "synthetic.json").is_file():
        raise UserError(f"corpus-meshes: exports the synthetic corpus's meshes, but {corpus} holds none "
                        "(with --data, leave this row out or generate the corpus there)")
    exported_corpus_meshes(corpus, meshes, fps=60)


def _run_spec(spec, root, *, seed, checkpoint, expert=None, seeds=None, stores: bool = False):
    """The row's :class:`RunSpec`; ``stores``: a run that writes the row's result file,
    named as the board names its rows (:func:`row_result_path`) and replacing a row's file
    of other settings only when told (``--force``)."""
    name, config = _method_and_config(spec)
    return RunSpec(method=name, config=config, data_root=root, samples=spec["samples"], seed=int(seed),
                   seeds=seeds, budget=Budget(max_steps=spec["max_steps"]), checkpoint=checkpoint,
                   sync_expert=expert, results_dir=spec["results"], vae=spec.get("vae"),
                   vocaset=_source_corpus(spec, root), name=row_result_path(spec, root).name if stores else None,
                   overwrite=bool(spec.get("force")))


def _checkpoint(spec, seed: int) -> Path:
    return Path(spec["work"]) / "trained" / spec["training"] / f"seed{int(seed)}"


def _train_record(spec, seed: int) -> Path:
    return Path(spec["work"]) / "stages" / "train" / f"{spec['training']}-seed{int(seed)}.json"


def train_stage(spec, root):
    """Train the row's method with seed ``spec["seed"]`` under its step budget and save it
    into ``<work>/trained/<training>/seed<k>``, with the half-budget check; returns the
    training record (timings, the check's values)."""
    seed = int(spec["seed"])
    final, record_path = _checkpoint(spec, seed), _train_record(spec, seed)
    if record_path.is_file() and final.is_dir() and any(final.iterdir()):
        record = read_json(record_path, what="a training record (JSON object)")
        if not isinstance(record, dict):
            raise DataError(f"{record_path}: expected a training record (a JSON object), got {type(record).__name__}; "
                            "remove it to train again")
        return record, None
    if all(_row_done(row, root) is not None for row in spec["rows"]):
        return {"seed": seed, "stored": True}, None  # every row of this training is stored: nothing to train for
    # trained into a folder of this process, renamed once saved: a worker killed while
    # training leaves no folder that a rerun would load as a trained method
    partial = process_staging(final)
    try:
        run = _run_spec(spec, root, seed=seed, checkpoint=partial)
        inputs = check_inputs(run)
        check, reason = half_budget_check(run, inputs)
        log_progress(f"{spec['row']}: training seed {seed}, {spec['max_steps']} steps ({spec['note']})")
        trained = train(run, inputs.dataset, check=check)
        half = dataclasses.asdict(check.result) if check is not None and check.called else None
        curve = [dataclasses.asdict(p) for p in check.points] if check is not None else []  # the learning curve
        record = {"seed": seed, "training": spec["training"], "train_s": trained.train_s,
                  "convergence_s": trained.convergence_s, "checked": check is not None, "reason": reason,
                  "half_budget": half, "curve": curve, "host": socket.gethostname()}
        _write_json(record_path, record)
        move_into_place(partial, final, replace=True)  # an earlier try finished after all (a lost node's): keep one
    finally:
        shutil.rmtree(partial, ignore_errors=True)
    return record, {"train_s": trained.train_s, "convergence_s": trained.convergence_s,
                    "training": spec["training"]}


def _seed_paths(spec, seed: int):
    folder = Path(spec["work"]) / "stages" / "rows" / spec["row"]
    return folder / f"seed{int(seed)}.json", folder / f"tracks-seed{int(seed)}"


def _seed_result(spec, inputs, run: SeedRun, *, label: str, reason: str | None) -> Result:
    """One seed's scores as a result file (what :func:`_seed_run` reads back): its
    metrics with the bootstrap replicates the seeds' combination needs, per-sentence
    rows, half-budget verdict, timings and latency (the row's result stores the first
    seed's); the evaluation's protocol record under ``protocol.evaluation``."""
    metrics = {}
    for name, entry in run.metrics.items():
        entry = {k: v for k, v in entry.items() if k != "replicates"}
        reps = run.seed_replicates(name)
        metrics[name] = entry if reps is None else {**entry, "replicates": reps.tolist()}
    return build_result(
        method={"name": spec["method"], "label": label, "config": {}},
        dataset={**dataset_identity(inputs.dataset), "num_subjects": run.num_subjects,
                 "num_sentences": run.num_sentences},
        protocol={"seed": run.seed, "samples": spec["samples"], "n_clipped": int(run.n_clipped),
                  "evaluation": dict(run.evaluation), "convergence_check": reason},
        metrics=metrics, timings=run.timings, per_sentence=run.per_sentence, convergence=run.convergence,
        tracks=_seed_paths(spec, run.seed)[1].name, latency=run.latency)


def _seed_run(result: Result) -> SeedRun:
    """The :class:`~benchmark.protocol.SeedRun` a seed's result file holds (:func:`_seed_result`)."""
    record = result.to_json()
    return SeedRun(
        seed=result.protocol.seed,
        metrics={name: {k: v for k, v in entry.items() if k != "replicates"}
                 for name, entry in record["metrics"].items()},
        per_sentence=list(record.get("per_sentence") or ()),
        replicates={name: entry.replicates for name, entry in result.metrics.items() if entry.replicates is not None},
        convergence=record.get("convergence"), evaluation=dict(result.protocol.get("evaluation", {})),
        n_clipped=result.protocol.get("n_clipped", 0), num_subjects=result.dataset.num_subjects or 0,
        num_sentences=result.dataset.num_sentences or 0, timings=dict(result.timings),
        latency=None if result.latency is None else result.latency.to_json())


def score_stage(spec, root, expert, record):
    """Generate and score the test split with the row's method trained with seed
    ``spec["seed"]`` (loaded from its checkpoint, with the row's sampling options);
    writes the seed's scores (a result file, :func:`_seed_result`) and tracks under
    ``<work>/stages/rows/<row>``."""
    seed = int(spec["seed"])
    scores_path, tracks = _seed_paths(spec, seed)
    if scores_path.is_file() and tracks.is_dir() and not spec["force"]:
        return str(scores_path), None
    if record.get("stored") or _row_done(spec, root) is not None:
        return str(scores_path), None  # the row's result exists: the store stage keeps it
    run = _run_spec(spec, root, seed=seed, checkpoint=_checkpoint(spec, seed), expert=expert)
    inputs = check_inputs(run)
    trained = train(run, inputs.dataset)  # loaded: the checkpoint holds the trained method
    names = tuple(getattr(inputs.dataset, "names", ()) or COEFFICIENT_NAMES)
    writer = TrackWriter(tracks, names)
    try:
        generated = generate(run, inputs.dataset, trained, store=writer)
        scored = score(run, inputs.dataset, generated)
    except BaseException:
        writer.discard()
        raise
    owns, half = spec["owns_training"], record.get("half_budget")
    # the half-budget check as the training saw it (a row scoring another's training has none)
    seen = (SimpleNamespace(result=None if half is None else HalfBudget(**half), called=half is not None,
                            points=[HalfBudget(**p) for p in record.get("curve") or ([half] if half else [])])
            if owns and record.get("checked") else None)
    convergence, reason = checked_convergence(seen, record.get("reason") if owns else NOT_CHECKED["loaded"],
                                              scored.metrics)
    seed_run = SeedRun.scored(seed, generated, scored, convergence=convergence, timings={
        "train_s": record.get("train_s") if owns else None, "load_s": trained.load_s,
        "convergence_s": record.get("convergence_s") if owns else None})
    writer.commit()
    write(scores_path, _seed_result(spec, inputs, seed_run, label=trained.label, reason=reason))
    return str(scores_path), {"generate_s": generated.seconds, "evaluate_s": scored.seconds,
                              "load_s": trained.load_s}


def _with_shared_verdict(spec, root, combined, reason):
    """``(combined, reason)`` of a row that scores another row's training
    (``spec["training_owner"]``, that row's spec): each seed and the row carry the
    owner's half-budget verdict (:func:`benchmark.protocol.convergence.shared_convergence`),
    read from the owner's result file; unchanged when that file is missing or holds
    other seeds."""
    owner = spec["training_owner"]
    path = row_result_path(owner, root)
    if not path.is_file():
        log_progress(f"{spec['row']}: {path} not found: its training's half-budget check is not recorded")
        return combined, reason
    result = read(path)
    by_seed = {record.seed: record.convergence.to_json() if record.convergence else None
               for record in result.per_seed or ()}
    if sorted(by_seed) != sorted(int(record["seed"]) for record in combined.per_seed):
        log_progress(f"{spec['row']}: {path} holds seeds {sorted(by_seed)}: its training's check is not recorded")
        return combined, reason
    per_seed = []
    for record in combined.per_seed:
        verdict = shared_convergence(by_seed[int(record["seed"])], owner["row"])
        record = {k: v for k, v in record.items() if k != "convergence"}
        per_seed.append({**record, "convergence": verdict} if verdict is not None else record)
    convergence = shared_convergence(result.convergence.to_json() if result.convergence else None, owner["row"])
    if convergence is None:
        return dataclasses.replace(combined, per_seed=per_seed), reason
    return (dataclasses.replace(combined, per_seed=per_seed, convergence=convergence),
            f"shared training: checked on row {owner['row']}")


def store_stage(spec, root, expert, *scores_paths):
    """The row's result file from its seeds' scores: combined over the seeds and stored
    with every seed's tracks, as ``benchmark.run --seeds`` stores a run."""
    done = _row_done(spec, root)
    if done is not None:
        log_progress(f"{spec['row']}: {done} exists, kept (--force rescores)")
        return str(done), None
    seeds = [int(s) for s in spec["seeds"]]
    provenance = current_provenance()
    # the seeds' scores; after them, a row sharing a training gets the owner's stored result
    # (a dependency only: its verdict is read from the owner's result file)
    loaded = [read(p) for p in scores_paths[:len(seeds)]]
    runs = [_seed_run(result) for result in loaded]
    run = _run_spec(spec, root, seed=seeds[0], seeds=tuple(seeds), expert=expert,
                    checkpoint=Path(spec["work"]) / "trained" / spec["training"], stores=True)
    # a run over seeds refuses a checkpoint folder that holds trained methods (it would
    # train them again); here they are trained, so the inputs are checked without it
    inputs = check_inputs(dataclasses.replace(run, checkpoint=None))
    first = train(dataclasses.replace(run, seeds=None, checkpoint=_checkpoint(spec, seeds[0])), inputs.dataset)
    combined = combined_seed_scores(runs, stream=seed_stream(first.label))
    reason = next((r.protocol.convergence_check for r in loaded if r.protocol.convergence_check != CHECKED), CHECKED)
    if spec.get("training_owner") is not None:
        combined, reason = _with_shared_verdict(spec, root, combined, reason)
    writer = track_writer(run, inputs, first)
    try:
        for seed in seeds:
            shutil.copytree(_seed_paths(spec, seed)[1], writer.staging / f"seed{seed}")
        timings = summed_timings(runs)
        timings["total_s"] = sum(v for v in timings.values() if v is not None)
        path = store_seeds(run, inputs, first, runs, combined, writer=writer, timings=timings,
                           provenance=provenance, convergence_check=reason)
    except BaseException:
        writer.discard()
        raise
    return str(path), {}
