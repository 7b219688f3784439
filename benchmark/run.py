"""``python -m benchmark.run``: train or load a method, generate on the test split,
score every metric and write one result JSON with its provenance.

Each step is a function so that tests (and notebooks) can call or replace it;
``main`` is a thin argparse shell over :func:`run_method`.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

from benchmark.methods import (
    AUDIO_RATE,
    Budget,
    MethodError,
    OUTPUT_COEFFICIENTS,
    OUTPUT_KINDS,
    OUTPUT_VERTICES,
    MethodOutputError,
    UnknownMethodError,
    Utterance,
    get_method,
    validated_tracks,
    validated_vertices,
)
from benchmark.methods.base import CONFIG_FILE, progress_bars
from benchmark.methods.contract import COEFFICIENT_NAMES
from benchmark.results import build_result, current_provenance, result_filename, write_result
from benchmark.runs import TrackWriter, tracks_folder_name

__all__ = [
    "DEFAULT_RESULTS_DIR",
    "MethodTimeout",
    "UsageError",
    "check_results_dir",
    "default_data_root",
    "default_results_dir",
    "generated_tracks",
    "main",
    "make_method",
    "parse_budget",
    "parse_config",
    "prepared_method",
    "run_method",
    "sentence_seed",
]

def default_results_dir() -> Path:
    """Where results go unless ``--results`` says otherwise: ``$BLENDVOCA_RESULTS``, else
    ``$XDG_DATA_HOME/blendvoca/results`` (``~/.local/share/blendvoca/results``), never
    inside the installed package. The committed leaderboard's folder is passed explicitly."""
    if os.environ.get("BLENDVOCA_RESULTS"):
        return Path(os.environ["BLENDVOCA_RESULTS"]).expanduser()
    base = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return Path(base).expanduser() / "blendvoca" / "results"


#: Kept for callers of the old constant: the user results folder at import time.
DEFAULT_RESULTS_DIR = default_results_dir()
#: Extra seconds over ``Budget.max_seconds`` before the runner stops a training run.
TRAIN_GRACE_S = 60.0


class UsageError(ValueError):
    """A user mistake on the command line (exit status 2, one ``error:`` line)."""


def parse_budget(text: str | None = None, *, max_steps: int | None = None,
                 max_seconds: float | None = None) -> Budget:
    """A :class:`Budget` from ``--budget`` text and/or explicit limits.

    Accepted text: ``"500"`` or ``"500steps"`` (steps), ``"90s"``, ``"5m"``,
    ``"1h"`` (time), or comma-separated ``"steps=500,seconds=300"``.
    """
    steps, seconds = max_steps, max_seconds
    if text:
        for part in str(text).replace(" ", "").split(","):
            m = re.fullmatch(r"(?:steps=)?(\d+)(?:steps?)?", part)
            if m:
                steps = int(m.group(1))
                continue
            m = re.fullmatch(r"(?:seconds=)?(\d+(?:\.\d*)?)(s|sec|m|min|h)?", part)
            if m and (m.group(2) or part.startswith("seconds=")):
                factor = {"s": 1, "sec": 1, None: 1, "m": 60, "min": 60, "h": 3600}[m.group(2)]
                seconds = float(m.group(1)) * factor
                continue
            raise ValueError(
                f"--budget: expected e.g. '500' (steps), '300s', '5m' or 'steps=500,seconds=300', got {part!r}"
            )
    return Budget(max_steps=steps, max_seconds=seconds)


def parse_config(pairs=(), *, preset: str | None = None) -> dict:
    """Method config from ``KEY=VALUE`` strings (values parsed as JSON when they can be).

    ``preset`` (``--preset``) is passed through as ``config["preset"]``.
    """
    config = {}
    for pair in pairs or ():
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise ValueError(f"--config: expected KEY=VALUE, got {pair!r}")
        try:
            config[key] = json.loads(value)
        except json.JSONDecodeError:
            config[key] = value
    if preset is not None:
        config["preset"] = preset
    return config


def make_method(name: str, config: dict | None = None):
    """Instantiate the registered method ``name`` with ``config``.

    Raises
    ------
    MethodError
        The constructor raised (e.g. an unknown config key).
    """
    cls = get_method(name)
    try:
        return cls(**(config or {}))
    except Exception as exc:
        raise MethodError(f"method {name!r}: construction with config {config!r} failed: "
                          f"{type(exc).__name__}: {exc}") from exc


def prepared_method(name: str, config: dict, dataset, *, seed: int, budget: Budget, checkpoint=None):
    """The method ready to generate: loaded from ``checkpoint`` when it holds one,
    otherwise built and trained (and saved to ``checkpoint`` when given).

    Returns
    -------
    method : Method
    timings : dict
        ``{"train_s": ..., "load_s": ...}`` (one of them None).
    """
    cls = get_method(name)
    timings = {"train_s": None, "load_s": None}
    if checkpoint is not None and Path(checkpoint).is_file():
        # a released weights file (e.g. FaceFormer's vocaset.pth): methods that read one
        # provide ``from_official_checkpoint(path, **config)``; ``train`` then only reads
        # what the method needs from the dataset (templates) and trains nothing
        loader = getattr(cls, "from_official_checkpoint", None)
        if loader is None:
            raise MethodError(f"method {name!r}: --checkpoint {checkpoint} is a file, but this method loads only "
                              f"directories written by its save()")
        start = time.perf_counter()
        try:
            method = loader(str(checkpoint), **config)
            method.train(dataset, seed=seed, budget=budget)
        except Exception as exc:
            raise MethodError(f"method {name!r}: loading {checkpoint} failed: {type(exc).__name__}: {exc}") from exc
        timings["load_s"] = time.perf_counter() - start
        return method, timings
    if checkpoint is not None and Path(checkpoint).is_dir() and any(Path(checkpoint).iterdir()):
        saved = Path(checkpoint) / CONFIG_FILE
        if saved.is_file():
            saved_name = json.loads(saved.read_text()).get("name")
            if saved_name not in (None, name, getattr(cls, "name", None)):
                raise MethodError(f"method {name!r}: checkpoint {checkpoint} holds method {saved_name!r}, not {name!r}")
        start = time.perf_counter()
        try:
            method = cls.load(checkpoint)
        except Exception as exc:
            raise MethodError(f"method {name!r}: load from {checkpoint} failed: {type(exc).__name__}: {exc}") from exc
        method = _with_config(method, config, name, checkpoint)
        timings["load_s"] = time.perf_counter() - start
        return method, timings
    method = make_method(name, config)
    start = time.perf_counter()
    limit = None if budget.max_seconds is None else budget.max_seconds * 1.1 + TRAIN_GRACE_S
    try:
        with _TimeLimit(limit, f"method {name!r}: train (budget {budget.max_seconds:g} s + grace)"
                        if limit else ""):
            method.train(dataset, seed=seed, budget=budget)
    except MethodTimeout:
        raise
    except Exception as exc:
        raise MethodError(f"method {name!r}: train failed: {type(exc).__name__}: {exc}") from exc
    timings["train_s"] = time.perf_counter() - start
    if checkpoint is not None:
        try:
            method.save(checkpoint)
        except Exception as exc:
            raise MethodError(f"method {name!r}: save to {checkpoint} failed: {type(exc).__name__}: {exc}") from exc
    return method, timings


def _with_config(method, config: dict, name: str, checkpoint):
    """A loaded method with the ``--config`` entries that differ from its saved config applied:
    sampling options (``method.sampling_options``) are set, anything else is an error
    (the checkpoint was trained with another value; retrain instead)."""
    saved = method.config()
    missing = object()
    changed = {k: v for k, v in config.items() if saved.get(k, missing) != v}
    fixed = sorted(k for k in changed if k not in method.sampling_options)
    if fixed:
        given = ", ".join(f"{k}={changed[k]!r}" for k in fixed)
        trained = ", ".join(f"{k}={saved[k]!r}" if k in saved else f"{k} unset" for k in fixed)
        options = list(method.sampling_options) or "none"
        raise MethodError(f"method {name!r}: --config {given} differs from the checkpoint {checkpoint} (trained with "
                          f"{trained}); only sampling options can change after training (here: {options})")
    if not changed:
        return method
    try:
        return method.with_sampling_options(**changed)
    except Exception as exc:
        raise MethodError(f"method {name!r}: sampling options {changed} on {checkpoint} failed: "
                          f"{type(exc).__name__}: {exc}") from exc


def sentence_seed(seed: int, index: int) -> int:
    """Seed for the ``index``-th sentence of a run seeded with ``seed`` (independent streams)."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0] & 0x7FFFFFFF)


class _TimeLimit:
    """Raise :class:`MethodTimeout` in the main thread once ``seconds`` have passed (SIGALRM; a no-op
    where signals are unavailable, i.e. off the main thread or on Windows)."""

    def __init__(self, seconds: float | None, what: str):
        self.seconds, self.what = seconds, what
        self._armed = False

    def _fire(self, signum, frame):
        raise MethodTimeout(f"{self.what}: exceeded the limit of {self.seconds:g} s")

    def __enter__(self):
        import signal
        import threading

        if (self.seconds is not None and self.seconds > 0 and hasattr(signal, "setitimer")
                and threading.current_thread() is threading.main_thread()):
            self._previous = signal.signal(signal.SIGALRM, self._fire)
            signal.setitimer(signal.ITIMER_REAL, float(self.seconds))
            self._armed = True
        return self

    def __exit__(self, *exc):
        if self._armed:
            import signal

            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self._previous)
        return False


class MethodTimeout(MethodError):
    """A method's ``generate`` or ``train`` ran past the limit the runner enforces."""


def generated_tracks(method, dataset, *, split: str = "test", samples: int = 1, seed: int = 0,
                     clip: bool = False, name: str | None = None, progress: bool = True, store=None,
                     vertices_out=None, time_limit: float | None = None, sentence_batch: int = 1):
    """Ask ``method`` for every sentence of ``split`` and check each answer.

    Parameters
    ----------
    method : Method
    dataset : benchmark.data dataset
    split : str
    samples : int
        Samples per sentence for stochastic methods; deterministic methods are
        asked for one.
    seed : int
    clip : bool
        Clip values outside [0, 1] instead of refusing them.
    store : benchmark.runs.TrackWriter, optional
        Receives every scored track (and a vertex method's own vertices).
    vertices_out : dict, optional
        Filled with a vertex method's own ``(S, T, V, 3)`` vertices per key (memory
        permitting; the runner reads them back from ``store`` instead).
    time_limit : float, optional
        Seconds one ``generate`` call may take (stopped with :class:`MethodTimeout`);
        a call for ``n`` sentences may take ``n`` times that.
    sentence_batch : int, default 1
        Sentences per call: above 1, the sentences, in order of length, go to
        ``method.generate_many`` in groups of this size (each with the seed it has
        alone, :func:`sentence_seed` of its position in the split).

    Returns
    -------
    generated : dict
        ``{(subject, sentence): (S, T, 32) float64 ndarray}`` in the split's order,
        ``T`` = ground-truth frames; for ``output = "vertices"`` methods the tracks
        fitted to their vertices with the speaker's rig (:mod:`benchmark.vertex_fit`).
    n_clipped : int

    Raises
    ------
    MethodError
        ``generate`` raised or ran past ``time_limit`` (message names method, subject and sentence).
    MethodOutputError
        The output broke the contract (shape, frames, NaN, range).
    """
    name = name or getattr(method, "name", type(method).__name__)
    kind = getattr(method, "output", OUTPUT_COEFFICIENTS)
    if kind not in OUTPUT_KINDS:
        raise MethodOutputError(f"method {name!r}: output must be one of {OUTPUT_KINDS}, got {kind!r}")
    if isinstance(sentence_batch, bool) or int(sentence_batch) != sentence_batch or int(sentence_batch) < 1:
        raise ValueError(f"sentence_batch: expected an integer >= 1, got {sentence_batch!r}")
    num_samples = int(samples) if getattr(method, "stochastic", False) else 1
    names = tuple(getattr(dataset, "names", ()) or ())
    num_coeffs = len(names) if names else 32
    items = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    if not items:
        raise ValueError(f"dataset split {split!r} has no sentences")
    frames = [int(np.asarray(dataset.coeffs(subject, sentence)).shape[0]) for subject, sentence in items]
    if sentence_batch > 1:
        by_length = sorted(range(len(items)), key=lambda i: (frames[i], i))
        groups = [by_length[i:i + int(sentence_batch)] for i in range(0, len(items), int(sentence_batch))]
    else:
        groups = [[i] for i in range(len(items))]
    try:
        from tqdm import tqdm
        bar = tqdm(total=len(items), desc=f"{name}: generate", unit="sentence", disable=not progress, file=sys.stderr)
    except ImportError:
        bar = None

    def utterance_of(index):
        subject, sentence = items[index]
        audio, rate = dataset.audio(subject, sentence)
        if rate != AUDIO_RATE:
            raise ValueError(f"dataset audio for {subject}/{sentence}: expected {AUDIO_RATE} Hz, got {rate}")
        return Utterance(subject=subject, sentence=sentence, split=split, audio=audio, num_frames=frames[index])

    def where_of(group):
        return f"method {name!r}, " + "; ".join(f"subject {items[i][0]!r}, sentence {items[i][1]!r}" for i in group)

    generated, n_clipped = {}, 0
    for group in groups:
        utterances = [utterance_of(index) for index in group]
        seeds = [sentence_seed(seed, index) for index in group]
        where = where_of(group)
        limit = None if time_limit is None else time_limit * len(group)
        try:
            with _TimeLimit(limit, f"{where}: generate"), progress_bars(progress):
                many = getattr(method, "generate_many", None) if sentence_batch > 1 else None
                if many is None:  # one sentence per call, or a method without generate_many
                    outputs = [method.generate(u, samples=num_samples, seed=s) for u, s in zip(utterances, seeds)]
                else:
                    outputs = list(many(utterances, samples=num_samples, seeds=seeds))
        except MethodTimeout:
            raise
        except Exception as exc:
            raise MethodError(f"{where}: generate failed: {type(exc).__name__}: {exc}") from exc
        if len(outputs) != len(group):
            raise MethodOutputError(f"{where}: generate_many returned {len(outputs)} outputs for {len(group)} utterances")
        for index, output in zip(group, outputs):
            subject, sentence = items[index]
            num_frames = frames[index]
            if kind == OUTPUT_VERTICES:
                rig = dataset.rig(subject)
                verts = validated_vertices(output, method=name, subject=subject, sentence=sentence,
                                           num_frames=num_frames, samples=num_samples,
                                           num_vertices=int(np.asarray(rig.neutral).shape[0]))
                from benchmark.vertex_fit import fitted_sample_tracks

                tracks = fitted_sample_tracks(verts, rig, names or rig.names)
                if store is not None:
                    store.write_vertices(subject, sentence, verts, rig.neutral)
                if vertices_out is not None:
                    vertices_out[(subject, sentence)] = verts
            else:
                tracks, clipped = validated_tracks(output, method=name, subject=subject, sentence=sentence,
                                                   num_frames=num_frames, samples=num_samples, num_coeffs=num_coeffs,
                                                   clip=clip)
                n_clipped += clipped
            if store is not None:
                store.write_tracks(subject, sentence, tracks)
            generated[(subject, sentence)] = tracks
        if bar is not None:
            bar.update(len(group))
    if bar is not None:
        bar.close()
    return {key: generated[key] for key in items}, n_clipped


def default_data_root(*, progress: bool = True) -> Path:
    """The bundled-default BlendVOCA build, built first if it is not there yet.

    ``$BLENDVOCA_DATA`` names an existing build and wins; otherwise the build of the
    bundled synthetic corpus lives in ``<user cache>/blendvoca-default`` (see
    ``blendvoca.assets.cache_dir``) and is made with ``blendvoca.build`` when its
    ``manifest.json`` is missing (the build is resumable).
    """
    env = os.environ.get("BLENDVOCA_DATA")
    if env:
        return Path(env).expanduser()
    from blendvoca.build.pipeline import build_dataset, default_output_dir

    root = default_output_dir()
    if not (root / "manifest.json").is_file():

        print(f"building the bundled-default BlendVOCA into {root} (once)", file=sys.stderr)
        summary = build_dataset(root, None, progress=progress)
        if summary.failures:
            raise RuntimeError(f"bundled-default build in {root} had {len(summary.failures)} failure(s), e.g. "
                               f"{summary.failures[0]}")
    return root


def _evaluate_default(generated, dataset, split="test", **kw):
    from benchmark.evaluate import evaluate_split

    return evaluate_split(generated, dataset, split=split, **kw)


def _open_default(root, vocaset=None):
    from benchmark.data import open_blendvoca

    return open_blendvoca(root, vocaset=vocaset)


def _check_evaluation_assets(syncnet, sync_expert) -> None:
    """UsageError unless the VAE (and the given SyncNet / expert files) are in place."""
    from blendvoca.assets import find_local

    if find_local("said-vae") is None:
        raise UsageError("the evaluation needs the VAE feature extractor (asset 'said-vae'); "
                         "run `python -m blendvoca.assets fetch said-vae` or set BLENDVOCA_ASSETS")
    for flag, value in (("--syncnet-weights", syncnet), ("--sync-expert", sync_expert)):
        if isinstance(value, (str, os.PathLike)) and not Path(value).expanduser().exists():
            raise UsageError(f"{flag} {value}: no such file")


def check_results_dir(path) -> Path:
    """``path`` as a results folder: created if missing; UsageError if it is a file or not writable."""
    import tempfile

    path = Path(path).expanduser()
    if path.exists() and not path.is_dir():
        raise UsageError(f"--results {path}: expected a folder, got a file")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise UsageError(f"--results {path}: not writable ({exc.strerror or exc})") from None
    return path


def run_method(
    method_name: str,
    data_root=None,
    *,
    samples: int = 10,
    seed: int = 0,
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
    seed : int
        Training and sampling seed.
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
    generate_time_limit : float, optional
        Seconds one ``generate`` call may take before the run stops with an error.
    vocaset : path-like, optional
        The source VOCASET corpus (for ``dataset.vertices``) when the build's
        recorded one is elsewhere.
    syncnet, sync_expert : path-like or model, optional
        SyncNet weights and a learned sync expert for the lip-sync metrics (loaded
        lazily by ``benchmark.evaluate``).
    sentence_batch : int, default 1
        Sentences per generation call (:func:`generated_tracks`); recorded in the
        protocol when above 1, since batched samples may differ from one-by-one
        ones by float rounding.

    Notes
    -----
    Step budgets make runs deterministic: the same seed gives the same metric
    values. A time budget depends on the machine; the result records
    ``protocol.deterministic = false`` for it.

    Returns
    -------
    Path
        The result file. Nothing is written when any step fails.
    """
    total_start = time.perf_counter()
    budget = budget or Budget()
    config = dict(config or {})
    if isinstance(samples, bool) or int(samples) != samples or int(samples) < 1:
        raise UsageError(f"--samples: expected an integer >= 1, got {samples!r}")
    if generate_time_limit is not None and not generate_time_limit > 0:
        raise UsageError(f"--generate-time-limit: expected seconds > 0, got {generate_time_limit!r}")
    if isinstance(sentence_batch, bool) or int(sentence_batch) != sentence_batch or int(sentence_batch) < 1:
        raise UsageError(f"--sentence-batch: expected an integer >= 1, got {sentence_batch!r}")
    provenance = current_provenance()  # the code as it is when the run starts
    custom_evaluate = evaluate is not None
    if evaluate is None:
        def evaluate(generated, dataset, split="test", **kw):
            if syncnet is not None or sync_expert is not None:
                kw.update(syncnet=syncnet, sync_expert=sync_expert)
            return _evaluate_default(generated, dataset, split=split, progress=progress, **kw)
    if open_dataset is None:
        def open_dataset(root):
            return _open_default(root, vocaset=vocaset) if vocaset is not None else _open_default(root)
    if data_root is None:
        data_root = default_data_root(progress=progress)
    try:
        dataset = open_dataset(data_root)
    except (ValueError, FileNotFoundError) as exc:
        raise UsageError(f"--data {data_root}: {exc}") from None
    results_dir = check_results_dir(default_results_dir() if results_dir is None else results_dir)
    splits = getattr(dataset, "splits", None)
    if splits is not None and split not in splits:
        raise UsageError(f"--split: expected one of {sorted(splits)}, got {split!r}")
    try:
        subjects = dataset.split(split)
    except (KeyError, ValueError):
        raise UsageError(f"--split: the dataset has no split {split!r}") from None
    if not subjects:
        raise UsageError(f"--split {split!r}: no subjects of that split in {data_root}")
    cls = get_method(method_name)
    if getattr(cls, "output", OUTPUT_COEFFICIENTS) == OUTPUT_VERTICES and hasattr(dataset, "corpus_root"):
        try:  # the vertex metrics compare with the source meshes: fail now, not after training
            dataset.corpus_root()
        except FileNotFoundError as exc:
            raise UsageError(str(exc)) from None
    if not custom_evaluate:
        _check_evaluation_assets(syncnet, sync_expert)
    try:
        make_method(method_name, config)
    except MethodError as exc:
        raise UsageError(f"--config: {exc}") from None

    with progress_bars(progress):
        method, timings = prepared_method(method_name, config, dataset, seed=seed, budget=budget,
                                          checkpoint=checkpoint)
    stochastic = bool(getattr(method, "stochastic", False))
    kind = getattr(method, "output", OUTPUT_COEFFICIENTS)
    label = getattr(method, "label", None) or method_name
    filename = result_filename({"method": {"name": method_name, "label": label},
                                "dataset": {"manifest_hash": str(dataset.manifest_hash)},
                                "protocol": {"samples": int(samples) if stochastic else 1, "seed": int(seed)}})
    names = tuple(getattr(dataset, "names", ()) or COEFFICIENT_NAMES)
    store = TrackWriter(Path(results_dir) / tracks_folder_name(filename), names)
    try:
        start = time.perf_counter()
        generated, n_clipped = generated_tracks(method, dataset, split=split, samples=samples, seed=seed, clip=clip,
                                                name=method_name, progress=progress, store=store,
                                                time_limit=generate_time_limit, sentence_batch=int(sentence_batch))
        timings["generate_s"] = time.perf_counter() - start
        start = time.perf_counter()
        if kind == OUTPUT_VERTICES:
            metrics = evaluate(generated, dataset, split=split, vertices=store.stored_vertices())
        else:
            metrics = evaluate(generated, dataset, split=split)
        timings["evaluate_s"] = time.perf_counter() - start
    except BaseException:
        store.discard()
        raise
    timings["total_s"] = time.perf_counter() - total_start

    try:
        method_config = method.config()
        json.dumps(method_config)
    except Exception as exc:
        store.discard()
        raise MethodError(f"method {method_name!r}: config() must return a JSON-serialisable dict ({exc})") from exc
    cls = type(method)
    from blendvoca.build.hashing import content_digest

    result = build_result(
        method={
            "name": method_name,
            "label": label,
            "class": f"{cls.__module__}:{cls.__qualname__}",
            "stochastic": stochastic,
            "reference": bool(getattr(method, "reference", False)),
            "output": kind,
            "config": method_config,
        },
        dataset={
            "manifest_hash": str(dataset.manifest_hash),
            "path": str(Path(data_root).resolve()) if isinstance(data_root, (str, os.PathLike)) else str(data_root),
            "split": split,
            "num_subjects": len({s for s, _ in generated}),
            "num_sentences": len(generated),
        },
        protocol={
            "samples": int(samples) if stochastic else 1,
            "seed": int(seed),
            "budget": budget.to_dict(),
            "clip": bool(clip),
            "n_clipped": int(n_clipped),
            "checkpoint": None if checkpoint is None else str(checkpoint),
            **({"checkpoint_sha256": content_digest(checkpoint)} if checkpoint is not None and Path(checkpoint).exists() else {}),
            "deterministic": budget.max_seconds is None,
            "generate_time_limit": generate_time_limit,
            **({"sentence_batch": int(sentence_batch)} if sentence_batch > 1 else {}),
            **({"lipsync_models": lipsync_models_provenance(syncnet, sync_expert)}
               if syncnet is not None or sync_expert is not None else {}),
        },
        metrics=dict(metrics),
        timings=timings,
        tracks=tracks_folder_name(filename),
        per_sentence=_per_sentence_rows(metrics, generated),
        provenance=provenance,
    )
    store.commit()
    return write_result(result, results_dir, filename)


def lipsync_models_provenance(syncnet=None, sync_expert=None) -> dict:
    """What a result records of the lip-sync models it was scored with: the files and,
    for the learned expert, the data it was trained on."""
    from blendvoca.build.hashing import content_digest

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
        out["sync_expert"] = {**model_file(sync_expert), "trained_on": dict(getattr(expert, "trained_on", {}) or {})}
    return out


def _per_sentence_rows(metrics, generated) -> list:
    """One row per scored sentence: the evaluation's rows (``Scores.per_sentence``) or, for an
    evaluation that gives none, the sentence's subject and name."""
    rows = {(r["subject"], r["sentence"]): r for r in getattr(metrics, "per_sentence", None) or []}
    return [dict(rows.get(key, {"subject": key[0], "sentence": key[1]})) for key in generated]


class _Parser(argparse.ArgumentParser):
    """argparse with the project's CLI convention: a user mistake is one ``error:`` line, exit 2."""

    def error(self, message):
        print(f"error: {message}", file=sys.stderr)
        raise SystemExit(2)


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="python -m benchmark.run", description=__doc__.split("\n\n")[0])
    p.add_argument("--method", required=False, help="registered or installed method name")
    p.add_argument("--data", default=None, help="BlendVOCA build (default: the bundled-default build)")
    p.add_argument("--vocaset", default=None, metavar="DIR",
                   help="source VOCASET corpus for dataset.vertices (default: the one the build recorded)")
    p.add_argument("--samples", type=int, default=10, help="samples per sentence for stochastic methods")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--budget", default=None,
                   help="training budget: '500' steps (deterministic), '300s' (recorded as non-deterministic), "
                        "'steps=500,seconds=300'")
    p.add_argument("--max-steps", type=int, default=None)
    p.add_argument("--max-seconds", type=float, default=None)
    p.add_argument("--results", default=None,
                   help="result folder (default: $BLENDVOCA_RESULTS or ~/.local/share/blendvoca/results)")
    p.add_argument("--preset", default=None, help="passed to the method config as preset=...")
    p.add_argument("--config", action="append", default=[], metavar="KEY=VALUE",
                   help="method config entry (repeatable; VALUE parsed as JSON when possible)")
    p.add_argument("--split", default="test")
    p.add_argument("--checkpoint", default=None, help="load the trained method from here, or train and save here; "
                        "a file: the authors' released weights (faceformer, codetalker, said)")
    p.add_argument("--clip", action="store_true", help="clip out-of-range coefficients instead of failing")
    p.add_argument("--generate-time-limit", type=float, default=None, metavar="SECONDS",
                   help="stop the run when one generate call takes longer")
    p.add_argument("--sentence-batch", type=int, default=1, metavar="N",
                   help="sentences per generation call, batched by methods that can (SAiD); recorded in the result")
    p.add_argument("--syncnet-weights", default=None, metavar="PATH",
                   help="SyncNet weights: adds the SyncNet AV offset/confidence (renders every sentence)")
    p.add_argument("--sync-expert", default=None, metavar="PATH",
                   help="learned sync expert (benchmark.lipsync.load_expert): adds av_offset/confidence_expert")
    p.add_argument("--list", action="store_true", help="list the available methods and exit")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.list:
        from benchmark.methods import available_methods

        print("\n".join(available_methods()))
        return 0
    if not args.method:
        parser.error("--method is required (or --list)")
    for flag, value in (("--data", args.data), ("--vocaset", args.vocaset)):
        if value is not None and not Path(value).expanduser().is_dir():
            parser.error(f"{flag} {value}: no such folder")
    try:
        budget = parse_budget(args.budget, max_steps=args.max_steps, max_seconds=args.max_seconds)
        config = parse_config(args.config, preset=args.preset)
        path = run_method(args.method, args.data, samples=args.samples, seed=args.seed, budget=budget,
                          results_dir=args.results, config=config, split=args.split, checkpoint=args.checkpoint,
                          clip=args.clip, progress=not args.quiet, generate_time_limit=args.generate_time_limit,
                          vocaset=args.vocaset, syncnet=args.syncnet_weights, sync_expert=args.sync_expert,
                          sentence_batch=args.sentence_batch)
    except (UnknownMethodError, UsageError) as exc:  # unknown method: the message lists close matches
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (TypeError, ValueError) as exc:
        if isinstance(exc, MethodOutputError):
            print(f"error: the method misbehaved, no result written: {exc}", file=sys.stderr)
            return 3
        print(f"error: {exc}", file=sys.stderr)  # --budget / --config / data problems
        return 2
    except MethodError as exc:
        print(f"error: the method misbehaved, no result written: {exc}", file=sys.stderr)
        return 3
    if not args.quiet:
        result = json.loads(Path(path).read_text())
        for metric, fields in result["metrics"].items():
            arrow = {True: "↑", False: "↓"}.get(fields["higher_is_better"], " ")
            ci = fields.get("ci95")
            ci = "" if not ci else f" [{ci[0]:.4g}, {ci[1]:.4g}]"
            print(f"  {metric:<28} {arrow} {fields['mean']:.4g}{ci} {fields['unit']}".rstrip(), file=sys.stderr)
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
