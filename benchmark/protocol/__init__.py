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

:func:`run` composes them (nothing is written when a step fails);
``python -m benchmark.run`` is the command line over it. A run over several training seeds (``RunSpec.seeds``)
repeats train, generate and score per seed and stores one result
(:mod:`benchmark.protocol.seeds`). Which error a step raises says whose fault it is
(:mod:`blendvoca.errors`): :class:`UsageError` / ``UserError`` for what was asked,
``DataError`` for a build file, ``MethodError`` for the method.
"""

from __future__ import annotations

import time
import warnings
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
    with_default_sync_expert,
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
    "with_default_sync_expert",
    "write_run",
]


def run(spec: RunSpec, *, evaluate=None, open_dataset=None) -> Path:
    """Check, train, generate, score and store the run ``spec`` asks for.

    Parameters
    ----------
    spec : RunSpec
    evaluate : callable, optional
        ``evaluate(tracks, dataset, split=..., metrics=None) -> {metric: {...}}`` in place of
        ``benchmark.evaluation.evaluate_split`` (its assets are then not checked).
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
    if evaluate is None:  # the default evaluation scores a build of recorded speech with the real-speech expert
        spec = with_default_sync_expert(spec, inputs.dataset)
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


def run_method(method_name: str, data_root=None, *, evaluate=None, open_dataset=None, **spec_fields) -> Path:
    """Deprecated (removed after 2027-06-30): ``run(RunSpec(method_name, data_root=data_root,
    **spec_fields), evaluate=evaluate, open_dataset=open_dataset)``; build a :class:`RunSpec`."""
    warnings.warn("benchmark.protocol.run_method is removed after 2027-06-30: build a RunSpec and call "
                  "benchmark.protocol.run(spec)", DeprecationWarning, stacklevel=2)
    return run(RunSpec(method_name, data_root=data_root, **spec_fields), evaluate=evaluate, open_dataset=open_dataset)
