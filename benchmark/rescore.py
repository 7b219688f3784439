"""``python -m benchmark.rescore RUN.json ... --sync-expert PATH [--syncnet-weights PATH]``:
add the model-based lip-sync metrics to stored runs, from the tracks they stored.

A stored run (:mod:`benchmark.runs`) keeps every generated track, so the lip-sync
scores of a learned sync expert or of SyncNet can be added later without running
the method again: the tracks are read back, scored exactly as ``benchmark.run``
scores them (:func:`benchmark.protocol.score_lipsync_models`, the lip-sync stage of
:func:`benchmark.evaluation.evaluate_split`), and the result file is rewritten with
those metrics, their per-sentence values and the models' provenance
(``protocol.lipsync_models``). Other metrics are left as they are.

Before scoring, the files of the rescored speakers (their audio, rigs and ground-truth
tracks) are checked against the digests in the build's ``manifest.json``, as
``benchmark.run`` checks them: a file changed since the build is refused (exit status
4) unless ``--no-verify``, which scores the files as they are and records the run as
not verified (``protocol.verified``).
"""

from __future__ import annotations

import sys
from pathlib import Path

from benchmark.evaluation.registry import ordered_metrics
from benchmark.protocol import lipsync_models_provenance, open_data, score_lipsync_models, write_run
from benchmark.results import check
from benchmark.runs import read_run
from blendvoca import cli
from blendvoca.errors import UserError

__all__ = ["main", "rescored_result"]


def rescored_result(json_path, *, syncnet=None, sync_expert=None, data=None, verify: bool = True) -> dict:
    """The result of a stored run with the model-based lip-sync metrics (re)computed.

    Parameters
    ----------
    json_path : str or path-like
        A result JSON written by ``benchmark.run`` (with stored tracks).
    syncnet, sync_expert : str or path-like, optional
        SyncNet weights (authors' format) and a learned sync expert; at least one.
    data : str or path-like, optional
        The BlendVOCA build to read audio and rigs from (default: the run's ``dataset.path``).
    verify : bool, default True
        Check the rescored speakers' files against the build's manifest digests before
        scoring; off, they are scored as they are and ``protocol.verified`` becomes False.

    Returns
    -------
    dict
        The result record, its metrics in table order.

    Raises
    ------
    UserError
        No model given, a model file that holds none, or a build other than the run's.
    DataError
        The result file or its stored tracks do not read, or a file the build's manifest
        lists is gone.
    CheckFailed
        ``verify`` and a file of a rescored speaker differs from what the build made.
    """
    if syncnet is None and sync_expert is None:
        raise UserError("benchmark.rescore: expected --sync-expert and/or --syncnet-weights, got neither")
    json_path = Path(json_path)
    stored = read_run(json_path)
    result = stored.result.to_json()
    if result.get("seeds") or result["protocol"].get("seeds"):
        # each seed's tracks and intervals would have to be rescored and recombined
        raise UserError(f"benchmark.rescore: {json_path} combines runs over the training seeds "
                        f"{result.get('seeds') or result['protocol'].get('seeds')}; rescoring such a result is not "
                        "supported: rerun it with benchmark.run --seeds and the lip-sync models")
    dataset = open_data(data if data is not None else stored.dataset_root)
    if str(dataset.manifest_hash) != result["dataset"]["manifest_hash"]:
        raise UserError(f"benchmark.rescore: {json_path} was scored on manifest "
                        f"{result['dataset']['manifest_hash'][:12]}, but {dataset.root} has "
                        f"{str(dataset.manifest_hash)[:12]}")
    keys = [(row["subject"], row["sentence"]) for row in result.get("per_sentence") or []] or stored.keys
    tracks = {key: stored.tracks(*key) for key in keys}
    # the same check benchmark.run makes before it scores (benchmark.protocol.spec): only
    # the files of the speakers whose tracks are rescored, since only those are read
    check = getattr(dataset, "verify", None) if verify else None
    if check is not None:
        check(sorted({subject for subject, _ in keys}))
    scored = score_lipsync_models(tracks, dataset, syncnet=syncnet, sync_expert=sync_expert)
    metrics = {**result["metrics"], **scored.metrics}
    rows = {(row["subject"], row["sentence"]): row for row in scored.per_sentence}
    result = {**result, "metrics": {name: metrics[name] for name in ordered_metrics(list(metrics))}}
    result["per_sentence"] = [{**row, **rows.get((row["subject"], row["sentence"]), {})}
                              for row in result.get("per_sentence") or []]
    result["protocol"] = {**result["protocol"],
                          "lipsync_models": {**result["protocol"].get("lipsync_models", {}),
                                             **lipsync_models_provenance(syncnet, sync_expert)}}
    if not verify:  # metrics now come from files nobody checked, whatever the run checked
        result["protocol"]["verified"] = False
    return result


@cli.command
def main(argv=None) -> int:
    p = cli.parser("benchmark.rescore", __doc__)
    p.add_argument("runs", nargs="+", help="result JSON files of stored runs")
    p.add_argument("--sync-expert", default=None, metavar="PATH", help="learned sync expert (benchmark.lipsync)")
    p.add_argument("--syncnet-weights", default=None, metavar="PATH", help="SyncNet weights (syncnet_v2.model)")
    cli.add_data_option(p, help="BlendVOCA build folder (default: each run's dataset.path)")
    p.add_argument("--no-verify", dest="verify", action="store_false",
                   help="score the rescored speakers' files as they are, without checking them against the "
                        "build's manifest.json digests first (a modified build is otherwise refused, exit 4; "
                        "recorded in the result)")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    cli.require_address_space("benchmark.rescore")
    for run in args.runs:
        result = rescored_result(run, syncnet=args.syncnet_weights, sync_expert=args.sync_expert,
                                 data=args.data, verify=args.verify)
        path = Path(run)
        print(write_run(check(result, str(path)), path.parent, path.name, overwrite=True))  # its own file
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
