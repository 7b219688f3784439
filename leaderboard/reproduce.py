"""``python -m leaderboard.reproduce``: the committed leaderboard from nothing.

One command generates the VOCASET-size one-to-many synthetic corpus (12 speakers x
40 sentences, seed 0, 70 % of the motion fixed by the audio, 8 oracle draws per
sentence; test split 2 speakers x 40 sentences), builds BlendVOCA from it, scores
every built-in method with a step budget (deterministic: the same command gives the
same numbers), every trained row with training seeds 0, 1 and 2, and renders the
tables::

    python -m leaderboard.reproduce --work ~/blendvoca-12x40 \\
        --results leaderboard/results --tables leaderboard/tables

``--corpus facegood`` makes the real board instead (:data:`FACEGOOD`): the FACEGOOD
captures built from their asset files (``data_manifest.yaml``, through the asset
resolver), a VAE trained on the build's training split for the latent metrics, the
project's real-speech lip-sync expert, and the rows of :data:`FACEGOOD_PLAN`. Each
corpus is data (:class:`CorpusPlan`, :data:`CORPORA`); its rows go into its own table.

The plan is a set of tasks (:mod:`leaderboard.executors`): the corpus and its build
(``--data BUILD`` scores an existing build instead), the learned lip-sync expert, and
per row and seed the training (rows of one method that differ only in sampling,
CDFace diverse and lips fixed, share it), generation and scoring, then the row's
result file. ``--executor sequential`` (the default) runs them one after the other
in this process; ``--executor ray`` runs them as Ray tasks on a local Ray instance,
or on an existing cluster with ``--address`` (``pip install -e ".[cluster]"``),
each with the CPUs, GPUs and memory its row declares; a task whose worker dies runs
again. Both write the same result files.

Every stage is resumable: an existing corpus, build, trained model, scored seed or
result file is reused (``--force`` rescores, reusing trained models). ``--only NAME``
(repeated, or comma-separated) scores some rows only. The corpus takes about 7 GB,
the build a few minutes on 2 cores. ``--archive DIR`` first moves the result files
already in ``--results`` (and their tracks) into ``DIR``, which the tables do not
read. Wall times per stage are kept under ``<work>/stages/timings``;
``--timings`` prints them per row and stage (with ``--results``, also those of the
result files there, which outlive the work folder), and each task's peak memory (its
process and children). ``--write-memory`` merges those peaks into
``leaderboard/measured-memory.json``, from which the plan declares each task's memory
(the peak x 1.25 + 0.5 GiB; unmeasured tasks: 2 GiB, the build 4 GiB); a plan with a
task declaring more than the machine has is refused before anything runs.
"""

from __future__ import annotations

import shutil
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import DataError, UserError
from blendvoca.runtime.locks import LockHeld, held_lock
from blendvoca.runtime.progress import show_progress
from leaderboard.executors import EXECUTORS, log_progress
from leaderboard.executors.memory import declared_memory_gb, measured_memory, measured_peak_gb

__all__ = ["CORPORA", "CORPUS", "FACEGOOD", "FACEGOOD_PLAN", "PLAN", "SEEDS", "SYNTHETIC", "CorpusPlan", "PlanEntry",
           "archive_results", "main", "plan_tasks", "reproduce"]

#: The synthetic corpus of the committed leaderboard: the one-to-many corpus, whose
#: oracle draws give the oracle rows.
CORPUS = {"speakers": 12, "sentences": 40, "seed": 0, "layout": "processed", "audio_determined": 0.7,
          "oracle_samples": 8}
#: Folders of the corpus and its build under ``--work`` (named after the corpus, so a
#: work folder of an earlier corpus is not taken for this one).
CORPUS_NAME = "synth-one-to-many"
BUILD_NAME = "blendvoca12x40-one-to-many"
#: The lock file of a work folder (held while a reproduce runs on it).
WORK_LOCK = ".reproduce.lock"
#: Training seeds of every trained row.
SEEDS = (0, 1, 2)
#: Training steps of built-in methods without their own entry.
DEFAULT_STEPS = 1000


@dataclass(frozen=True)
class PlanEntry:
    """How one leaderboard row is produced.

    Attributes
    ----------
    method : str
        Registered method (``corpus-meshes``: the mesh adapter on the corpus's meshes).
    config : dict
    samples : int
    max_steps : int or None
    note : str
    shared_training : str or None
        Rows with the same key train once per seed: the first row of the plan with the
        key owns the training (``<work>/trained/<key>/seed<k>``, with its half-budget
        check), the others load it and change only its sampling options
        (``Method.sampling_options``). Training is deterministic under a step budget,
        so this gives the numbers of training again.
    name : str or None
        The row's name (``--only``, the work folder); default: the method.
    cpus, gpus, memory_gb
        What each of the row's tasks reserves (:class:`leaderboard.executors.Resources`);
        ``cpus`` is also the task's thread count, on either executor: 2, the cores the
        committed board was made with (its floats depend on it in the last digits).
        ``memory_gb`` (GiB) is the default of a task whose peak was not measured on the
        build: a measured one declares its peak with a margin
        (:mod:`leaderboard.executors.memory`).
    """

    method: str
    config: dict = field(default_factory=dict)
    samples: int = 1
    max_steps: int | None = None
    note: str = ""
    shared_training: str | None = None
    name: str | None = None
    cpus: int = 2
    gpus: float = 0.0
    memory_gb: float | None = 2.0

    @property
    def row(self) -> str:
        """The row's name."""
        return self.name or self.method


#: CDFace's cpu-demo stages stop at a step count only (no time limits: deterministic).
CDFACE_STEPS_ONLY = {"preset": "cpu-demo", "vq_max_seconds": None, "query_max_seconds": None}

#: Training steps of the learned lip-sync expert (benchmark.lipsync) scoring every row.
EXPERT_STEPS = 1271

#: The rows, in scoring order (cheap references first).
PLAN = (
    PlanEntry("ground-truth", note="upper reference: the build's own tracks"),
    PlanEntry("oracle-sample", samples=8, note="the corpus's own conditional draws, 8 samples"),
    PlanEntry("oracle-mean", note="the mean of the corpus's 8 conditional draws"),
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
    PlanEntry("cdface", config=CDFACE_STEPS_ONLY, samples=5, max_steps=4000, shared_training="cdface",
              note="CDFace cpu-demo preset, 4000 steps per stage (the preset's), 5 samples (the paper's S)"),
    PlanEntry("cdface", config={**CDFACE_STEPS_ONLY, "control": "lips"}, samples=5, max_steps=4000,
              shared_training="cdface", name="cdface-lips",
              note="CDFace lips fixed, upper face varied (the paper's Table III setting; the model of the row above)"),
)


def memory_build(data=None, build_name: str = BUILD_NAME) -> str:
    """The name the measured-memory table knows a build by: its folder's name (the
    plan's own build: ``build_name``, the corpus's :attr:`CorpusPlan.build_name`)."""
    return build_name if data is None else Path(data).expanduser().resolve().name


def memory_refusal(tasks, node_gb: float, *, memory: dict | None = None, build: str | None = None) -> str | None:
    """The one-line reason a plan cannot run on a node of ``node_gb`` GiB: its first task
    declaring more memory than that (with the measured peak its declaration comes
    from); None when every task fits."""
    from leaderboard.executors.memory import oversized

    over = oversized(tasks, node_gb)
    if not over:
        return None
    task = over[0]
    peak = measured_peak_gb(measured_memory() if memory is None else memory, build or BUILD_NAME, task.row,
                            task.stage)
    why = "the plan's default" if peak is None else f"its measured peak {peak:.2f} GiB with the margin"
    more = f" (and {len(over) - 1} more task(s))" if len(over) > 1 else ""
    return (f"plan entry {task.key} needs {task.resources.memory_gb:g} GiB of memory ({why}), more than the "
            f"{node_gb:.1f} GiB this machine has{more}; nothing was run")


@dataclass(frozen=True)
class CorpusPlan:
    """One board's corpus, as data: where its build comes from, what scores its latent and
    lip-sync columns, and its rows.

    Attributes
    ----------
    name : str
        ``--corpus NAME``.
    title : str
        The corpus in messages and docs.
    dataset : str
        The corpus name its builds record (``BlendVOCADataset.dataset_name``; ``"vocaset"``:
        the VOCASET layout, which the synthetic corpus has): ``--data`` must be such a build.
    plan : tuple of PlanEntry
        The rows, in scoring order; each row's ``max_steps`` is its budget on this corpus.
    build_name : str
        The build's folder under ``--work``.
    source_name : str or None
        The generated corpus's folder under ``--work`` (the synthetic corpus); None: the
        build is made by the dataset adapter ``dataset`` from its asset files.
    generator : dict or None
        ``blendvoca.synthetic.generate_corpus`` arguments of a generated corpus.
    vae_steps : int or None
        None: the latent metrics use the published VAE; else a VAE is trained on the
        build's training split with this many steps (``benchmark.features.train``).
    vae_init : str or None
        Where that training starts: None from random weights, ``"published"`` from the
        published VAE (fine-tuned: from random weights FACEGOOD's decoder dies, docs/datasets.md).
    extra_methods : bool
        Add a row (:data:`DEFAULT_STEPS`) for each built-in method the plan does not name.
    assets : str or None
        ``"module:NAME"`` of the ``data_manifest.yaml`` ids the adapter builds from (a
        mapping or sequence of ids; imported only when checked); None: none.
    """

    name: str
    title: str
    dataset: str
    plan: tuple
    build_name: str
    source_name: str | None = None
    generator: dict | None = None
    vae_steps: int | None = None
    vae_init: str | None = None
    extra_methods: bool = False
    assets: str | None = None

    def asset_ids(self) -> tuple:
        """The ``data_manifest.yaml`` ids of the files its build reads (none for a generated corpus)."""
        if self.assets is None:
            return ()
        import importlib

        module, name = self.assets.split(":")
        return tuple(getattr(importlib.import_module(module), name))  # the adapter: imported only now


#: The synthetic board (the committed leaderboard).
SYNTHETIC = CorpusPlan("synthetic", "the synthetic one-to-many corpus (12 x 40)", "vocaset", PLAN, BUILD_NAME,
                       source_name=CORPUS_NAME, generator=CORPUS, extra_methods=True)


def _on_facegood(row: str, **changes) -> PlanEntry:
    """The synthetic board's row ``row`` (its budget, resources and sampling) with ``changes``."""
    return replace(next(e for e in PLAN if e.row == row), **changes)


#: Styles of FaceFormer and CodeTalker on FACEGOOD: one per training take (one speaker, 4 takes).
FACEGOOD_STYLES = 4
#: The real board's rows: the reference rows a capture has (no oracle draws, no source
#: meshes) and every trainable method, each with the synthetic board's budget per row
#: (the real board's own budgets are chosen later by the settled-by-ranking rule, here).
FACEGOOD_PLAN = (
    _on_facegood("ground-truth", note="upper reference: the build's own tracks (FACEGOOD's controls on ARKit shapes)"),
    _on_facegood("mean"),
    _on_facegood("static"),
    _on_facegood("random"),
    _on_facegood("regression"),
    _on_facegood("said"),
    _on_facegood("faceformer", samples=FACEGOOD_STYLES,
                 note="FaceFormer cpu-demo (log-mel front end, width 64) on the ARKit reference rig's vertices, "
                      f"1500 steps of one sentence, {FACEGOOD_STYLES} samples = the {FACEGOOD_STYLES} training takes' "
                      "styles"),
    _on_facegood("codetalker", samples=FACEGOOD_STYLES,
                 note="CodeTalker cpu-demo (VQ-VAE 64 = 4 x 16, 128 codes) on the ARKit reference rig's vertices, "
                      f"800 + 1200 steps (stage 1 + 2), {FACEGOOD_STYLES} samples = the {FACEGOOD_STYLES} training "
                      "takes' styles"),
    _on_facegood("cdface"),
    _on_facegood("cdface-lips"),
)
#: Training steps of the real board's VAE (docs/datasets.md's recipe for a corpus's own VAE).
FACEGOOD_VAE_STEPS = 3000
#: The real board: FACEGOOD's seven takes, split by take (train 2_01-2_04, val 2_05, test 3_15, 3_16).
FACEGOOD = CorpusPlan("facegood", "FACEGOOD", "facegood", FACEGOOD_PLAN, "facegood-build",
                      vae_steps=FACEGOOD_VAE_STEPS, vae_init="published",
                      assets="blendvoca.datasets.facegood:ASSET_IDS")
#: ``--corpus NAME`` -> its plan.
CORPORA = {plan.name: plan for plan in (SYNTHETIC, FACEGOOD)}


def _corpus(name) -> CorpusPlan:
    if isinstance(name, CorpusPlan):
        return name
    if name not in CORPORA:
        raise UserError(f"--corpus {name!r}: expected one of {list(CORPORA)}")
    return CORPORA[name]


def _entries(only, corpus: CorpusPlan = SYNTHETIC) -> list:
    from benchmark.methods import BUILTIN_METHODS

    planned = {e.method for e in corpus.plan} | {"mesh-adapter"}
    extra = [PlanEntry(name, max_steps=DEFAULT_STEPS, note=f"default config, {DEFAULT_STEPS} steps")
             for name in sorted(BUILTIN_METHODS) if name not in planned] if corpus.extra_methods else []
    entries = list(corpus.plan) + extra
    if only:
        known = {e.row for e in entries} | {e.method for e in entries}
        unknown = sorted(set(only) - known)
        if unknown:
            raise UserError(f"--only: unknown plan entries {unknown}; expected some of "
                            f"{list(dict.fromkeys(e.row for e in entries))}")
        # a method name selects each of its rows (cdface: both CDFace rows)
        entries = [e for e in entries if e.row in only or e.method in only]
    return entries


def _trains(entry: PlanEntry) -> bool:
    """Whether the row's method learns from a training seed (it then runs with seeds)."""
    from benchmark.methods import get_method
    from benchmark.protocol.spec import trains_nothing

    return trains_nothing(get_method("mesh-adapter" if entry.method == "corpus-meshes" else entry.method)) is None


def _split_names(values) -> list | None:
    """``--only a,b --only c`` -> ``["a", "b", "c"]`` (None when not given)."""
    if not values:
        return None
    return [name.strip() for value in values for name in str(value).split(",") if name.strip()]


def plan_tasks(work, results_dir, *, only=None, data=None, seeds=SEEDS, max_steps=None,
               expert_steps: int = EXPERT_STEPS, cpus_per_task: int | None = None, force: bool = False,
               memory: dict | None = None, corpus="synthetic", vae=None, vae_steps: int | None = None) -> list:
    """The plan as tasks (:class:`leaderboard.executors.Task`), in dependency order.

    Parameters
    ----------
    work, results_dir : path-like
    only : sequence of str, optional
        Row or method names (a method selects each of its rows).
    data : path-like, optional
        Score this build; None generates and builds the plan's corpus under ``work``.
    corpus : str or CorpusPlan
        The board (:data:`CORPORA`): ``"synthetic"`` (the committed board) or ``"facegood"``.
    vae : path-like, optional
        The VAE of the latent metrics instead of the corpus's (the published one, or the
        one trained on the build); checked against the build's coefficient names.
    vae_steps : int, optional
        Training steps of the corpus's VAE instead of the plan's (``CorpusPlan.vae_steps``).
    seeds : sequence of int
        Training seeds of the trained rows.
    max_steps : int, optional
        Caps every row's training steps (quick runs and tests; recorded in each result).
    expert_steps : int
        Training steps of the lip-sync expert.
    cpus_per_task : int, optional
        Every row's CPUs (and threads) instead of the plan's ``PlanEntry.cpus``.
    memory : dict, optional
        Measured peaks (:func:`leaderboard.executors.memory.measured_memory`; default:
        the committed table). A task whose row and stage were measured on this build
        declares :func:`~leaderboard.executors.memory.declared_memory_gb` of its peak,
        the others the plan's default (``PlanEntry.memory_gb``).

    Every task's spec carries the progress switch as it is now (``"progress"``): each
    task runs with it, wherever it runs (:func:`leaderboard.executors.execute`).

    Returns
    -------
    list of Task
        ``data``, ``expert``, then per row either ``row/<row>`` (one run), or
        ``train/<training>/seed<k>``, ``score/<row>/seed<k>`` and ``store/<row>``.
    """
    from leaderboard.executors import Resources, Task
    from leaderboard.executors import stages

    if int(expert_steps) < 1:  # 0 or fewer steps would train until a budget that never comes
        raise UserError(f"expert_steps: expected an integer >= 1, got {expert_steps}")

    corpus = _corpus(corpus)
    if vae_steps is not None and int(vae_steps) < 1:
        raise UserError(f"vae_steps: expected an integer >= 1, got {vae_steps}")
    entries = _entries(only, corpus)
    seeds = [int(s) for s in seeds]
    base = {"work": str(Path(work).expanduser().resolve()), "results": str(Path(results_dir).expanduser().resolve()),
            "force": bool(force), "progress": show_progress()}
    # the build the tasks run on names their measured peaks (recorded with each task's timing)
    base["build"] = memory_build(data, corpus.build_name)
    measured = measured_memory() if memory is None else memory

    def declared(row, stage, default):
        peak = measured_peak_gb(measured, base["build"], row, stage)
        return default if peak is None else declared_memory_gb(peak)

    corpus_name = corpus.source_name or corpus.name
    if corpus.generator is not None:  # a generated corpus: the synthetic board's stages, as they always were
        tasks = [
            Task("data", "data", stages.data_stage, {**base, "data": None if data is None else str(data),
                                                     "corpus": dict(corpus.generator), "corpus_name": corpus_name,
                                                     "build_name": corpus.build_name},
                 resources=Resources(cpus=2, memory_gb=declared(None, "data", 4.0)),
                 outputs=(str(Path(base["work"]) / corpus.build_name),)),
            Task("expert", "expert", stages.expert_stage, {**base, "expert_steps": int(expert_steps)}, deps=("data",),
                 resources=Resources(cpus=1, memory_gb=declared(None, "expert", 2.0)),
                 outputs=("<cache>/sync-expert",)),
        ]
        vae_path = None if vae is None else str(Path(vae).expanduser().resolve())
    else:
        from leaderboard.executors import capture_stages

        tasks, vae_path = capture_stages.corpus_tasks(corpus, base, data=data, vae=vae, vae_steps=vae_steps)

    def row_spec(entry: PlanEntry, trained: bool) -> dict:
        steps = entry.max_steps
        if max_steps is not None:
            steps = int(max_steps) if steps is None else min(int(steps), int(max_steps))
        spec = {**base, "row": entry.row, "method": entry.method, "config": dict(entry.config),
                "samples": entry.samples, "max_steps": steps, "note": entry.note, "corpus_name": corpus_name,
                "seeds": list(seeds) if trained else None, "training": entry.shared_training or entry.row}
        return spec if vae_path is None else {**spec, "vae": vae_path}

    trained_rows = [e for e in entries if _trains(e)]
    owners = {}
    for entry in list(corpus.plan) + [e for e in entries if e not in corpus.plan]:
        owners.setdefault(entry.shared_training or entry.row, entry)
    emitted = set()
    for entry in entries:
        def resources(row, stage, cpus=int(cpus_per_task or entry.cpus), gpus=entry.gpus, entry=entry):
            return Resources(cpus=cpus, gpus=gpus, memory_gb=declared(row, stage, entry.memory_gb))

        if entry not in trained_rows:
            spec = row_spec(entry, False)
            tasks.append(Task(f"row/{entry.row}", "single", stages.single_stage, spec, deps=("data", "expert"),
                              resources=resources(entry.row, "single"), outputs=(base["results"],), row=entry.row))
            continue
        spec = row_spec(entry, True)
        training = spec["training"]
        owner = owners[training]
        for seed in seeds:
            key = f"train/{training}/seed{seed}"
            if key not in emitted:
                emitted.add(key)
                sharing = [row_spec(e, True) for e in trained_rows if (e.shared_training or e.row) == training]
                tasks.append(Task(key, "train", stages.train_stage,
                                  {**row_spec(owner, True), "seed": seed, "rows": sharing}, deps=("data",),
                                  resources=resources(owner.row, "train"), row=owner.row, seed=seed,
                                  outputs=(str(Path(base["work"]) / "trained" / training / f"seed{seed}"),)))
            tasks.append(Task(f"score/{entry.row}/seed{seed}", "score", stages.score_stage,
                              {**spec, "seed": seed, "owns_training": owner.row == entry.row},
                              deps=("data", "expert", key), resources=resources(entry.row, "score"),
                              row=entry.row, seed=seed,
                              outputs=(str(Path(base["work"]) / "stages" / "rows" / entry.row),)))
        # a row scoring another row's training carries that row's half-budget verdict
        shares = owner.row != entry.row
        store_deps = (f"store/{owner.row}",) if shares and owner in entries else ()
        tasks.append(Task(f"store/{entry.row}", "store", stages.store_stage,
                          {**spec, "training_owner": row_spec(owner, True) if shares else None},
                          deps=("data", "expert", *(f"score/{entry.row}/seed{s}" for s in seeds), *store_deps),
                          resources=resources(entry.row, "store", cpus=1, gpus=0.0), row=entry.row,
                          outputs=(base["results"],)))
    if corpus.generator is None:  # the check of the table the rows join needs their result names
        tasks[1] = replace(tasks[1], spec={**tasks[1].spec, "rows": [row_spec(e, _trains(e)) for e in entries]})
    return tasks


def archive_results(results_dir, archive) -> list:
    """Move every result file of ``results_dir`` and its tracks folder into ``archive``.

    The tables read only the result files directly in ``results_dir``, so an archive
    beside it (e.g. ``leaderboard/results-archive/<name>``) keeps the old board out of
    the new one's tables. Nothing is moved when a name would replace a file already
    in ``archive``.

    Returns
    -------
    list of Path
        The moved result files, at their new place.
    """
    from benchmark.runs import tracks_folder_name

    results_dir, archive = Path(results_dir).expanduser().resolve(), Path(archive).expanduser().resolve()
    if archive == results_dir:
        raise UserError(f"--archive {archive}: expected a folder other than --results")
    moves = []
    for path in sorted(results_dir.glob("*.json")) if results_dir.is_dir() else ():
        moves.append(path)
        tracks = results_dir / tracks_folder_name(path.name)
        if tracks.is_dir():
            moves.append(tracks)
    clashes = [p.name for p in moves if (archive / p.name).exists()]
    if clashes:
        raise UserError(f"--archive {archive}: already holds {clashes[:3]}; nothing was moved")
    archive.mkdir(parents=True, exist_ok=True)
    for path in moves:
        shutil.move(str(path), str(archive / path.name))
    return [archive / p.name for p in moves if p.suffix == ".json"]


def _check_corpus_inputs(corpus: CorpusPlan, data, vae) -> None:
    """UserError, before anything runs, when the board cannot be made as asked: ``data``
    a build of another corpus (its rows would go into that corpus's table), the corpus's
    asset files missing (named, with where to put them), or ``vae`` not a file."""
    if vae is not None and not Path(vae).expanduser().is_file():
        raise UserError(f"--vae {vae}: no such file (a VAE state dict, python -m benchmark.features.train)")
    if data is not None:
        from benchmark.data import open_blendvoca

        try:
            found = getattr(open_blendvoca(Path(data).expanduser()), "dataset_name", "vocaset")
        except (UserError, DataError, FileNotFoundError) as exc:
            raise UserError(f"--data {data}: {exc}") from None
        if found != corpus.dataset:
            raise UserError(f"--data {data}: a build of the {found} corpus, but --corpus {corpus.name} plans rows of "
                            f"{corpus.title} (builds recording the corpus {corpus.dataset!r}); give a build of that "
                            "corpus, or the --corpus of this build")
        return
    from leaderboard.executors.capture_stages import missing_assets

    missing = missing_assets(corpus.asset_ids())
    if missing:
        from blendvoca.assets import entry

        mirrors = sorted({str(Path(entry(i)["mirror"]).parent) for i in missing})
        raise UserError(f"--corpus {corpus.name}: its files are not found: asset ids {', '.join(missing)} "
                        f"(data_manifest.yaml); put them under a folder named in BLENDVOCA_ASSETS (as "
                        f"{', '.join(mirrors)}/<file>, e.g. BLENDVOCA_ASSETS=shared/assets:shared/realdata), or fetch "
                        f"them: python -m blendvoca.assets fetch {' '.join(missing)}; or give --data BUILD")


def reproduce(work, results_dir, tables_dir, *, only=None, force: bool = False, executor: str = "sequential",
              address: str | None = None, data=None, seeds=SEEDS, max_steps: int | None = None,
              expert_steps: int = EXPERT_STEPS, cpus_per_task: int | None = None, max_retries: int = 3,
              archive=None, corpus="synthetic", vae=None, vae_steps: int | None = None) -> list:
    """Build the dataset, score the plan's rows into ``results_dir`` and render ``tables_dir``.

    Parameters
    ----------
    work, results_dir, tables_dir : path-like
    only : sequence of str, optional
        Rows to score (row or method names); default: all.
    executor : {"sequential", "ray"}
        Where the plan's tasks run (:func:`leaderboard.executors.run_tasks`).
    address : str, optional
        An existing Ray cluster (``--executor ray`` only); None starts a local instance.
    data, seeds, max_steps, expert_steps, cpus_per_task
        As :func:`plan_tasks`.
    max_retries : int
        Ray's reruns of a task whose worker died.
    archive : path-like, optional
        First move the result files already in ``results_dir`` there (:func:`archive_results`).
    corpus, vae, vae_steps
        As :func:`plan_tasks`. A corpus built from asset files needs them in place (or
        ``data``), and ``data`` must be a build of the corpus: checked before anything runs.

    Returns
    -------
    list of Path
        The result files of the plan's rows, in plan order.
    """
    from leaderboard.build import build_leaderboard
    from leaderboard.executors import run_tasks

    if executor not in EXECUTORS:
        raise UserError(f"--executor {executor!r}: expected one of {list(EXECUTORS)}")
    if address is not None and executor != "ray":
        raise UserError("--address: only with --executor ray")
    if data is not None and not Path(data).expanduser().is_dir():
        raise UserError(f"--data {data}: no such folder")
    corpus = _corpus(corpus)
    _check_corpus_inputs(corpus, data, vae)
    # an unknown --only row fails before the corpus and the build are made
    tasks = plan_tasks(work, results_dir, only=only, data=data, seeds=seeds, max_steps=max_steps,
                       expert_steps=expert_steps, cpus_per_task=cpus_per_task, force=force, corpus=corpus,
                       vae=vae, vae_steps=vae_steps)
    if executor == "sequential" or address is None:
        # a task declaring more memory than this machine has would be killed (or wait forever on Ray)
        from leaderboard.executors.memory import machine_memory_gb

        refusal = memory_refusal(tasks, machine_memory_gb(), build=memory_build(data, corpus.build_name))
        if refusal is not None:
            raise UserError(refusal)
    work = Path(work).expanduser()
    work.mkdir(parents=True, exist_ok=True)
    try:
        with held_lock(work / WORK_LOCK):  # one reproduce per work folder: two would run every stage twice
            if archive is not None:
                for path in archive_results(results_dir, archive):
                    log_progress(f"archived {path}")
            values = run_tasks(tasks, executor=executor, address=address, max_retries=max_retries)
            paths = [Path(values[t.key]) for t in tasks if t.stage in ("single", "store")]
            from leaderboard.settled import store_statements  # the table's verdict on each row, into its record

            for path in store_statements(results_dir):
                log_progress(f"stored the statements its half budget would change in {path}")
            for path in build_leaderboard(results_dir, tables_dir):
                log_progress(f"wrote {path}")
    except LockHeld as exc:
        raise UserError(f"--work {work}: another leaderboard.reproduce (pid {exc.holder or 'unknown'}) is using this "
                        "work folder; wait for it to finish (rerunning then resumes), or give another --work") from None
    return paths


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("leaderboard.reproduce", __doc__)
    parser.add_argument("--work", required=True, help="folder for the corpus (~7 GB), the build and the stages")
    parser.add_argument("--tables", default=None, help="table folder (the committed one: leaderboard/tables)")
    parser.add_argument("--only", action="append", default=None, metavar="NAME[,NAME...]",
                        help="score only these rows (row or method names; repeated or comma-separated)")
    parser.add_argument("--force", action="store_true", help="rescore rows whose result file exists")
    parser.add_argument("--executor", choices=EXECUTORS, default="sequential",
                        help="run the plan's tasks in this process (sequential) or as Ray tasks (ray)")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="an existing Ray cluster ('auto', HOST:6379 or ray://HOST:10001; default: a local "
                             "Ray instance for the run)")
    parser.add_argument("--max-retries", type=int, default=3, metavar="N",
                        help="reruns of a Ray task whose worker died (default 3)")
    parser.add_argument("--seeds", default=",".join(map(str, SEEDS)), metavar="S1,S2,...",
                        help="training seeds of the trained rows (default 0,1,2)")
    parser.add_argument("--expert-steps", type=int, default=EXPERT_STEPS, metavar="N",
                        help=f"training steps of the lip-sync expert (default {EXPERT_STEPS})")
    parser.add_argument("--cpus-per-task", type=int, default=None, metavar="N",
                        help="CPUs (and threads) of every row's tasks instead of the plan's (2); the last digits "
                             "of some metrics depend on it")
    parser.add_argument("--archive", default=None, metavar="DIR",
                        help="first move the result files in --results (and their tracks) into DIR, "
                             "which the tables do not read")
    parser.add_argument("--corpus", choices=tuple(CORPORA), default="synthetic",
                        help="the board: synthetic (the generated 12 x 40 one-to-many corpus, the committed board) or "
                             "facegood (the FACEGOOD captures from their asset files, a VAE trained on the build, "
                             "the real-speech lip-sync expert; docs/leaderboard.md)")
    parser.add_argument("--vae", default=None, metavar="PATH",
                        help="the VAE of the latent metrics instead of the corpus's (synthetic: the published one; "
                             "facegood: one trained on the build's training split); checked against the build")
    parser.add_argument("--vae-steps", type=int, default=None, metavar="N",
                        help=f"training steps of a captured corpus's VAE (default {FACEGOOD_VAE_STEPS})")
    parser.add_argument("--timings", action="store_true",
                        help="print the wall time per row and stage recorded under --work (and, with "
                             "--results, in that folder's result files), and exit")
    parser.add_argument("--write-memory", nargs="?", const="", default=None, metavar="PATH",
                        help="merge the peak memory per row and stage recorded under --work into the table the "
                             "plan declares its memory from (default: the committed "
                             "leaderboard/measured-memory.json), and exit")
    cli.add_data_option(parser, help="score this BlendVOCA build (of the --corpus) instead of generating and "
                                     "building the 12 x 40 corpus or building the captures")
    cli.add_results_option(parser, help="result folder (the committed one: leaderboard/results)")
    # a step budget caps every row's own (quick runs; recorded in the results): the board has no time budgets
    cli.add_budget_options(parser)
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    if args.write_memory is not None:
        from leaderboard.executors import timing_records
        from leaderboard.executors.memory import write_measured_memory

        records = [r for r in timing_records(args.work) if r.get("peak_rss_gb") is not None]
        if not records:
            raise UserError(f"--write-memory: expected stage timing records with a peak_rss_gb under "
                            f"{Path(args.work) / 'stages' / 'timings'}, found none")
        print(write_measured_memory(records, args.write_memory or None))
        return cli.EXIT_OK
    if args.timings:
        from leaderboard.executors import result_timing_table, timing_records, timing_table
        from leaderboard.executors.memory import memory_table

        print(timing_table(args.work))
        if any(r.get("peak_rss_gb") is not None for r in timing_records(args.work)):
            print("\nPeak memory (the task's process's RSS and its children's unique memory, the highest over the seeds):\n")
            print(memory_table(timing_records(args.work)))
        if args.results is not None:
            print(f"\nFrom the result files in {args.results}:\n")
            print(result_timing_table(args.results))
        return cli.EXIT_OK
    for flag, value in (("--results", args.results), ("--tables", args.tables)):
        if value is None:
            parser.error(f"{flag} is required")
    max_steps, max_seconds = cli.budget_limits(args)
    if max_seconds is not None:
        parser.error("--budget/--max-seconds: the board's budgets are steps (deterministic); give --max-steps N")
    for flag, value, least in (("--cpus-per-task", args.cpus_per_task, 1), ("--expert-steps", args.expert_steps, 1),
                               ("--max-retries", args.max_retries, 0), ("--vae-steps", args.vae_steps, 1)):
        if value is not None and value < least:
            parser.error(f"{flag}: expected an integer >= {least}, got {value}")
    cli.require_address_space("leaderboard.reproduce")
    from benchmark.protocol import parse_seeds

    for path in reproduce(args.work, args.results, args.tables, only=_split_names(args.only), force=args.force,
                          executor=args.executor, address=args.address, data=args.data,
                          seeds=parse_seeds(args.seeds), max_steps=max_steps, expert_steps=args.expert_steps,
                          cpus_per_task=args.cpus_per_task, max_retries=args.max_retries, archive=args.archive,
                          corpus=args.corpus, vae=args.vae, vae_steps=args.vae_steps):
        print(path)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
