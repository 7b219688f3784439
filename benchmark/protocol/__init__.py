"""The benchmark protocol: what one run of a method does, step by step.

A run is asked for with a :class:`RunSpec` and goes through four steps, each a
function returning a small record, so that tests and notebooks can call, replace or
inspect any of them::

    spec = RunSpec("regression", budget=Budget(max_steps=50))
    inputs = check_inputs(spec)                  # the build, results folder, split ... (UsageError)
    check, why_not = half_budget_check(spec, inputs)                  # settled or not (convergence)
    trained = train(spec, inputs.dataset, check=check)                # Trained: built and trained, or loaded
    writer = track_writer(spec, inputs, trained)
    generated = generate(spec, inputs.dataset, trained, store=writer)   # Generated
    scored = score(spec, inputs.dataset, generated)                      # Scored
    convergence = convergence_record(check.result, scored.metrics)
    path = store(spec, inputs, trained, generated, scored, writer=writer, timings=..., provenance=...,
                 convergence=convergence, convergence_check="checked")

:func:`run` composes them (nothing is written when a step fails) and
:func:`run_method` is the same with keyword arguments; ``python -m benchmark.run``
is the command line over it. A run over several training seeds (``RunSpec.seeds``)
repeats train, generate and score per seed and stores one result
(:mod:`benchmark.protocol.seeds`). Which error a step raises says whose fault it is
(:mod:`blendvoca.errors`): :class:`UsageError` / ``UserError`` for what was asked,
``DataError`` for a build file, ``MethodError`` for the method.
"""

from __future__ import annotations

import time
from pathlib import Path

from benchmark.methods import Budget
from benchmark.protocol.convergence import (
    CHECK_METRICS,
    CHECKED,
    NOT_CHECKED,
    HalfBudgetCheck,
    checked_convergence,
    convergence_record,
    half_budget_check,
)
from benchmark.protocol.generation import Generated, generate, generated_tracks, sentence_seed
from benchmark.protocol.limits import DEFAULT_GENERATE_LIMIT, GenerateLimit, TimeLimit, generate_limit
from benchmark.protocol.scoring import MODEL_LIPSYNC_METRICS, Scored, loaded_lipsync_models, score, score_lipsync_models
from benchmark.protocol.spec import (
    Inputs,
    RunSpec,
    UsageError,
    check_inputs,
    check_results_dir,
    checked_seeds,
    default_data_root,
    default_results_dir,
    open_data,
)
from benchmark.protocol.seeds import CombinedScores, SeedRun, combined_seed_scores, parse_seeds, run_seeds
from benchmark.protocol.storing import (
    lipsync_models_provenance,
    result_name,
    store,
    store_seeds,
    track_writer,
    write_run,
)
from benchmark.protocol.training import TRAIN_GRACE_S, Trained, make_method, prepared_method, train
from benchmark.results import current_provenance

__all__ = [
    "CHECKED",
    "CHECK_METRICS",
    "DEFAULT_GENERATE_LIMIT",
    "GenerateLimit",
    "MODEL_LIPSYNC_METRICS",
    "NOT_CHECKED",
    "TRAIN_GRACE_S",
    "CombinedScores",
    "Generated",
    "HalfBudgetCheck",
    "Inputs",
    "RunSpec",
    "Scored",
    "SeedRun",
    "TimeLimit",
    "Trained",
    "UsageError",
    "check_inputs",
    "check_results_dir",
    "checked_seeds",
    "combined_seed_scores",
    "convergence_record",
    "default_data_root",
    "default_results_dir",
    "generate",
    "generate_limit",
    "generated_tracks",
    "half_budget_check",
    "lipsync_models_provenance",
    "loaded_lipsync_models",
    "make_method",
    "open_data",
    "parse_seeds",
    "prepared_method",
    "result_name",
    "run",
    "run_method",
    "run_seeds",
    "score",
    "score_lipsync_models",
    "sentence_seed",
    "store",
    "store_seeds",
    "track_writer",
    "train",
    "write_run",
]


def run(spec: RunSpec, *, evaluate=None, open_dataset=None) -> Path:
    """Check, train, generate, score and store the run ``spec`` asks for.

    Parameters
    ----------
    spec : RunSpec
    evaluate : callable, optional
        ``evaluate(tracks, dataset, split=...) -> {metric: {...}}`` in place of
        ``benchmark.evaluate.evaluate_split`` (its assets are then not checked).
    open_dataset : callable, optional
        ``open_dataset(root) -> dataset`` in place of ``benchmark.data.open_blendvoca``.

    Returns
    -------
    Path
        The result file. Nothing is written when any step fails.
    """
    started = time.perf_counter()
    provenance = current_provenance()  # the code as it is when the run starts
    inputs = check_inputs(spec, open_dataset=open_dataset, evaluation_assets=evaluate is None)
    if spec.seeds is not None:
        return run_seeds(spec, inputs, evaluate=evaluate, provenance=provenance, started=started)
    check, reason = half_budget_check(spec, inputs, evaluate=evaluate)
    trained = train(spec, inputs.dataset, check=check)
    writer = track_writer(spec, inputs, trained)
    try:
        generated = generate(spec, inputs.dataset, trained, store=writer)
        scored = score(spec, inputs.dataset, generated, evaluate=evaluate)
        convergence, reason = checked_convergence(check, reason, scored.metrics)
        timings = {"train_s": trained.train_s, "load_s": trained.load_s, "generate_s": generated.seconds,
                   "evaluate_s": scored.seconds, "convergence_s": trained.convergence_s,
                   "total_s": time.perf_counter() - started}
        return store(spec, inputs, trained, generated, scored, writer=writer, timings=timings, provenance=provenance,
                     convergence=convergence, convergence_check=reason)
    except BaseException:
        writer.discard()
        raise


def run_method(
    method_name: str,
    data_root=None,
    *,
    samples: int = 10,
    seed: int | None = None,
    seeds=None,
    budget: Budget | None = None,
    results_dir=None,
    config: dict | None = None,
    split: str = "test",
    checkpoint=None,
    clip: bool = False,
    evaluate=None,
    open_dataset=None,
    progress: bool = True,
    generate_time_limit: float | None = None,
    vocaset=None,
    syncnet=None,
    sync_expert=None,
    sentence_batch: int = 1,
    verify: bool = True,
    device: str | None = None,
    vae=None,
) -> Path:
    """Train or load ``method_name``, generate on ``split``, score it and write the result.

    Parameters
    ----------
    method_name : str
        Registered or installed method name.
    data_root : path-like or None
        BlendVOCA build; None uses :func:`default_data_root`.
    samples : int
        Samples per sentence for stochastic methods (deterministic ones give one).
    seed : int, optional
        Training and sampling seed (default 0).
    seeds : sequence of int, optional
        Training seeds (exclusive with ``seed``): one run per seed, stored as one
        result (:mod:`benchmark.protocol.seeds`); the method must train.
    budget : Budget, optional
        Training limits (default: none, the method's own defaults).
    results_dir : path-like, optional
        Where the result JSON and its tracks folder are written (default:
        :func:`default_results_dir`).
    config : dict, optional
        Method constructor kwargs.
    checkpoint : path-like, optional
        Load the trained method from here if it holds one, else train and save there.
    clip : bool
        Clip out-of-range coefficients instead of failing.
    evaluate : callable, optional
        ``evaluate(generated, dataset, split=...) -> {metric: {...}}``; default
        ``benchmark.evaluate.evaluate_split``.
    open_dataset : callable, optional
        ``open_dataset(root) -> dataset``; default ``benchmark.data.open_blendvoca``.
    generate_time_limit : float or GenerateLimit, optional
        How long one ``generate`` call may take before the run stops with
        :class:`~blendvoca.errors.MethodTimeout`: None for
        :data:`DEFAULT_GENERATE_LIMIT` (120 s + 60 s per second of audio), seconds
        per call, or 0 for no limit.
    vocaset : path-like, optional
        The source VOCASET corpus (for ``dataset.vertices``) when the build's
        recorded one is elsewhere.
    syncnet, sync_expert : path-like or model, optional
        SyncNet weights and a learned sync expert for the lip-sync metrics (loaded
        when the run is scored).
    sentence_batch : int, default 1
        Sentences per generation call (:func:`generated_tracks`); recorded in the
        protocol when above 1, since batched samples may differ from one-by-one
        ones by float rounding.
    verify : bool, default True
        Check the split's files against the build's manifest digests first
        (:class:`~blendvoca.errors.CheckFailed` for one that changed).
    device : str, optional
        ``"cpu"``, ``"cuda"``, ``"cuda:N"`` or ``"auto"``: where the method trains and
        generates (``RunSpec.device``); a GPU run records ``protocol.device``.
    vae : path-like, optional
        The VAE of the latent metrics (``RunSpec.vae``); default the published one.

    Notes
    -----
    Step budgets make runs deterministic: the same seed gives the same metric
    values. A time budget depends on the machine; the result records
    ``protocol.deterministic = false`` for it. A trained method that calls
    ``on_checkpoint`` at half its steps is checked for convergence
    (:mod:`benchmark.protocol.convergence`; the result's ``convergence``).

    Raises
    ------
    UsageError
        Among others: ``seed`` and ``seeds`` both given, a repeated or non-integer
        seed, ``seeds`` for a method that does not train (all before anything trains).

    Returns
    -------
    Path
        The result file. Nothing is written when any step fails.
    """
    if seed is not None and seeds is not None:
        raise UsageError("--seeds: not allowed with --seed (the seeds are the training seeds of the run)")
    spec = RunSpec(method=method_name, config=config, data_root=data_root, split=split, samples=samples,
                   seed=0 if seed is None else seed, seeds=seeds, budget=budget, checkpoint=checkpoint, clip=clip,
                   generate_time_limit=generate_time_limit, sentence_batch=sentence_batch, vocaset=vocaset,
                   syncnet=syncnet, sync_expert=sync_expert, results_dir=results_dir, verify=verify, progress=progress,
                   device=device, vae=vae)
    return run(spec, evaluate=evaluate, open_dataset=open_dataset)
