"""``python -m benchmark.rescore RUN.json ... --sync-expert PATH [--syncnet-weights PATH]``:
add the model-based lip-sync metrics to stored runs, from the tracks they stored.

A stored run (:mod:`benchmark.runs`) keeps every generated track, so the lip-sync
scores of a learned sync expert or of SyncNet can be added later without running
the method again: the tracks are read back, scored exactly as ``benchmark.run``
scores them (the lip-sync stage of :func:`benchmark.evaluate.evaluate_split`), and
the result file is rewritten with those metrics, their per-sentence values and the
models' provenance (``protocol.lipsync_models``). Other metrics are left as they are.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

__all__ = ["main", "rescored_result"]

_MODEL_METRICS = ("av_offset_expert", "av_confidence_expert", "av_offset_syncnet", "av_confidence_syncnet")


def rescored_result(json_path, *, syncnet=None, sync_expert=None, data=None, progress: bool = True) -> dict:
    """The result of a stored run with the model-based lip-sync metrics (re)computed.

    Parameters
    ----------
    json_path : path-like
        A result JSON written by ``benchmark.run`` (with stored tracks).
    syncnet, sync_expert : path-like, optional
        SyncNet weights (authors' format) and a learned sync expert; at least one.
    data : path-like, optional
        The BlendVOCA build to read audio and rigs from (default: the run's ``dataset.path``).
    """
    from benchmark.data import open_blendvoca
    from benchmark.evaluate import _lipsync_values, _load_models, _sentence_entries
    from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES
    from benchmark.metrics.registry import ordered_metrics
    from benchmark.run import lipsync_models_provenance
    from benchmark.runs import read_run

    if syncnet is None and sync_expert is None:
        raise ValueError("benchmark.rescore: expected --sync-expert and/or --syncnet-weights, got neither")
    stored = read_run(json_path)
    result = stored.result
    dataset = open_blendvoca(data if data is not None else stored.dataset_root)
    if str(dataset.manifest_hash) != result["dataset"]["manifest_hash"]:
        raise ValueError(f"benchmark.rescore: {json_path} was scored on manifest {result['dataset']['manifest_hash'][:12]}, "
                         f"but {dataset.root} has {str(dataset.manifest_hash)[:12]}")
    keys = [(row["subject"], row["sentence"]) for row in result.get("per_sentence") or []] or stored.keys
    generated = {key: stored.tracks(*key) for key in keys}
    rigs = {s: dataset.rig(s) for s in {k[0] for k in keys}}
    audio = {k: dataset.audio(*k) for k in keys}
    syncnet_model, expert_model = _load_models(syncnet, sync_expert)
    values = _lipsync_values(generated, rigs, audio, dataset.names, syncnet=syncnet_model, sync_expert=expert_model,
                             progress=progress)
    values = {name: v for name, v in values.items() if name in _MODEL_METRICS}
    # evaluate_split's own bootstrap seed (0), as benchmark.run scores: same tracks, same intervals
    added, rows = _sentence_entries(values, seed=0, resamples=BOOTSTRAP_RESAMPLES)
    metrics = {**result["metrics"], **added}
    result = {**result, "metrics": {name: metrics[name] for name in ordered_metrics(list(metrics))}}
    result["per_sentence"] = [{**row, **rows.get((row["subject"], row["sentence"]), {})}
                              for row in result.get("per_sentence") or []]
    result["protocol"] = {**result["protocol"],
                          "lipsync_models": {**result["protocol"].get("lipsync_models", {}),
                                             **lipsync_models_provenance(syncnet, sync_expert)}}
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmark.rescore", description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="result JSON files of stored runs")
    p.add_argument("--sync-expert", default=None, metavar="PATH", help="learned sync expert (benchmark.lipsync)")
    p.add_argument("--syncnet-weights", default=None, metavar="PATH", help="SyncNet weights (syncnet_v2.model)")
    p.add_argument("--data", default=None, help="BlendVOCA build (default: each run's dataset.path)")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    from benchmark.results import write_result
    from blendvoca.errors import error_line

    for run in args.runs:
        try:
            result = rescored_result(run, syncnet=args.syncnet_weights, sync_expert=args.sync_expert,
                                     data=args.data, progress=not args.quiet)
        except (ValueError, KeyError, OSError) as error:
            print(error_line(error), file=sys.stderr)
            return 2
        path = Path(run)
        print(write_result(result, path.parent, path.name))
    return 0


if __name__ == "__main__":
    sys.exit(main())
