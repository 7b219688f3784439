"""``python -m leaderboard.reproduce``: the committed leaderboard from nothing.

One command generates the VOCASET-size synthetic corpus (12 speakers x 40 sentences,
seed 0; test split 2 speakers x 40 sentences), builds BlendVOCA from it, scores every
built-in method with a step budget (deterministic: the same command gives the same
numbers) and renders the tables::

    python -m leaderboard.reproduce --work ~/blendvoca-12x40 \\
        --results leaderboard/results --tables leaderboard/tables

Every stage is resumable: an existing corpus, build, trained model or result file
is reused (``--force`` rescores). ``--only NAME`` scores some methods only. The
corpus takes about 7 GB and 1 minute, the build about 2 minutes on 2 cores; rows of
one method that differ only in sampling (CDFace diverse and lips fixed) share one
training, kept in ``<work>/trained``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import UserError

__all__ = ["CORPUS", "PLAN", "PlanEntry", "main", "reproduce"]

#: The synthetic corpus of the committed leaderboard.
CORPUS = {"speakers": 12, "sentences": 40, "seed": 0, "layout": "processed"}
#: Training steps of built-in methods without their own entry.
DEFAULT_STEPS = 1000


@dataclass(frozen=True)
class PlanEntry:
    """How one leaderboard row is produced."""

    method: str
    config: dict = field(default_factory=dict)
    samples: int = 1
    max_steps: int | None = None
    note: str = ""
    #: Rows with the same key train once: the first saves its trained method into
    #: ``<work>/trained/<key>``, the others load it and change only its sampling
    #: options (``Method.sampling_options``). Training is deterministic under a step
    #: budget, so this gives the numbers of training again.
    shared_training: str | None = None


#: CDFace's cpu-demo stages stop at a step count only (no time limits: deterministic).
CDFACE_STEPS_ONLY = {"preset": "cpu-demo", "vq_max_seconds": None, "query_max_seconds": None}

#: Training steps of the learned lip-sync expert (benchmark.lipsync) scoring every row.
EXPERT_STEPS = 1271

#: The rows, in scoring order (cheap references first).
PLAN = (
    PlanEntry("ground-truth", note="upper reference: the build's own tracks"),
    PlanEntry("mean", note="train-split mean, constant"),
    PlanEntry("static", note="all zeros: the neutral face"),
    PlanEntry("corpus-meshes", note="the source meshes through the mesh adapter (60 fps, head-crop QP fit)"),
    PlanEntry("random", samples=10, note="smooth random tracks, 10 samples"),
    PlanEntry("regression", max_steps=1500, note="log-mel -> 1-D conv regression, 1500 steps"),
    PlanEntry("said", config={"preset": "cpu-demo"}, samples=5, max_steps=1500,
              note="SAiD cpu-demo preset, 1500 steps, 5 samples, DDIM 50 (paper: 72 samples, DDIM 1000)"),
    PlanEntry("faceformer", config={"preset": "cpu-demo"}, samples=8, max_steps=1500,
              note="FaceFormer cpu-demo (log-mel front end, width 64), 1500 steps of one sentence, "
                   "8 samples = 8 training-speaker styles"),
    PlanEntry("codetalker", config={"preset": "cpu-demo"}, samples=8, max_steps=2000,
              note="CodeTalker cpu-demo (VQ-VAE 64 = 4 x 16, 128 codes), 800 + 1200 steps (stage 1 + 2), "
                   "8 samples = 8 training-speaker styles"),
    PlanEntry("cdface", config=CDFACE_STEPS_ONLY, samples=5, max_steps=1500, shared_training="cdface",
              note="CDFace cpu-demo preset, 1500 steps per stage, 5 samples (the paper's S)"),
    PlanEntry("cdface", config={**CDFACE_STEPS_ONLY, "control": "lips"}, samples=5, max_steps=1500,
              shared_training="cdface",
              note="CDFace lips fixed, upper face varied (the paper's Table III setting; the model of the row above)"),
)


def _log(message: str) -> None:
    print(f"[reproduce] {message}", file=sys.stderr, flush=True)


def built_dataset(work: Path, *, workers: int = 2, progress: bool = True) -> Path:
    """The 12 x 40 synthetic corpus and its BlendVOCA build under ``work`` (made when missing)."""
    from blendvoca.build import build_dataset
    from blendvoca.synthetic import generate_corpus

    corpus = work / "synth"
    if not (corpus / "synthetic.json").is_file():
        _log(f"generating the synthetic corpus into {corpus}")
        generate_corpus(corpus, progress=progress, **CORPUS)
    root = work / "blendvoca12x40"
    summary = build_dataset(root, corpus, workers=workers, progress=progress)
    if summary.failures:
        raise RuntimeError(f"build of {root} had {len(summary.failures)} failure(s), e.g. {summary.failures[0]}")
    return root


def _entries(only) -> list:
    from benchmark.methods import BUILTIN_METHODS

    planned = {e.method for e in PLAN} | {"mesh-adapter"}
    extra = [PlanEntry(name, max_steps=DEFAULT_STEPS, note=f"default config, {DEFAULT_STEPS} steps")
             for name in sorted(BUILTIN_METHODS) if name not in planned]
    entries = list(PLAN) + extra
    if only:
        unknown = sorted(set(only) - {e.method for e in entries})
        if unknown:
            raise UserError(f"--only: unknown plan entries {unknown}; expected some of {[e.method for e in entries]}")
        entries = [e for e in entries if e.method in only]
    return entries


def reproduce(work, results_dir, tables_dir, *, only=None, force: bool = False, progress: bool = True) -> list:
    """Build the dataset, score the plan's methods into ``results_dir`` and render ``tables_dir``.

    Returns
    -------
    list of Path
        The result files of the plan's rows.
    """
    from benchmark.methods import get_method
    from benchmark.results import result_filename
    from benchmark.run import run_method
    from leaderboard.build import build_leaderboard

    work, results_dir = Path(work).expanduser(), Path(results_dir)
    entries = _entries(only)  # an unknown --only row fails before the corpus and the build are made
    root = built_dataset(work, progress=progress)
    from benchmark.data import open_blendvoca

    dataset = open_blendvoca(root)
    from benchmark.lipsync.expert_training import cached_expert

    # the learned lip-sync expert, trained once on the build's training split (step budget: deterministic)
    _, expert = cached_expert(root, max_seconds=None, max_steps=EXPERT_STEPS, progress=progress)
    paths = []
    for entry in entries:
        name, config = entry.method, dict(entry.config)
        if name == "corpus-meshes":
            from baselines.mesh_adapter.export import exported_corpus_meshes

            meshes = work / "corpus-meshes-60fps"
            if not (meshes / "adapter.yaml").is_file():
                exported_corpus_meshes(work / "synth", meshes, fps=60, progress=progress)
            name, config = "mesh-adapter", {"config": str(meshes / "adapter.yaml")}
        cls = get_method(name)
        # the label may depend on the config (mesh-adapter's source, cdface's control)
        label = getattr(cls(**config), "label", None) or name
        samples = entry.samples if cls.stochastic else 1
        expected = results_dir / result_filename({"method": {"name": name, "label": label},
                                                  "dataset": {"manifest_hash": dataset.manifest_hash},
                                                  "protocol": {"samples": samples, "seed": 0}})
        if expected.is_file() and not force:
            _log(f"{label}: {expected} exists, kept (--force rescores)")
            paths.append(expected)
            continue
        _log(f"{label}: {entry.note}")
        from benchmark.methods.base import Budget

        checkpoint = None if entry.shared_training is None else work / "trained" / entry.shared_training
        paths.append(run_method(name, root, samples=samples, seed=0, budget=Budget(max_steps=entry.max_steps),
                                results_dir=results_dir, config=config, progress=progress, sync_expert=expert,
                                checkpoint=checkpoint))
    for path in build_leaderboard(results_dir, tables_dir):
        _log(f"wrote {path}")
    return paths


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("leaderboard.reproduce", __doc__)
    parser.add_argument("--work", required=True, help="folder for the corpus (~7 GB) and the build")
    parser.add_argument("--tables", required=True, help="table folder (the committed one: leaderboard/tables)")
    parser.add_argument("--only", action="append", default=None, metavar="METHOD", help="score only these rows")
    parser.add_argument("--force", action="store_true", help="rescore rows whose result file exists")
    cli.add_results_option(parser, required=True, help="result folder (the committed one: leaderboard/results)")
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    for path in reproduce(args.work, args.results, args.tables, only=args.only, force=args.force,
                          progress=not args.quiet):
        print(path)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
