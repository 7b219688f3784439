"""The stages of a board on a captured corpus (``leaderboard.reproduce --corpus facegood``).

A capture is not generated: its build is made by its dataset adapter from the files
``data_manifest.yaml`` names (through the asset resolver), and what scores its rows is
not the synthetic board's:

* ``data`` (:func:`capture_data_stage`): the build under ``<work>/<build_name>`` and a
  VAE trained on its training split, ``<work>/vae/<build_name>.pth`` with its card
  (:mod:`benchmark.features.card`), each made when missing (resumable; the VAE also
  when its card records another step budget or build); or a given ``--vae``, checked against
  the build's coefficient names;
* ``expert`` (:func:`capture_models_stage`): the project's real-speech lip-sync expert
  (:data:`benchmark.lipsync.default_expert.REAL_SPEECH_EXPERT`), after checking that the
  result files already in ``--results`` on this build were scored by the same corpus,
  VAE and expert (the rows join their table: one table, one set of scoring models).

The row stages are the synthetic board's (:mod:`leaderboard.executors.stages`); each
row's spec carries the VAE (``spec["vae"]``).
"""

from __future__ import annotations

import time
from pathlib import Path

from blendvoca.errors import DataError, UserError
from blendvoca.format import manifest_path
from leaderboard.executors.core import Resources, Task, log_progress

__all__ = ["capture_data_stage", "capture_models_stage", "corpus_tasks", "missing_assets", "vae_path"]


def vae_path(work, build_name: str) -> Path:
    """Where the board's VAE is trained to: ``<work>/vae/<build_name>.pth``."""
    return Path(work) / "vae" / f"{build_name}.pth"


def corpus_tasks(corpus, base: dict, *, data=None, vae=None, vae_steps=None) -> tuple[list, str]:
    """The ``data`` and ``expert`` tasks of the captured corpus ``corpus``
    (:class:`leaderboard.reproduce.CorpusPlan`) and the VAE path every row is scored with."""
    given = vae is not None
    path = Path(vae).expanduser().resolve() if given else vae_path(base["work"], corpus.build_name)
    steps = None if given else int(vae_steps if vae_steps is not None else corpus.vae_steps)
    data_spec = {**base, "data": None if data is None else str(data), "dataset": corpus.dataset,
                 "title": corpus.title, "build_name": corpus.build_name, "vae": str(path), "vae_steps": steps,
                 "vae_init": corpus.vae_init}
    build = str(Path(base["work"]) / corpus.build_name) if data is None else str(data)
    tasks = [
        Task("data", "data", capture_data_stage, data_spec, resources=Resources(cpus=2, memory_gb=4.0),
             outputs=(build, str(path))),
        Task("expert", "expert", capture_models_stage, {**base, "dataset": corpus.dataset, "title": corpus.title,
                                                         "vae": str(path)},
             deps=("data",), resources=Resources(cpus=1, memory_gb=2.0), outputs=()),
    ]
    return tasks, str(path)


def missing_assets(asset_ids) -> list:
    """The asset ids of ``asset_ids`` with no local copy (``$BLENDVOCA_ASSETS``, the cache);
    nothing is downloaded."""
    from blendvoca.assets import find_local

    return [asset_id for asset_id in asset_ids if find_local(asset_id) is None]


def capture_data_stage(spec):
    """The build the rows are scored on (``spec["data"]``, or the corpus built by its
    adapter under ``spec["work"]``) and the VAE of its latent metrics (trained on its
    training split when missing, or the given one checked against it)."""
    from benchmark.data import open_blendvoca
    from benchmark.features.card import check_vae_fits, read_vae_card

    started = time.perf_counter()
    details = {}
    if spec.get("data"):
        root = Path(spec["data"]).expanduser().resolve()
        if not manifest_path(root).is_file():
            raise UserError(f"--data {root}: not a BlendVOCA build (no manifest.json)")
    else:
        root = Path(spec["work"]) / spec["build_name"]
        if not manifest_path(root).is_file():
            root = built_capture(root, spec["dataset"], spec["title"])
            details["build_s"] = time.perf_counter() - started
    dataset = open_blendvoca(root)
    vae = Path(spec["vae"])
    if spec["vae_steps"] is None:  # the user's VAE: it must read this build's coefficients
        check_vae_fits(vae, dataset.names, data=root)
    elif not (vae.is_file() and _trained_as_planned(read_vae_card(vae), dataset, int(spec["vae_steps"]),
                                                    spec.get("vae_init"))):
        # missing, or trained with another budget (--vae-steps), start or on another build (--data): trained now
        from benchmark.features.train import train_vae_on_build  # torch: loaded only to train

        start = f", from the {spec['vae_init']} VAE" if spec.get("vae_init") else ""
        log_progress(f"training the VAE of the latent metrics on {root}'s training split, {spec['vae_steps']} "
                     f"steps{start}")
        vae.parent.mkdir(parents=True, exist_ok=True)
        begun = time.perf_counter()
        train_vae_on_build(root, vae, steps=int(spec["vae_steps"]), init=spec.get("vae_init"), seed=0)
        details["vae_s"] = time.perf_counter() - begun
    else:  # trained by an earlier run: on this build's shapes (a build made again may differ)
        check_vae_fits(vae, dataset.names, data=root)
    return str(root), (details or None)


def _trained_as_planned(card, dataset, steps: int, init=None) -> bool:
    """Whether a VAE's card says it was trained on ``dataset`` (its recipe) with ``steps``
    steps from the starting weights ``init`` (None: random)."""
    from benchmark.protocol.storing import dataset_identity

    if card is None:
        return False
    trained_on = (card.get("data") or {}).get("recipe_id")
    return (card.get("steps") == steps and card.get("init") == init
            and trained_on == dataset_identity(dataset)["recipe_id"])


def built_capture(root: Path, dataset: str, title: str, *, workers: int = 2) -> Path:
    """The corpus ``dataset`` built by its adapter from its asset files into ``root``."""
    from blendvoca.datasets import adapter

    log_progress(f"building {title} into {root} from its asset files (data_manifest.yaml)")
    summary = adapter(dataset)(None, root, workers=workers)
    if summary.failures:
        raise RuntimeError(f"build of {root} had {len(summary.failures)} failure(s), e.g. {summary.failures[0]}")
    return Path(root)


def _expert_digest(path) -> str:
    from benchmark.protocol.storing import lipsync_models_provenance

    return lipsync_models_provenance(None, path)["sync_expert"]["weights_sha256"]


def table_conflicts(results_dir, dataset, *, vae, expert, corpus: str, replaced=()) -> list:
    """What in ``results_dir`` would share the table of ``dataset``'s rows (its recipe id)
    but was scored otherwise: ``"<file>: <what differs>"`` for each result of another
    corpus, VAE (``protocol.vae``; none: the published one) or lip-sync expert (its
    weights digest). Files named in ``replaced`` (rows the plan writes again) are left out."""
    from benchmark.protocol.storing import dataset_identity
    from benchmark.results import read
    from blendvoca.format.hashing import content_digest
    from leaderboard.collect import result_files

    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        return []
    key = dataset_identity(dataset)["recipe_id"]
    vae_digest, expert_digest = content_digest(vae), _expert_digest(expert)
    replaced = {Path(p).name for p in replaced}
    out = []
    for path in result_files(results_dir):
        if path.name in replaced:
            continue
        result = read(path)
        if result.key != key:
            continue  # another table
        differs = []
        if (result.dataset.name or "vocaset") != corpus:
            differs.append(f"corpus {result.dataset.name or 'vocaset'}, not {corpus}")
        theirs = (result.protocol.get("vae") or {}).get("sha256")
        if theirs != vae_digest:
            differs.append(f"VAE {str(theirs)[:12] if theirs else 'the published one'}, not {vae_digest[:12]}")
        model = (result.protocol.lipsync_models or {}).get("sync_expert") or {}
        if model.get("weights_sha256") != expert_digest:
            differs.append(f"lip-sync expert {str(model.get('weights_sha256') or 'none')[:12]}, "
                           f"not {expert_digest[:12]}")
        if differs:
            out.append(f"{path.name}: {', '.join(differs)}")
    return out


def capture_models_stage(spec, root):
    """The lip-sync expert scoring every row (the project's real-speech expert), once the
    rows' table is checked: a result already in ``--results`` on this build that another
    corpus, VAE or expert scored would share the table (a UserError naming them; nothing
    is scored)."""
    from benchmark.data import open_blendvoca
    from benchmark.lipsync.default_expert import REAL_SPEECH_EXPERT
    from leaderboard.executors.stages import row_result_path

    if not REAL_SPEECH_EXPERT.is_file():
        raise DataError(f"{REAL_SPEECH_EXPERT}: the project's real-speech lip-sync expert is missing from the "
                        "package; reinstall it")
    replaced = [row_result_path(row, root) for row in spec.get("rows", ())] if spec["force"] else []
    conflicts = table_conflicts(spec["results"], open_blendvoca(root), vae=spec["vae"], expert=REAL_SPEECH_EXPERT,
                                corpus=spec["dataset"], replaced=replaced)
    if conflicts:
        raise UserError(f"--results {spec['results']}: the {spec['title']} rows would share a table with results "
                        f"scored otherwise ({'; '.join(conflicts[:3])}{'; ...' if len(conflicts) > 3 else ''}); "
                        "move them out first (--archive DIR) or give another --results")
    return str(REAL_SPEECH_EXPERT), None
