"""What a benchmark run is asked to do (:class:`RunSpec`) and what it reads, checked
before anything is trained (:func:`check_inputs`)."""

from __future__ import annotations

import dataclasses

import math
import os
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from benchmark.data import open_blendvoca
from benchmark.methods import FPS, OUTPUT_COEFFICIENTS, OUTPUT_VERTICES, Budget, Method, MethodError, get_method
from benchmark.protocol.limits import GenerateLimit
from benchmark.protocol.training import make_method
from benchmark.protocol.verification import held_ground_truth, verified_inputs
from blendvoca.assets import find_local
from blendvoca.errors import DataError, UserError
from blendvoca.format import manifest_path

__all__ = [
    "LATENCY_SENTENCES",
    "Inputs",
    "RunSpec",
    "UsageError",
    "check_inputs",
    "checked_fractions",
    "checked_probe_times",
    "with_default_sync_expert",
    "check_results_dir",
    "checked_seeds",
    "default_data_root",
    "default_results_dir",
    "open_data",
    "trains_nothing",
]


class UsageError(UserError):
    """A mistake in what a run was asked to do (a flag, a path, a config entry): exit
    status 2, one ``error:`` line, nothing trained or written."""


def _is_seconds(value) -> bool:
    """True for a finite number >= 0 (``True`` is not one)."""
    try:
        return not isinstance(value, bool) and math.isfinite(float(value)) and float(value) >= 0
    except (TypeError, ValueError, OverflowError):
        return False


def _is_count(value, least: int = 1) -> bool:
    """True for an integer >= ``least`` (``True`` is not a count)."""
    try:
        return not isinstance(value, bool) and int(value) == value and int(value) >= least
    except (TypeError, ValueError, OverflowError):
        return False


def checked_seeds(seeds) -> tuple:
    """``seeds`` as a tuple of distinct integers >= 0 (the training seeds of a run).

    Raises
    ------
    UsageError
        Not a non-empty sequence of such integers, or a seed given twice (naming ``--seeds``).
    """
    if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__iter__"):
        raise UsageError(f"--seeds: expected a list of integers such as 0,1,2, got {seeds!r}")
    out = []
    for value in seeds:
        if not _is_count(value, 0):
            raise UsageError(f"--seeds: expected integers >= 0, got {value!r}")
        if int(value) in out:
            raise UsageError(f"--seeds: seed {int(value)} is given twice; expected distinct seeds")
        out.append(int(value))
    if not out:
        raise UsageError("--seeds: expected at least one seed, got none")
    return tuple(out)


@dataclass(frozen=True)
class RunSpec:
    """What a run is asked to do; checked when made (:class:`UsageError` otherwise).

    Parameters
    ----------
    method : str
        Registered or installed method name.
    config : dict, optional
        Method constructor kwargs (``--config`` / ``--preset``).
    data_root : path-like or None
        BlendVOCA build; None means :func:`default_data_root`.
    split : str, default "test"
        The split generated and scored.
    samples : int, default 10
        Samples per sentence for stochastic methods (deterministic ones give one).
    seed : int, optional
        Training and sampling seed (``--seed``); None: 0, or with ``seeds`` the first of
        them (another seed beside ``seeds`` is refused).
    seeds : sequence of int, optional
        Training seeds (``--seeds 0,1,2``): one run per seed (each trained, generated
        and scored with that seed) stored as one result; distinct integers >= 0, not
        with ``seed``. None: the single run of ``seed``.
    budget : Budget, optional
        Training limits (default: none, the method's own defaults).
    checkpoint : path-like, optional
        Load the trained method from here when it holds one, else train and save there;
        a file is a method's released weights (``from_official_checkpoint``).
    clip : bool
        Clip out-of-range coefficients instead of refusing them.
    generate_time_limit : float or GenerateLimit, optional
        How long one ``generate`` call may take: None (default) for
        :data:`~benchmark.protocol.limits.DEFAULT_GENERATE_LIMIT` (120 s + 60 s per
        second of audio), a number of seconds per call, or 0 for no limit.
    sentence_batch : int, default 1
        Sentences per generation call.
    vocaset : path-like, optional
        The source VOCASET corpus (``dataset.vertices``) when the build's recorded one
        is elsewhere.
    syncnet, sync_expert : path-like or model, optional
        SyncNet weights and a learned sync expert for the lip-sync metrics.
    results_dir : path-like, optional
        Where the result and its tracks go (default :func:`default_results_dir`).
    verify : bool, default True
        Check the files of the split against the build's ``manifest.json`` digests
        before anything runs (``--no-verify`` turns it off; recorded in the result).
    vae : path-like, optional
        A VAE state dict for the latent metrics (``--vae``; e.g. one trained on the
        dataset with ``python -m benchmark.features.train``); None: the published VAE
        (asset ``said-vae``), trained on BlendVOCA: out of domain on other corpora.
    device : str, optional
        ``"cpu"``, ``"cuda"``, ``"cuda:N"`` or ``"auto"`` (``--device``): handed to the
        method's ``train`` and where the trained method generates; None: each method's
        own choice (the CPU for every built-in one). Checked when the spec is made.
    overwrite : bool, default False
        Replace a result of other settings stored under the name this run writes
        (``--overwrite``); without it such a run is refused before anything is stored
        (:class:`benchmark.protocol.storing.ResultExistsError`).
    name : str, optional
        The result's file name, for a caller that names its own results (the
        leaderboard's rows); None: :func:`benchmark.protocol.storing.result_name`.
    checkpoint_fractions : sequence of float, optional
        Where in the step budget the learning curve is scored (``--checkpoint-fractions``;
        increasing, each in (0, 1], 1 being the full budget); None:
        :data:`benchmark.protocol.convergence.CURVE_FRACTIONS` (a quarter and half).
    lookahead_probes : sequence of float, optional
        Where the look-ahead probe cuts each probed sentence, seconds from its start
        (``--lookahead-probes``; :mod:`benchmark.protocol.lookahead`); None: its default
        cuts. A time outside a probed sentence is refused by :func:`check_inputs`.
    """

    method: str
    config: dict = field(default_factory=dict)
    data_root: object = None
    split: str = "test"
    samples: int = 10
    seed: int | None = None
    seeds: tuple | None = None
    budget: Budget = field(default_factory=Budget)
    checkpoint: object = None
    clip: bool = False
    generate_time_limit: object = None
    sentence_batch: int = 1
    vocaset: object = None
    syncnet: object = None
    sync_expert: object = None
    results_dir: object = None
    verify: bool = True
    device: str | None = None
    vae: object = None
    overwrite: bool = False
    name: str | None = None
    checkpoint_fractions: tuple | None = None
    lookahead_probes: tuple | None = None

    def __post_init__(self):
        if self.checkpoint_fractions is not None:
            try:
                object.__setattr__(self, "checkpoint_fractions", checked_fractions(self.checkpoint_fractions))
            except ValueError as exc:
                raise UsageError(str(exc)) from None
        if not _is_count(self.samples):
            raise UsageError(f"--samples: expected an integer >= 1, got {self.samples!r}")
        limit = self.generate_time_limit
        if limit is not None and not isinstance(limit, GenerateLimit) and not _is_seconds(limit):
            raise UsageError(f"--generate-time-limit: expected seconds >= 0 (0: no limit), got {limit!r}")
        if not _is_count(self.sentence_batch):
            raise UsageError(f"--sentence-batch: expected an integer >= 1, got {self.sentence_batch!r}")
        # a copy: the caller's dict may change after the run was asked for
        object.__setattr__(self, "config", dict(self.config or {}))
        object.__setattr__(self, "budget", self.budget or Budget())
        object.__setattr__(self, "samples", int(self.samples))
        object.__setattr__(self, "sentence_batch", int(self.sentence_batch))
        if self.lookahead_probes is not None:
            probes = self.lookahead_probes
            # numbers here; inside every probed sentence: check_inputs, which knows their lengths
            if isinstance(probes, (str, bytes)) or not hasattr(probes, "__iter__") or not probes or not all(
                    isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t) for t in probes):
                raise UsageError(f"--lookahead-probes: expected times in seconds such as 0.5,1.2, got {probes!r}")
            object.__setattr__(self, "lookahead_probes", tuple(float(t) for t in probes))
        if self.vae is not None and not Path(self.vae).expanduser().is_file():
            raise UsageError(f"--vae {self.vae}: no such file (a VAE state dict, python -m benchmark.features.train)")
        if self.device is not None:
            from blendvoca.cli import checked_device  # torch only for a GPU name

            object.__setattr__(self, "device", checked_device(self.device))
        if self.seeds is not None:
            seeds = checked_seeds(self.seeds)
            if self.seed is not None and self.seed != seeds[0]:  # seeds[0]: a spec made from one with seeds
                raise UsageError("--seeds: not allowed with --seed (the seeds are the training seeds of the run)")
            object.__setattr__(self, "seeds", seeds)
            object.__setattr__(self, "seed", seeds[0])
        elif self.seed is None:
            object.__setattr__(self, "seed", 0)

    @property
    def evaluates_lipsync_models(self) -> bool:
        """True when SyncNet weights or a sync expert were given."""
        return self.syncnet is not None or self.sync_expert is not None


@dataclass(frozen=True)
class Inputs:
    """What a run reads, checked before anything is trained.

    Attributes
    ----------
    dataset : benchmark.data dataset
        The opened build (or what ``open_dataset`` returned).
    data_root : path-like
        The build's root as asked for (the bundled default when none was).
    results_dir : Path
        An existing, writable results folder.
    subjects : tuple of str
        The subjects of the run's split.
    verified : int or None
        The number of the build's files (of every split) checked against its manifest; None
        when they were not (``verify`` off, or a dataset without a manifest).
    """

    dataset: object
    data_root: object
    results_dir: Path
    subjects: tuple
    verified: int | None = None


def default_results_dir() -> Path:
    """Where results go unless ``--results`` says otherwise: ``$BLENDVOCA_RESULTS``, else
    ``$XDG_DATA_HOME/blendvoca/results`` (``~/.local/share/blendvoca/results``), never
    inside the installed package. The committed leaderboard's folder is passed explicitly."""
    if os.environ.get("BLENDVOCA_RESULTS"):
        return Path(os.environ["BLENDVOCA_RESULTS"]).expanduser()
    base = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return Path(base).expanduser() / "blendvoca" / "results"


def default_data_root() -> Path:
    """The bundled-default BlendVOCA build, built first if it is not there yet.

    ``$BLENDVOCA_DATA`` names an existing build and wins; otherwise the build of the
    bundled synthetic corpus lives in ``<user cache>/blendvoca-default`` (see
    ``blendvoca.assets.cache_dir``) and is made with ``blendvoca.build`` when its
    ``manifest.json`` is missing (the build is resumable).
    """
    env = os.environ.get("BLENDVOCA_DATA")
    if env:
        return Path(env).expanduser()
    from blendvoca.builder.pipeline import build_dataset, default_output_dir  # the build stack, only when needed

    root = default_output_dir()
    if not manifest_path(root).is_file():
        print(f"building the bundled-default BlendVOCA into {root} (once)", file=sys.stderr)
        summary = build_dataset(root, None)
        if summary.failures:
            raise DataError(f"bundled-default build in {root} had {len(summary.failures)} failure(s), e.g. "
                               f"{summary.failures[0]}")
    return root


def check_results_dir(path) -> Path:
    """``path`` as a results folder: created if missing; UsageError if it is a file or not writable."""
    path = Path(os.fspath(path)).expanduser()
    if path.exists() and not path.is_dir():
        raise UsageError(f"--results {path}: expected a folder, got a file")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise UsageError(f"--results {path}: not writable ({exc.strerror or exc})") from None
    return path


def _open_default(root, vocaset=None):
    return open_blendvoca(root, vocaset=vocaset)


def open_data(root, *, vocaset=None, open_dataset=None):
    """The build at ``root`` opened (``open_dataset(root)``, default
    ``benchmark.data.open_blendvoca``); a folder that is not a readable build is a
    :class:`UsageError` naming ``--data``."""
    try:
        if open_dataset is not None:
            return open_dataset(root)
        return _open_default(root, vocaset=vocaset) if vocaset is not None else _open_default(root)
    except (UserError, DataError, FileNotFoundError) as exc:  # the reader's word on the folder the user named
        raise UsageError(f"--data {root}: {exc}") from None


def _check_evaluation_assets(syncnet, sync_expert) -> None:
    """UsageError unless the VAE (and the given SyncNet / expert files) are in place."""
    if find_local("said-vae") is None:
        raise UsageError("the evaluation needs the VAE feature extractor (asset 'said-vae'); "
                         "run `python -m blendvoca.assets fetch said-vae` or set BLENDVOCA_ASSETS")
    for flag, value in (("--syncnet-weights", syncnet), ("--sync-expert", sync_expert)):
        if isinstance(value, (str, os.PathLike)) and not Path(value).expanduser().exists():
            raise UsageError(f"{flag} {value}: no such file")


def with_default_sync_expert(spec: RunSpec, dataset) -> RunSpec:
    """``spec`` with the project's real-speech expert as ``sync_expert`` when none was given
    and the build is of recorded speech (:func:`benchmark.lipsync.default_expert.default_sync_expert`):
    a corpus too small to train its own expert (one Live Link take) is still scored with a
    learned expert, and the result records it as any other (its weights digest)."""
    if spec.sync_expert is not None:
        return spec
    from benchmark.lipsync.default_expert import default_sync_expert

    default = default_sync_expert(dataset)
    return spec if default is None else dataclasses.replace(spec, sync_expert=default)


def trains_nothing(method) -> str | None:
    """Why ``method`` (a class or an instance) learns nothing from a training seed, or
    None when it does: a reference method, one whose class does not override
    ``Method.train``, or one that says so (``learns = False``: it fits stored outputs,
    or holds the authors' weights)."""
    cls = method if isinstance(method, type) else type(method)
    if getattr(method, "reference", False):
        return "it is a reference method"
    if getattr(cls, "train", Method.train) is Method.train:
        return "it has no train step"
    if not getattr(method, "learns", True):
        return "its train step learns nothing from the seed"
    return None


def _check_seeded_training(spec: RunSpec, method) -> None:
    """UsageError unless every seed of ``spec.seeds`` trains ``method`` anew."""
    why = trains_nothing(method)
    if why is not None:
        raise UsageError(f"--seeds: method {spec.method!r} does not train ({why}); a run over training seeds needs "
                         "a method that trains (use --seed)")
    if spec.checkpoint is not None:
        path = Path(os.fspath(spec.checkpoint)).expanduser()
        if path.is_file():
            raise UsageError(f"--seeds: --checkpoint {path} is a weights file, which trains nothing; a run over "
                             "training seeds trains every seed (give an empty folder to save each seed's method)")
        if path.is_dir() and any(path.iterdir()):
            raise UsageError(f"--seeds: --checkpoint {path} is not empty; a run over training seeds trains every "
                             "seed and saves each into <checkpoint>/seed<k> of an empty or new folder")


#: Sentences of the split (its first ones) the latency and the look-ahead probe are measured on.
LATENCY_SENTENCES = 3


def checked_fractions(fractions, option: str = "--checkpoint-fractions") -> tuple:
    """``fractions`` as a tuple of floats when they are increasing and each in (0, 1] (1 is
    the full budget, scored anyway); a string is read as ``"0.25,0.5"``.

    Raises
    ------
    ValueError
        Naming ``option`` and the value: not numbers, empty, not increasing, or outside (0, 1].
    """
    raw = fractions
    if isinstance(fractions, str):
        fractions = [part for part in fractions.split(",") if part.strip()]
    try:
        values = tuple(float(f) for f in fractions)
    except (TypeError, ValueError):
        raise ValueError(f"{option} {raw}: expected increasing fractions of the step budget in (0, 1], "
                         "e.g. 0.25,0.5") from None
    if not values:
        raise ValueError(f"{option} {raw!r}: expected at least one fraction of the step budget in (0, 1]")
    outside = [v for v in values if not (0.0 < v <= 1.0)]
    if outside:
        raise ValueError(f"{option} {raw}: expected fractions of the step budget in (0, 1], got {outside[0]:g}")
    if any(b <= a for a, b in zip(values, values[1:])):
        raise ValueError(f"{option} {raw}: expected increasing fractions (each larger than the one before)")
    return values


def checked_probe_times(times, utterances: dict, *, option: str = "--lookahead-probes") -> tuple:
    """``times`` (seconds into each probed sentence) checked against the sentences
    ``utterances`` (``{(subject, sentence): seconds long}``).

    Raises
    ------
    UsageError
        A time that is not a finite number, or not inside every probed sentence (after its
        first frame, before its last one): the message names ``option``, the value and the
        sentence's length.
    """
    frame_s = 1.0 / FPS  # a cut needs a frame before it and one after it
    out = []
    for value in times:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
            raise UsageError(f"{option}: expected times in seconds such as 0.5,1.2, got {value!r}")
        for (subject, sentence), seconds in utterances.items():
            if not frame_s <= float(value) <= seconds - frame_s:
                raise UsageError(f"{option} {value:g}: outside the utterance {subject}/{sentence}, which is "
                                 f"{seconds:.3f} s long (expected a time in [{frame_s:.3f}, "
                                 f"{seconds - frame_s:.3f}] s)")
        out.append(float(value))
    if not out:
        raise UsageError(f"{option}: expected at least one time in seconds, got none")
    return tuple(out)


def _check_probe_times(spec: RunSpec, dataset) -> None:
    """UsageError unless every time of ``spec.lookahead_probes`` lies inside each sentence
    the look-ahead probe cuts (the split's first ``LATENCY_SENTENCES``)."""
    items = [(subject, sentence) for subject in dataset.split(spec.split) for sentence in dataset.sentences(subject)]
    lengths = {key: len(dataset.coeffs(*key)) / FPS for key in items[:LATENCY_SENTENCES]}
    checked_probe_times(spec.lookahead_probes, lengths)


def check_inputs(spec: RunSpec, *, open_dataset=None, evaluation_assets: bool = True) -> Inputs:
    """Open the build and check everything a run can check before training: the results
    folder, the split, a vertex method's source meshes, the evaluation's assets and the
    method's config.

    Parameters
    ----------
    spec : RunSpec
    open_dataset : callable, optional
        ``open_dataset(root) -> dataset`` (default ``benchmark.data.open_blendvoca``).
    evaluation_assets : bool, default True
        Check the default evaluation's assets (off when a run brings its own evaluation).

    Raises
    ------
    UsageError
        Any of them is not usable; nothing was trained or written.
    CheckFailed
        ``spec.verify`` and a file of the split differs from what the build made
        (``dataset.verify``, where the dataset has one).
    """
    data_root = spec.data_root if spec.data_root is not None else default_data_root()
    dataset = open_data(data_root, vocaset=spec.vocaset, open_dataset=open_dataset)
    results_dir = check_results_dir(default_results_dir() if spec.results_dir is None else spec.results_dir)
    splits = getattr(dataset, "splits", None)
    if splits is not None and spec.split not in splits:
        raise UsageError(f"--split: expected one of {sorted(splits)}, got {spec.split!r}")
    try:
        subjects = dataset.split(spec.split)
    except (KeyError, ValueError):  # a dataset without ``splits``: its split() refuses the name
        raise UsageError(f"--split: the dataset has no split {spec.split!r}") from None
    if not subjects:
        raise UsageError(f"--split {spec.split!r}: no subjects of that split in {data_root}")
    if spec.lookahead_probes is not None:
        _check_probe_times(spec, dataset)
    cls = get_method(spec.method)
    if (getattr(cls, "output", OUTPUT_COEFFICIENTS) == OUTPUT_VERTICES and hasattr(dataset, "corpus_root")
            and getattr(dataset, "vertex_space", "mesh") == "mesh"):  # "rig": the build's rigs give the vertices
        try:  # the vertex metrics compare with the source meshes: fail now, not after training
            dataset.corpus_root()
        except FileNotFoundError as exc:
            raise UsageError(str(exc)) from None
    if evaluation_assets:
        _check_evaluation_assets(spec.syncnet, spec.sync_expert)
    if spec.vae is not None and getattr(dataset, "names", None):
        from benchmark.features.card import check_vae_fits  # torch: loaded only for a given VAE

        try:  # another shape set's latent features measure nothing
            check_vae_fits(spec.vae, dataset.names, data=data_root)
        except (UserError, DataError) as exc:
            raise UsageError(str(exc)) from None
    try:
        method = make_method(spec.method, spec.config)
    except MethodError as exc:
        raise UsageError(f"--config: {exc}") from None
    if spec.seeds is not None:
        _check_seeded_training(spec, method)
    # last: the cheap checks above answer a mistyped flag before the files are read; every
    # split's files (the method trains on them too), then the scored split held in memory
    verified = verified_inputs(spec, dataset)
    held_ground_truth(spec, dataset)
    return Inputs(dataset=dataset, data_root=data_root, results_dir=results_dir, subjects=tuple(subjects),
                  verified=verified)

