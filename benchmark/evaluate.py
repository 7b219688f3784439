"""Evaluation protocol: every metric of a method's generated tracks on a split.

``evaluate_split(generated, dataset, split="test")`` where
``generated[(subject, sentence)]`` is an ``(S, T, 32)`` array (S samples, 60 fps,
BlendVOCA column order) returns :class:`Scores`: a dict ``{metric: entry}`` with
``entry = {"mean", "std", "ci95": [lo, hi], "n", "higher_is_better", "unit",
"label", "group"}`` (plus ``"sample_std"`` for S >= 2), built from the metric
registry (:mod:`benchmark.metrics.registry`), and ``Scores.per_sentence``, one row
per scored sentence. Intervals: :mod:`benchmark.metrics.bootstrap`. See
docs/metrics.md for the definitions and the window protocol.
"""

from __future__ import annotations

import warnings
import zlib
from collections.abc import Hashable, Mapping
from os import PathLike
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES, mean_ci, statistic_ci, statistics_ci
from benchmark.metrics.multimodality import PAIRS_PER_WINDOW
from benchmark.metrics.registry import metric_info, ordered_metrics
from benchmark.metrics.windows import GT_DROP_LAST, window_starts

__all__ = [
    "FD_RESAMPLES",
    "Scores",
    "WIND_RESAMPLES",
    "evaluate_split",
    "latent_metrics",
    "lipsync_metrics",
    "metric_entry",
    "own_vertex_metrics",
    "sentence_vertex_values",
    "vertex_metrics",
]

#: Bootstrap resamples of FD (closed form per resample: cheap).
FD_RESAMPLES = 200
#: Bootstrap resamples of WInD (one GMM fit of the generated set per resample).
WIND_RESAMPLES = 20
#: Largest number of windows a WInD resample is fitted on (a seeded subsample beyond it).
WIND_RESAMPLE_WINDOWS = 20000
#: Windows encoded per progress step.
_ENCODE_CHUNK = 4096


class Scores(dict):
    """``{metric: entry}`` in table order, with :attr:`per_sentence` rows
    (``{"subject", "sentence", metric: value, ...}`` for the per-sentence metrics)."""

    def __init__(self, metrics=(), per_sentence=None):
        super().__init__(metrics)
        self.per_sentence = list(per_sentence or [])


def metric_entry(name: str, mean, std=None, *, ci95=None, n=None, sample_std=None, **extra) -> dict:
    """A result entry for the registered metric ``name`` (label, unit, direction and group from the registry)."""
    info = metric_info(name)
    mean = float(mean)
    entry = {"mean": mean, "std": None if std is None else float(std),
             "ci95": [mean, mean] if ci95 is None else [float(ci95[0]), float(ci95[1])],
             "n": None if n is None else int(n), "higher_is_better": info.higher_is_better, "unit": info.unit,
             "label": info.label, "group": info.group}
    if sample_std is not None:
        entry["sample_std"] = float(sample_std)
    entry.update(extra)
    return entry


def _sentence_entries(values: dict, *, seed: int, resamples: int) -> tuple[dict, dict]:
    """Entries of per-sentence metrics from ``values[name][key] = (S,) per-sample values (or a scalar)``.

    Returns ``(entries, {key: {name: sentence value}})``; ``sample_std`` is the std over
    sample indices of the per-sample means over sentences (stochastic methods).
    """
    entries, rows = {}, {}
    for name, per_key in values.items():
        if not per_key:
            continue
        keys = list(per_key)
        arrays = [np.atleast_1d(np.asarray(per_key[k], dtype=np.float64)) for k in keys]
        sentence = np.array([a.mean() for a in arrays])
        for k, v in zip(keys, sentence):
            rows.setdefault(k, {})[name] = float(v)
        std = float(sentence.std(ddof=1)) if len(sentence) > 1 else None
        sample_std = None
        lengths = {len(a) for a in arrays}
        if len(lengths) == 1 and lengths.pop() >= 2:
            sample_std = float(np.stack(arrays).mean(axis=0).std(ddof=1))
        entries[name] = metric_entry(name, sentence.mean(), std, n=len(sentence), sample_std=sample_std,
                                     ci95=mean_ci(sentence, resamples=resamples, seed=seed + zlib.crc32(name.encode())))
    return entries, rows


def _resolve_extractor(extractor):
    from benchmark.features import load_published_vae

    if extractor is None or isinstance(extractor, (str, PathLike)):
        return load_published_vae(extractor)
    return extractor


def _check_generated(generated: Mapping, keys: list, channels: int) -> dict:
    if not isinstance(generated, Mapping):
        raise TypeError(f"evaluate_split: generated must map (subject, sentence) -> (S, T, {channels}), got {type(generated).__name__}")
    out = {}
    for key in keys:
        if key not in generated:
            continue
        tracks = np.asarray(generated[key], dtype=np.float64)
        if tracks.ndim == 2:
            tracks = tracks[None]
        if tracks.ndim != 3 or tracks.shape[2] != channels or tracks.shape[0] < 1:
            raise ValueError(f"evaluate_split: generated[{key!r}] must be (S, T, {channels}), got {tracks.shape}")
        if not np.all(np.isfinite(tracks)):
            raise ValueError(f"evaluate_split: generated[{key!r}] contains NaN or inf")
        out[key] = tracks
    if not out:
        raise ValueError(f"evaluate_split: no generated track matches the split's {len(keys)} (subject, sentence) keys")
    return out


def _encoded(extractor, windows, desc: str, progress: bool) -> np.ndarray:
    from benchmark.features import encode_windows

    chunks = range(0, len(windows), _ENCODE_CHUNK)
    return np.concatenate([encode_windows(extractor, windows[i:i + _ENCODE_CHUNK])
                           for i in tqdm(chunks, desc=desc, unit="chunk", disable=not progress)])


def _wind_cache_dir(wind_cache):
    if wind_cache is True:
        from blendvoca.assets import cache_dir

        return cache_dir() / "wind-gmm"
    return None if wind_cache in (None, False) else Path(wind_cache)


def _wind_with_interval(fake, real, members, k, *, repeats, seed, resamples, workers, cache, progress):
    """WInD mean and std over ``repeats`` seeded fit pairs (as :func:`benchmark.metrics.wind`)
    and its bootstrap interval over the generated sentences ``members``.

    Resample ``b`` refits the generated side on the windows of the resampled
    sentences (a seeded subsample of `WIND_RESAMPLE_WINDOWS` beyond that) and
    compares it with the ground truth's seed-``seed`` mixture. The ground-truth
    fits are the same for every method scored on a split: they are looked up in
    (and added to) ``cache`` (:func:`benchmark.metrics.cached_gmm_components_many`).
    All fits are seeded and single-threaded: the result does not depend on
    ``workers`` or on the cache.
    """
    from benchmark.metrics import cached_gmm_components_many, gmm_components_many, wind_from_gmms
    from benchmark.metrics.bootstrap import bootstrap_indices

    if repeats < 1:
        raise ValueError(f"wind: repeats must be >= 1, got {repeats}")
    n = len(members)
    rows = bootstrap_indices(n, resamples, seed + 1) if n >= 2 else np.empty((0, n), dtype=np.int64)
    # the windows of every resample first: the thinning draws stay in resample order
    thin = np.random.default_rng(np.random.SeedSequence([seed, 0x57]))
    resample_jobs = []
    for row in rows:
        picked = np.concatenate([members[i] for i in row])
        if len(picked) > WIND_RESAMPLE_WINDOWS:
            picked = thin.choice(picked, WIND_RESAMPLE_WINDOWS, replace=False)
        resample_jobs.append((fake[picked], min(k, len(picked)), seed))
    real_gmms = cached_gmm_components_many([(real, k, seed + r) for r in range(repeats)], cache, workers)
    jobs = [(fake, k, seed + r) for r in range(repeats)] + resample_jobs
    bar = (lambda it: tqdm(it, total=len(jobs), desc="WInD fits", unit="fit", disable=not progress))
    fits = gmm_components_many(jobs, workers, progress=bar)
    scores = np.array([wind_from_gmms(fits[r], real_gmms[r]) for r in range(repeats)])
    w_mean, w_std = float(scores.mean()), float(np.std(scores, ddof=1)) if repeats > 1 else 0.0
    resampled = [wind_from_gmms(gmm, real_gmms[0]) for gmm in fits[repeats:]]
    ci = statistics_ci(lambda _rows: resampled, n, w_mean, resamples=resamples, seed=seed + 1)
    return w_mean, w_std, ci


def latent_metrics(ground_truth: Mapping[Hashable, np.ndarray], generated: Mapping[Hashable, np.ndarray], extractor,
                   *, samples_for_multimodality: int = PAIRS_PER_WINDOW, wind_components: int = 5,
                   wind_repeats: int = 10, seed: int = 0, fd_resamples: int = FD_RESAMPLES,
                   wind_resamples: int = WIND_RESAMPLES, wind_workers: int = 2, wind_cache=True,
                   progress: bool = False) -> dict:
    """FD, WInD and multimodality over VAE features of 120-frame windows, with bootstrap intervals.

    Parameters
    ----------
    ground_truth : key -> (T, C); generated : key -> (S, T, C)
    extractor : feature extractor (see :func:`benchmark.features.encode_windows`)
    fd_resamples, wind_resamples : int
        Bootstrap resamples over the generated sentences (the ground-truth set is fixed).
    wind_workers : int
        Processes for the WInD mixture fits (repeats and bootstrap refits); each fit is
        seeded and single-threaded, so the scores do not depend on it.
    wind_cache : True, path or None
        Folder keeping the ground-truth mixture fits (the same for every method scored
        on a split; True: ``<user cache>/wind-gmm``, None: no cache). The scores do not
        depend on it.

    Returns
    -------
    dict of metric entries (multimodality only when some window has >= 2 samples);
    ``n`` = number of generated sentences, ``windows`` = generated windows.
    """
    from benchmark.metrics import (
        cut_windows,
        feature_statistics,
        frechet_distance,
        frechet_distance_from_stats,
        multimodality,
        paired_samples,
    )

    windows = cut_windows(ground_truth, generated)
    if len(windows.real) < 2 or len(windows.fake) < 2:
        raise ValueError(
            f"latent_metrics: need >= 2 windows on each side, got {len(windows.real)} ground-truth and "
            f"{len(windows.fake)} generated (sequences shorter than 120 frames give none)"
        )
    real = _encoded(extractor, windows.real, "encode ground-truth windows", progress)
    fake = _encoded(extractor, windows.fake, "encode generated windows", progress)
    sentence_of = {}
    owner = np.array([sentence_of.setdefault(key, len(sentence_of)) for key, _, _ in windows.fake_keys])
    n = len(sentence_of)
    members = [np.flatnonzero(owner == i) for i in range(n)]
    extra = {"windows": int(len(fake))}

    # FD: per-sentence sums make each resample's mean and covariance closed-form
    mu_r, sigma_r = feature_statistics(real)
    counts = np.array([len(m) for m in members], dtype=np.float64)
    sums = np.stack([fake[m].sum(axis=0) for m in members])
    outers = np.stack([fake[m].T @ fake[m] for m in members])

    def fd_of(rows):
        total = counts[rows].sum()
        mu = sums[rows].sum(axis=0) / total
        sigma = (outers[rows].sum(axis=0) - total * np.outer(mu, mu)) / (total - 1)
        return frechet_distance_from_stats(mu, sigma, mu_r, sigma_r)

    fd = frechet_distance(fake, real)
    bar = (lambda it: tqdm(it, desc="FD bootstrap", unit="resample", disable=not progress))
    out = {"fd": metric_entry("fd", fd, None, n=n, ci95=statistic_ci(fd_of, n, fd, resamples=fd_resamples,
                                                                       seed=seed, progress=bar), **extra)}

    k = min(wind_components, len(real), len(fake))
    w_mean, w_std, wind_ci = _wind_with_interval(fake, real, members, k, repeats=wind_repeats, seed=seed,
                                                 resamples=wind_resamples, workers=wind_workers,
                                                 cache=_wind_cache_dir(wind_cache), progress=progress)
    out["wind"] = metric_entry("wind", w_mean, w_std, n=n, ci95=wind_ci, **extra)

    groups = windows.fake_groups()
    sums_d, counts_d, all_d = np.zeros(n), np.zeros(n), []
    for i, m in enumerate(members):
        a, b = paired_samples(fake[m], [groups[j] for j in m], samples_for_multimodality)
        if len(a):
            d = np.linalg.norm(a - b, axis=1)
            sums_d[i], counts_d[i] = d.sum(), len(d)
            all_d.append(d)
    if all_d:
        dists = np.concatenate(all_d)
        value = multimodality(*paired_samples(fake, groups, samples_for_multimodality))

        def mm_of(rows):
            return sums_d[rows].sum() / max(counts_d[rows].sum(), 1.0)

        out["multimodality"] = metric_entry(
            "multimodality", value, dists.std(ddof=1) if len(dists) > 1 else None, n=n,
            ci95=statistic_ci(mm_of, n, value, resamples=BOOTSTRAP_RESAMPLES, seed=seed + 2), **extra)
    return out


def sentence_vertex_values(preds, gt_v, neutral, lip, upper) -> dict:
    """LVE, LVE², MVE, |FDD| per sample and, for S >= 2, the diversity measures of one sentence.

    Parameters
    ----------
    preds : (S, T, V, 3) ndarray
    gt_v : (T, V, 3) ndarray
    neutral : (V, 3) ndarray
    lip, upper : int ndarrays
        Lip and upper-face vertex indices.

    Returns
    -------
    dict
        ``lve``, ``lve_squared``, ``mve``, ``fdd``: (S,) arrays; ``apd``, ``upd``,
        ``lpd``, ``mpd``: floats (S >= 2 only).
    """
    from benchmark.metrics import vertex

    out = {"lve": [], "lve_squared": [], "mve": [], "fdd": []}
    gt_dynamics = {}
    for p in preds:
        out["lve"].append(vertex.lip_vertex_error(p, gt_v, lip))
        out["lve_squared"].append(vertex.lip_vertex_error(p, gt_v, lip, squared=True))
        out["mve"].append(vertex.mean_vertex_error(p, gt_v))
        # |FDD| per sequence: CodeTalker's signed mean lets too-lively and
        # too-still sequences cancel, and a ranking needs "closer to 0 is better".
        # (upper_face_dynamics_deviation, with the ground truth's term computed
        # once per length rather than once per sample.)
        t = min(len(p), len(gt_v))
        if t not in gt_dynamics:
            gt_dynamics[t] = vertex.motion_dynamics(gt_v[:t], neutral, upper)
        out["fdd"].append(abs(gt_dynamics[t] - vertex.motion_dynamics(p[:t], neutral, upper)))
    out = {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}
    if len(preds) >= 2:
        out.update(vertex.diversity_metrics(preds, upper, lip))
    return out


def _rig_deltas(rig, names) -> np.ndarray:
    rig_names = tuple(rig.names)
    if tuple(names) == rig_names:
        return np.asarray(rig.deltas, dtype=np.float64)
    missing = [n for n in names if n not in rig_names]
    if missing:
        raise ValueError(f"evaluate_split: the rig lacks the blendshapes {missing}")
    return np.asarray(rig.deltas, dtype=np.float64)[[rig_names.index(n) for n in names]]


def _rig_regions(rig, names):
    from benchmark.metrics import regions

    neutral = np.asarray(rig.neutral, dtype=np.float64)
    deltas = _rig_deltas(rig, names)
    return neutral, deltas, regions.lip_vertices(deltas, names), regions.upper_face_vertices(neutral)


def _by_metric(per_key: dict) -> dict:
    values = {}
    for key, sentence in per_key.items():
        for name, value in sentence.items():
            values.setdefault(name, {})[key] = value
    return values


#: The per-sentence function of the running `_map_sentences` (read by its forked workers).
_SENTENCE_TASK = None


def _run_sentence_task(key):
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # small matrix products: one BLAS thread is faster here
        return _SENTENCE_TASK(key)


def _map_sentences(task, keys, *, workers: int, desc: str, progress: bool) -> dict:
    """``{key: task(key)}`` over ``keys``, in ``workers`` forked processes (Linux; else here).

    ``task`` is pure numpy work (no torch: an OpenMP runtime used before a fork is
    not safe in the child), so the values do not depend on ``workers``.
    """
    import sys

    global _SENTENCE_TASK
    keys = list(keys)
    bar = (lambda it: tqdm(it, total=len(keys), desc=desc, unit="sentence", disable=not progress))
    _SENTENCE_TASK = task
    try:
        if workers <= 1 or len(keys) <= 1 or not sys.platform.startswith("linux"):
            return dict(zip(keys, bar(_run_sentence_task(k) for k in keys)))
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(min(workers, len(keys)), mp_context=multiprocessing.get_context("fork")) as pool:
            chunk = max(1, len(keys) // (8 * workers))
            return dict(zip(keys, bar(pool.map(_run_sentence_task, keys, chunksize=chunk))))
    finally:
        _SENTENCE_TASK = None


def _regions_of(rigs, names) -> dict:
    return {subject: _rig_regions(rig, names) for subject, rig in rigs.items()}


def _vertex_values(ground_truth, generated, rigs, names, progress=False, workers: int = 1) -> dict:
    from benchmark.metrics import vertex

    regions = _regions_of(rigs, names)

    def task(key):
        neutral, deltas, lip, upper = regions[key[0]]
        gt_v = vertex.rig_vertices(neutral, deltas, ground_truth[key])
        preds = np.stack([vertex.rig_vertices(neutral, deltas, t) for t in generated[key]])
        return sentence_vertex_values(preds, gt_v, neutral, lip, upper)

    return _by_metric(_map_sentences(task, generated, workers=workers, desc="vertex metrics", progress=progress))


def _own_vertex_values(generated_vertices, ground_truth_vertices, rigs, names, progress=False,
                       workers: int = 1) -> dict:
    regions = _regions_of(rigs, names)

    def task(key):
        subject, sentence = key
        neutral, _deltas, lip, upper = regions[subject]
        preds = np.asarray(generated_vertices[key], dtype=np.float64)
        gt_v = np.asarray(ground_truth_vertices(subject, sentence), dtype=np.float64)
        if preds.shape[1:] != gt_v.shape or gt_v.shape[1:] != neutral.shape:
            raise ValueError(f"own_vertex_metrics {subject}/{sentence}: expected vertices (S, {gt_v.shape[0]}, "
                             f"{neutral.shape[0]}, 3) like the source meshes {gt_v.shape} and the rig "
                             f"{neutral.shape}, got {preds.shape}")
        return sentence_vertex_values(preds, gt_v, neutral, lip, upper)

    return _by_metric(_map_sentences(task, list(generated_vertices), workers=workers, desc="vertex metrics (own)",
                                     progress=progress))


def vertex_metrics(ground_truth, generated, rigs: Mapping, names, *, seed: int = 0,
                   resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """LVE, MVE, FDD and the diversity measures through each speaker's rig.

    Parameters
    ----------
    ground_truth : (subject, sentence) -> (T, C); generated : same keys -> (S, T, C)
    rigs : subject -> rig with ``neutral``, ``deltas``, ``names``
    names : column names of the tracks

    Returns
    -------
    dict of metric entries; spread = std over sentences.
    """
    return _sentence_entries(_vertex_values(ground_truth, generated, rigs, names), seed=seed, resamples=resamples)[0]


def own_vertex_metrics(generated_vertices: Mapping, ground_truth_vertices, rigs: Mapping, names, *,
                       seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES, progress: bool = False) -> dict:
    """LVE, MVE, FDD and the diversity measures of a vertex-output method's own vertices.

    Parameters
    ----------
    generated_vertices : mapping (subject, sentence) -> (S, T, V, 3)
        The method's vertices (metres, the speaker's topology).
    ground_truth_vertices : callable (subject, sentence) -> (T, V, 3)
        The source meshes (``dataset.vertices``).
    rigs : subject -> rig
        Define the lip region (from the rig's mouth shapes) and the face regions.
    names : column names of the rig's shapes

    Returns
    -------
    dict of metric entries; spread = std over sentences.
    """
    values = _own_vertex_values(generated_vertices, ground_truth_vertices, rigs, names, progress)
    return _sentence_entries(values, seed=seed, resamples=resamples)[0]


def _lipsync_values(generated, rigs, audio, names, *, syncnet=None, sync_expert=None, max_lag=15,
                    progress=False, workers: int = 1) -> dict:
    from benchmark.lipsync import geometric_sync, mouth_activity, syncnet_sync_track
    from benchmark.metrics import vertex

    regions = _regions_of(rigs, names)

    def geometric(key):
        neutral, deltas, lip, _upper = regions[key[0]]
        samples, rate = audio[key]
        est = [geometric_sync(mouth_activity(vertex.rig_vertices(neutral, deltas, track), neutral, lip),
                              samples, rate, 60.0, max_lag) for track in generated[key]]
        return [abs(e.offset) for e in est], [e.confidence for e in est]

    geo = _map_sentences(geometric, generated, workers=workers, desc="lip sync (geometric)", progress=progress)
    values = {"av_offset_geometric": {k: v[0] for k, v in geo.items()},
              "av_confidence_geometric": {k: v[1] for k, v in geo.items()},
              "av_offset_syncnet": {}, "av_confidence_syncnet": {}, "av_offset_expert": {}, "av_confidence_expert": {}}
    # the torch models run in this process
    if syncnet is not None:
        for key in tqdm(list(generated), disable=not progress, desc="lip sync (SyncNet)", unit="sentence"):
            neutral, deltas, _lip, _upper = regions[key[0]]
            samples, rate = audio[key]
            verts = vertex.rig_vertices(neutral, deltas, generated[key][0])
            est = syncnet_sync_track(syncnet, verts, rigs[key[0]].faces, samples, rate)
            values["av_offset_syncnet"][key] = abs(est.offset)
            values["av_confidence_syncnet"][key] = est.confidence
    if sync_expert is not None:
        for key in tqdm(list(generated), disable=not progress, desc="lip sync (expert)", unit="sentence"):
            samples, rate = audio[key]
            est = [sync_expert.sync(np.asarray(track, dtype=np.float64), samples, rate) for track in generated[key]]
            values["av_offset_expert"][key] = [abs(e.offset) for e in est]
            values["av_confidence_expert"][key] = [e.confidence for e in est]
    return {k: v for k, v in values.items() if v}


def lipsync_metrics(generated, rigs: Mapping, audio: Mapping, names, *, syncnet=None, sync_expert=None,
                    max_lag: int = 15, seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES,
                    progress: bool = False) -> dict:
    """Geometric (weight-free) and, with the models, SyncNet and sync-expert AV offset/confidence.

    Offsets are averaged as absolute values (opposite errors must not cancel):
    geometric and expert in 60 fps frames over every sample, SyncNet in 25 fps
    frames over the first sample of each sentence.
    """
    values = _lipsync_values(generated, rigs, audio, names, syncnet=syncnet, sync_expert=sync_expert,
                             max_lag=max_lag, progress=progress)
    return _sentence_entries(values, seed=seed, resamples=resamples)[0]


def _load_models(syncnet, sync_expert):
    if syncnet is True or isinstance(syncnet, (str, PathLike)):
        from benchmark.lipsync import load_syncnet

        syncnet = load_syncnet(None if syncnet is True else syncnet)
    if isinstance(sync_expert, (str, PathLike)):
        from benchmark.lipsync.expert import load_expert

        sync_expert = load_expert(sync_expert)
    return syncnet, sync_expert


def evaluate_split(
    generated: Mapping,
    dataset,
    split: str = "test",
    *,
    extractor=None,
    samples_for_multimodality: int = PAIRS_PER_WINDOW,
    wind_components: int = 5,
    wind_repeats: int = 10,
    seed: int = 0,
    syncnet=None,
    sync_expert=None,
    vertex: bool = True,
    lipsync: bool = True,
    vertices: Mapping | None = None,
    resamples: int = BOOTSTRAP_RESAMPLES,
    fd_resamples: int = FD_RESAMPLES,
    wind_resamples: int = WIND_RESAMPLES,
    workers: int = 2,
    wind_cache=True,
    progress: bool = False,
) -> Scores:
    """Score generated tracks against a split's ground truth.

    Parameters
    ----------
    generated : mapping (subject, sentence) -> (S, T, 32) array_like
        S samples per sentence (S = 1 for deterministic methods), 60 fps,
        columns ``dataset.names``. Keys outside the split are ignored; split
        sentences without an entry are not scored.
    dataset : benchmark.data.BlendVOCADataset (or any object with ``split``,
        ``sentences``, ``coeffs``, ``audio``, ``rig``, ``names``; ``vertices``
        with ``vertices=``)
    split : str
    extractor : feature extractor, path to a VAE state_dict, or None for the
        published VAE (asset ``said-vae``).
    samples_for_multimodality : int
        Pairs per window for multimodality (36).
    wind_components, wind_repeats, seed : int
        WInD mixture size, number of repeated fits and first seed (also seeds the
        bootstrap).
    syncnet : SyncNet module, path to weights, True (the manifest asset
        ``syncnet-weights``), or None (skip SyncNet).
    sync_expert : object with ``sync(coeffs (T, 32), audio (N,)) -> .offset, .confidence``,
        a path for ``benchmark.lipsync.load_expert``, or None (skip).
    vertex, lipsync : bool
        Compute vertex-space and lip-sync metrics.
    vertices : mapping (subject, sentence) -> (S, T, V, 3), optional
        The own vertices of an ``output = "vertices"`` method (``generated`` then
        holds their rig fits): the vertex metrics compare them with the source
        meshes ``dataset.vertices(subject, sentence)`` instead of comparing rig
        reconstructions of the tracks.
    resamples, fd_resamples, wind_resamples : int
        Bootstrap resamples of the per-sentence metrics, FD and WInD.
    workers : int
        Processes for the WInD fits and the per-sentence vertex and geometric lip-sync
        metrics (forked, single-threaded each: the scores do not depend on it).
    wind_cache : True, path or None
        Where the ground-truth WInD fits are kept (see :func:`latent_metrics`).
    progress : bool
        tqdm bars for every stage.

    Returns
    -------
    Scores
        ``{name: {"mean", "std", "ci95", "n", "higher_is_better", "unit", "label",
        "group"[, "sample_std"]}}`` in table order with names ``fd``, ``wind``,
        ``multimodality`` (S >= 2), ``lve``, ``lve_squared``, ``mve``, ``fdd``,
        ``apd``/``upd``/``lpd``/``mpd`` (S >= 2), ``av_offset_geometric``,
        ``av_confidence_geometric``, the SyncNet and expert ones when given; and
        ``per_sentence`` rows. The latent metrics are left out (with a warning)
        when the split's ground truth has fewer than 2 windows of 120 frames.
    """
    names = tuple(dataset.names)
    keys = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    if not keys:
        raise ValueError(f"evaluate_split: split {split!r} of {dataset!r} has no sentences")
    generated = _check_generated(generated, keys, len(names))
    ground_truth = {k: dataset.coeffs(*k) for k in keys}
    n_real = sum(len(window_starts(len(v), drop_last=GT_DROP_LAST)) for v in ground_truth.values())
    results = {}
    if n_real >= 2:
        results.update(latent_metrics(ground_truth, generated, _resolve_extractor(extractor),
                                      samples_for_multimodality=samples_for_multimodality,
                                      wind_components=wind_components, wind_repeats=wind_repeats, seed=seed,
                                      fd_resamples=fd_resamples, wind_resamples=wind_resamples,
                                      wind_workers=workers, wind_cache=wind_cache, progress=progress))
    else:
        # sentences shorter than 122 frames give no 120-frame window: no latent metric
        warnings.warn(f"evaluate_split: split {split!r} has {n_real} ground-truth windows of 120 frames; "
                      "FD, WInD and multimodality are not computed", stacklevel=2)
    values = {}
    if vertex or lipsync:
        rigs = {s: dataset.rig(s) for s in {k[0] for k in generated}}
    if vertex and vertices is not None:
        values.update(_own_vertex_values(_Subset(vertices, list(generated)), dataset.vertices, rigs, names, progress,
                                         workers))
    elif vertex:
        values.update(_vertex_values(ground_truth, generated, rigs, names, progress, workers))
    if lipsync:
        syncnet, sync_expert = _load_models(syncnet, sync_expert)
        audio = {k: dataset.audio(*k) for k in generated}
        values.update(_lipsync_values(generated, rigs, audio, names, syncnet=syncnet, sync_expert=sync_expert,
                                      progress=progress, workers=workers))
    entries, rows = _sentence_entries(values, seed=seed, resamples=resamples)
    results.update(entries)
    per_sentence = [{"subject": k[0], "sentence": k[1], **rows.get(k, {})} for k in keys if k in generated]
    return Scores({name: results[name] for name in ordered_metrics(list(results))}, per_sentence)


class _Subset(Mapping):
    """The entries ``keys`` of a (lazily reading) mapping."""

    def __init__(self, mapping, keys):
        self._mapping, self._keys = mapping, keys

    def __getitem__(self, key):
        return self._mapping[key]

    def __iter__(self):
        return iter(self._keys)

    def __len__(self):
        return len(self._keys)
