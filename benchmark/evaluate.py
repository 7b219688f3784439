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
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES, bootstrap_indices, interval, mean_replicates
from benchmark.metrics.energy import energy_scores, vertex_energy_score
from benchmark.metrics.multimodality import PAIRS_PER_WINDOW
from benchmark.metrics.registry import ESTIMATORS, METRICS, metric_info, ordered_metrics
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
#: Every lip-sync metric name.
_LIPSYNC_NAMES = tuple(f"av_{kind}_{est}" for est in ESTIMATORS
                       for kind in ("offset", "confidence", "offset_signed", "lag_bias"))
#: Windows encoded per progress step.
_ENCODE_CHUNK = 4096


class Scores(dict):
    """``{metric: entry}`` in table order, with :attr:`per_sentence` rows
    (``{"subject", "sentence", metric: value, ...}`` for the per-sentence metrics),
    :attr:`replicates` (``{metric: (B,) bootstrap replicates}``, from which the
    intervals are read and runs of several seeds are combined) and :attr:`protocol`
    (facts of the split a result records beside its metrics: ``fd_floor_probe``)."""

    def __init__(self, metrics=(), per_sentence=None, replicates=None, protocol=None):
        super().__init__(metrics)
        self.per_sentence = list(per_sentence or [])
        self.replicates = dict(replicates or {})
        self.protocol = dict(protocol or {})


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


def _replicates_and_interval(point: float, replicates) -> tuple[np.ndarray, list]:
    replicates = np.asarray(replicates, dtype=np.float64)
    return replicates, (interval(replicates, point) if replicates.size else [point, point])


def _sentence_entries(values: dict, *, seed: int, resamples: int) -> tuple[dict, dict, dict]:
    """Entries of per-sentence metrics from ``values[name][key] = (S,) per-sample values (or a scalar)``.

    Returns ``(entries, {key: {name: sentence value}}, {name: bootstrap replicates})``;
    ``sample_std`` is the std over sample indices of the per-sample means over
    sentences (stochastic methods). The replicates are the means of the resampled
    sentences whose percentiles are the interval (:func:`benchmark.metrics.bootstrap.mean_ci`'s).
    """
    entries, rows, replicates = {}, {}, {}
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
        point = float(sentence.mean())
        reps = (mean_replicates(sentence, resamples=resamples, seed=seed + zlib.crc32(name.encode()))
                if len(sentence) >= 2 else np.empty(0))
        replicates[name], ci = _replicates_and_interval(point, reps)
        entries[name] = metric_entry(name, point, std, n=len(sentence), sample_std=sample_std, ci95=ci)
    return entries, rows, replicates


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


def _wind_with_replicates(fake, real, members, k, *, repeats, seed, resamples, workers, cache, progress):
    """WInD mean and std over ``repeats`` seeded fit pairs (as :func:`benchmark.metrics.wind`)
    and its bootstrap replicates over the generated sentences ``members`` (none for one sentence).

    Resample ``b`` refits the generated side on the windows of the resampled
    sentences (a seeded subsample of `WIND_RESAMPLE_WINDOWS` beyond that) and
    compares it with the ground truth's seed-``seed`` mixture. The refit starts EM
    from the generated side's seed-``seed`` mixture (a warm start, see
    docs/metrics.md "WInD cost"): a resample holds the same kind of windows, so EM
    converges in a few iterations instead of from a k-means start. The ground-truth
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
    jobs = [(fake, k, seed + r) for r in range(repeats)]
    bar = (lambda it: tqdm(it, total=len(jobs) + len(resample_jobs), desc="WInD fits", unit="fit",
                           disable=not progress))
    fits = gmm_components_many(jobs, workers, progress=bar)
    # warm starts from the seed-`seed` mixture (a resample with fewer windows than
    # components keeps its own k-means start)
    resample_jobs = [job + (fits[0],) if job[1] == k else job for job in resample_jobs]
    refits = gmm_components_many(resample_jobs, workers, progress=bar)
    scores = np.array([wind_from_gmms(fits[r], real_gmms[r]) for r in range(repeats)])
    w_mean, w_std = float(scores.mean()), float(np.std(scores, ddof=1)) if repeats > 1 else 0.0
    resampled = np.array([wind_from_gmms(gmm, real_gmms[0]) for gmm in refits])
    return w_mean, w_std, resampled


def latent_metrics(ground_truth: Mapping[Hashable, np.ndarray], generated: Mapping[Hashable, np.ndarray], extractor,
                   *, samples_for_multimodality: int = PAIRS_PER_WINDOW, wind_components: int = 5,
                   wind_repeats: int = 10, seed: int = 0, fd_resamples: int = FD_RESAMPLES,
                   wind_resamples: int = WIND_RESAMPLES, wind_workers: int = 2, wind_cache=True,
                   progress: bool = False, wind: bool = True, resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """FD, WInD, multimodality and the latent energy score over VAE features of 120-frame
    windows, with bootstrap intervals.

    Parameters
    ----------
    ground_truth : key -> (T, C); generated : key -> (S, T, C)
    extractor : feature extractor (see :func:`benchmark.features.encode_windows`)
    fd_resamples, wind_resamples, resamples : int
        Bootstrap resamples over the generated sentences (the ground-truth set is fixed)
        of FD, WInD and the per-sentence latent energy score.
    wind_workers : int
        Processes for the WInD mixture fits (repeats and bootstrap refits); each fit is
        seeded and single-threaded, so the scores do not depend on it.
    wind_cache : True, path or None
        Folder keeping the ground-truth mixture fits (the same for every method scored
        on a split; True: ``<user cache>/wind-gmm``, None: no cache). The scores do not
        depend on it.
    wind : bool
        Compute WInD (the mixture fits are most of the cost).

    Returns
    -------
    dict of metric entries (multimodality only when some window has >= 2 samples);
    ``n`` = number of generated sentences, ``windows`` = generated windows.
    """
    latent = _latent(ground_truth, generated, extractor, samples_for_multimodality=samples_for_multimodality,
                     wind_components=wind_components, wind_repeats=wind_repeats, seed=seed,
                     fd_resamples=fd_resamples, wind_resamples=wind_resamples, wind_workers=wind_workers,
                     wind_cache=wind_cache, progress=progress, wind=wind)
    entries = dict(latent.entries)
    per_sentence = {k: float(v.mean()) for k, v in latent.energy.items()}
    energy, _rows, _reps = _sentence_entries({"energy_latent": per_sentence}, seed=seed, resamples=resamples)
    for entry in energy.values():
        entry["windows"] = latent.entries["fd"]["windows"]
    entries.update(energy)
    return entries


@dataclass(frozen=True)
class _Latent:
    """What the VAE-feature metrics of a split give: set-level entries with their
    bootstrap replicates, the latent energy score per window of each sentence and the
    encoded ground truth (for the FD floor probe)."""

    entries: dict
    replicates: dict
    energy: dict
    real: np.ndarray


def _latent_energy(real, real_keys, fake, fake_keys) -> dict:
    """``{key: (windows,) energy scores}``: each generated window group (the S samples of one
    (sentence, start)) against the ground-truth window of that start."""
    real_index = {key_start: i for i, key_start in enumerate(real_keys)}
    groups: dict = {}
    for i, (key, start, _sample) in enumerate(fake_keys):
        groups.setdefault(key, {}).setdefault(start, []).append(i)
    out = {}
    for key, starts in groups.items():
        order = sorted(starts)
        samples = np.stack([fake[starts[t]] for t in order], axis=1)  # (S, windows, D)
        truth = real[[real_index[(key, t)] for t in order]]
        out[key] = energy_scores(samples, truth)
    return out


def _latent(ground_truth, generated, extractor, *, samples_for_multimodality, wind_components, wind_repeats, seed,
            fd_resamples, wind_resamples, wind_workers, wind_cache, progress, wind=True) -> _Latent:
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
    replicates = {}

    def resampled(name, statistic, point, count, resample_seed):
        rows = bootstrap_indices(n, count, resample_seed) if n >= 2 else np.empty((0, n), dtype=np.int64)
        bar = (lambda it: tqdm(it, desc=f"{metric_info(name).label} bootstrap", unit="resample", disable=not progress))
        replicates[name], ci = _replicates_and_interval(point, [statistic(row) for row in bar(rows)])
        return ci

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
    out = {"fd": metric_entry("fd", fd, None, n=n, ci95=resampled("fd", fd_of, fd, fd_resamples, seed), **extra)}

    if wind:
        k = min(wind_components, len(real), len(fake))
        w_mean, w_std, reps = _wind_with_replicates(fake, real, members, k, repeats=wind_repeats, seed=seed,
                                                    resamples=wind_resamples, workers=wind_workers,
                                                    cache=_wind_cache_dir(wind_cache), progress=progress)
        replicates["wind"], wind_ci = _replicates_and_interval(w_mean, reps)
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
            ci95=resampled("multimodality", mm_of, value, BOOTSTRAP_RESAMPLES, seed + 2), **extra)
    energy = _latent_energy(real, windows.real_keys, fake, windows.fake_keys)
    return _Latent(out, replicates, energy, real)


def sentence_vertex_values(preds, gt_v, neutral, lip, upper, *, diversity: bool = True) -> dict:
    """LVE, LVE², MVE, |FDD| per sample, the energy score and, for S >= 2, the diversity
    measures of one sentence (in one reference space: ``gt_v`` is the reference).

    Parameters
    ----------
    preds : (S, T, V, 3) ndarray
    gt_v : (T, V, 3) ndarray
    neutral : (V, 3) ndarray
    lip, upper : int ndarrays
        Lip and upper-face vertex indices.
    diversity : bool
        Compute the diversity measures (they do not depend on ``gt_v``).

    Returns
    -------
    dict
        ``lve``, ``lve_squared``, ``mve``, ``fdd``: (S,) arrays; ``energy``: float (mm);
        ``apd``, ``upd``, ``lpd``, ``mpd``: floats (S >= 2 and ``diversity`` only).
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
    out["energy"] = vertex_energy_score(preds, gt_v)
    if diversity and len(preds) >= 2:
        out.update(vertex.diversity_metrics(preds, upper, lip))
    return out


#: Vertex metrics that do not depend on the reference (equal in both spaces when the
#: samples are the same vertices).
_DIVERSITY = ("apd", "upd", "lpd", "mpd")


def _in_space(values: dict, space: str) -> dict:
    """``values`` of :func:`sentence_vertex_values` named for ``space`` (``lve`` -> ``lve_rig``)."""
    return {f"{name}_{space}": value for name, value in values.items()}


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


def _vertex_values(ground_truth, generated, rigs, names, progress=False, workers: int = 1, *,
                   mesh_vertices=None, own_vertices=None, spaces=("mesh", "rig")) -> dict:
    """Per-sentence vertex metrics and energy scores in the reference ``spaces``.

    Rig space: the rig reconstruction of ``generated`` against that of the ground-truth
    coefficients. Mesh space: ``own_vertices[key]`` (a vertex method's own output) or,
    for coefficient rows, the rig reconstruction of ``generated``, against
    ``mesh_vertices(subject, sentence)`` (the source meshes).
    """
    from benchmark.metrics import vertex

    regions = _regions_of(rigs, names)
    if "mesh" in spaces and mesh_vertices is None:
        raise ValueError("_vertex_values: the mesh space needs the source meshes (mesh_vertices)")

    def task(key):
        subject, sentence = key
        neutral, deltas, lip, upper = regions[subject]
        own = own_vertices is not None
        preds_rig = None
        if "rig" in spaces or not own:
            preds_rig = np.stack([vertex.rig_vertices(neutral, deltas, t) for t in generated[key]])
        out = {}
        if "rig" in spaces:
            gt_rig = vertex.rig_vertices(neutral, deltas, ground_truth[key])
            out.update(_in_space(sentence_vertex_values(preds_rig, gt_rig, neutral, lip, upper), "rig"))
        if "mesh" in spaces:
            gt_mesh = np.asarray(mesh_vertices(subject, sentence), dtype=np.float64)
            preds = np.asarray(own_vertices[key], dtype=np.float64) if own else preds_rig
            if preds.shape[2:] != gt_mesh.shape[1:] or gt_mesh.shape[1:] != neutral.shape:
                raise ValueError(f"vertex metrics {subject}/{sentence}: expected vertices (S, T, {neutral.shape[0]}, "
                                 f"3) like the source meshes {gt_mesh.shape} and the rig {neutral.shape}, got "
                                 f"{preds.shape}")
            # coefficient rows: the same vertices in both spaces, so the same diversity
            mesh = sentence_vertex_values(preds, gt_mesh, neutral, lip, upper,
                                          diversity=own or "rig" not in spaces)
            if not own and "rig" in spaces:
                mesh.update({n: out[f"{n}_rig"] for n in _DIVERSITY if f"{n}_rig" in out})
            out.update(_in_space(mesh, "mesh"))
        return out

    return _by_metric(_map_sentences(task, generated, workers=workers, desc="vertex metrics", progress=progress))


def vertex_metrics(ground_truth, generated, rigs: Mapping, names, *, seed: int = 0,
                   resamples: int = BOOTSTRAP_RESAMPLES, mesh_vertices=None) -> dict:
    """LVE, MVE, FDD, the energy score and the diversity measures of coefficient tracks
    through each speaker's rig: ``*_rig`` against the rig reconstruction of the ground
    truth and, with ``mesh_vertices``, ``*_mesh`` against the source meshes.

    Parameters
    ----------
    ground_truth : (subject, sentence) -> (T, C); generated : same keys -> (S, T, C)
    rigs : subject -> rig with ``neutral``, ``deltas``, ``names``
    names : column names of the tracks
    mesh_vertices : callable (subject, sentence) -> (T, V, 3), optional
        The source meshes (``dataset.vertices``).

    Returns
    -------
    dict of metric entries; spread = std over sentences.
    """
    spaces = ("mesh", "rig") if mesh_vertices is not None else ("rig",)
    values = _vertex_values(ground_truth, generated, rigs, names, mesh_vertices=mesh_vertices, spaces=spaces)
    return _sentence_entries(values, seed=seed, resamples=resamples)[0]


def own_vertex_metrics(generated_vertices: Mapping, ground_truth_vertices, rigs: Mapping, names, *,
                       seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES, progress: bool = False) -> dict:
    """The mesh-space vertex metrics (``*_mesh``) of a vertex-output method's own vertices.

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
    values = _vertex_values(None, generated_vertices, rigs, names, progress, mesh_vertices=ground_truth_vertices,
                            own_vertices=generated_vertices, spaces=("mesh",))
    return _sentence_entries(values, seed=seed, resamples=resamples)[0]


def _offset_values(values: dict, estimator: str, key, offsets, reference) -> None:
    """Add one sentence's offsets (a list, one per scored sample) of ``estimator`` to
    ``values``: mean |offset|, mean signed offset and, with the ground truth's signed
    offset ``reference`` on the same sentence, the lag bias."""
    offsets = [float(o) for o in offsets]
    values.setdefault(f"av_offset_{estimator}", {})[key] = [abs(o) for o in offsets]
    values.setdefault(f"av_offset_signed_{estimator}", {})[key] = offsets
    if reference is not None:
        values.setdefault(f"av_lag_bias_{estimator}", {})[key] = [o - float(reference) for o in offsets]


def _lipsync_values(generated, rigs, audio, names, *, syncnet=None, sync_expert=None, max_lag=15,
                    progress=False, workers: int = 1, ground_truth=None) -> dict:
    """Per-sentence AV offsets (absolute and signed) and confidences of every estimator
    given; with ``ground_truth`` (key -> (T, C) coefficients) also the lag bias: the
    signed offset minus the ground truth's on the same sentence, same estimator."""
    from benchmark.lipsync import geometric_sync, mouth_activity, syncnet_sync_track
    from benchmark.metrics import vertex

    regions = _regions_of(rigs, names)
    reference = ground_truth is not None

    def geometric(key):
        neutral, deltas, lip, _upper = regions[key[0]]
        samples, rate = audio[key]

        def estimate(track):
            activity = mouth_activity(vertex.rig_vertices(neutral, deltas, track), neutral, lip)
            return geometric_sync(activity, samples, rate, 60.0, max_lag)

        est = [estimate(track) for track in generated[key]]
        truth = estimate(ground_truth[key]).offset if reference else None
        return [e.offset for e in est], [e.confidence for e in est], truth

    geo = _map_sentences(geometric, generated, workers=workers, desc="lip sync (geometric)", progress=progress)
    values: dict = {}
    for key, (offsets, confidences, truth) in geo.items():
        _offset_values(values, "geometric", key, offsets, truth)
        values.setdefault("av_confidence_geometric", {})[key] = confidences
    # the torch models run in this process
    if syncnet is not None:
        for key in tqdm(list(generated), disable=not progress, desc="lip sync (SyncNet)", unit="sentence"):
            neutral, deltas, _lip, _upper = regions[key[0]]
            samples, rate = audio[key]

            def estimate(track):
                verts = vertex.rig_vertices(neutral, deltas, track)
                return syncnet_sync_track(syncnet, verts, rigs[key[0]].faces, samples, rate)

            est = estimate(generated[key][0])
            truth = estimate(ground_truth[key]).offset if reference else None
            _offset_values(values, "syncnet", key, [est.offset], truth)
            values.setdefault("av_confidence_syncnet", {})[key] = est.confidence
    if sync_expert is not None:
        for key in tqdm(list(generated), disable=not progress, desc="lip sync (expert)", unit="sentence"):
            samples, rate = audio[key]

            def estimate(track):
                return sync_expert.sync(np.asarray(track, dtype=np.float64), samples, rate)

            est = [estimate(track) for track in generated[key]]
            truth = estimate(ground_truth[key]).offset if reference else None
            _offset_values(values, "expert", key, [e.offset for e in est], truth)
            values.setdefault("av_confidence_expert", {})[key] = [e.confidence for e in est]
    return values


def lipsync_metrics(generated, rigs: Mapping, audio: Mapping, names, *, syncnet=None, sync_expert=None,
                    max_lag: int = 15, seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES,
                    progress: bool = False, ground_truth: Mapping | None = None) -> dict:
    """Geometric (weight-free) and, with the models, SyncNet and sync-expert AV offset/confidence.

    ``av_offset_*`` averages absolute offsets (opposite errors must not cancel: it
    measures sync quality), ``av_offset_signed_*`` the signed ones (positive: motion
    after audio), and with ``ground_truth`` ``av_lag_bias_*`` is the signed offset minus
    the ground truth's on the same sentence with the same estimator: the row's
    systematic lead or lag against the data. Geometric and expert in 60 fps frames
    over every sample, SyncNet in 25 fps frames over the first sample of each sentence.
    """
    values = _lipsync_values(generated, rigs, audio, names, syncnet=syncnet, sync_expert=sync_expert,
                             max_lag=max_lag, progress=progress, ground_truth=ground_truth)
    return _sentence_entries(values, seed=seed, resamples=resamples)[0]


def _load_models(syncnet, sync_expert):
    if syncnet is True or isinstance(syncnet, (str, PathLike)):
        from benchmark.lipsync import load_syncnet

        syncnet = load_syncnet(None if syncnet is True else syncnet)
    if isinstance(sync_expert, (str, PathLike)):
        from benchmark.lipsync.expert import load_expert

        sync_expert = load_expert(sync_expert)
    return syncnet, sync_expert


#: The constant added to the ground truth for :func:`fd_floor_probe`.
FD_FLOOR_SHIFT = 0.002


def fd_floor_probe(real_features: np.ndarray, ground_truth: Mapping, extractor) -> float:
    """FD of the ground truth shifted by +:data:`FD_FLOOR_SHIFT` (clipped to [0, 1]) against
    the ground truth: how much FD a constant offset too small to see costs on this split.

    Most ground-truth coefficients of a speech corpus sit exactly at 0 and the VAE
    maps that floor to a tight cluster, so FD is very sensitive to it; every result
    records this figure beside FD (``protocol.fd_floor_probe``) to read FD against it.

    Parameters
    ----------
    real_features : (N, D) ndarray
        The encoded ground-truth windows of the split.
    ground_truth : key -> (T, C)
    extractor : the feature extractor that encoded them
    """
    from benchmark.metrics import cut_windows, frechet_distance

    shifted = {k: np.clip(np.asarray(v, dtype=np.float64) + FD_FLOOR_SHIFT, 0.0, 1.0) for k, v in ground_truth.items()}
    windows = cut_windows(shifted)
    return float(frechet_distance(_encoded(extractor, windows.real, "encode shifted windows", False), real_features))


def _requested(metrics) -> frozenset | None:
    if metrics is None:
        return None
    from benchmark.metrics.registry import METRICS

    names = frozenset([metrics] if isinstance(metrics, str) else metrics)
    unknown = sorted(names - set(METRICS))
    if unknown:
        raise ValueError(f"evaluate_split: unknown metric(s) {unknown}; registered: {sorted(METRICS)}")
    return names


def _source_meshes(dataset, keys, mesh):
    """``dataset.vertices`` when the mesh space is scored, else None (``mesh=None``: when the
    dataset can give its source meshes, with a warning when it cannot)."""
    if mesh is False:
        return None
    vertices = getattr(dataset, "vertices", None)
    try:
        if vertices is None:
            raise AttributeError(f"{type(dataset).__name__} has no vertices()")
        vertices(*keys[0])
    except (AttributeError, NotImplementedError, OSError, KeyError, ValueError) as exc:
        if mesh:
            raise
        warnings.warn(f"evaluate_split: the source meshes cannot be read ({type(exc).__name__}: {exc}); "
                      "the mesh-space metrics (*_mesh) are not computed", stacklevel=3)
        return None
    return vertices


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
    mesh: bool | None = None,
    metrics=None,
) -> Scores:
    """Score generated tracks against a split's ground truth.

    Parameters
    ----------
    generated : mapping (subject, sentence) -> (S, T, 32) array_like
        S samples per sentence (S = 1 for deterministic methods), 60 fps,
        columns ``dataset.names``. Keys outside the split are ignored; split
        sentences without an entry are not scored.
    dataset : benchmark.data.BlendVOCADataset (or any object with ``split``,
        ``sentences``, ``coeffs``, ``audio``, ``rig``, ``names`` and, for the mesh
        space, ``vertices``)
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
        Compute vertex-space (and energy) and lip-sync metrics.
    vertices : mapping (subject, sentence) -> (S, T, V, 3), optional
        The own vertices of an ``output = "vertices"`` method (``generated`` then
        holds their rig fits): its mesh-space metrics compare them with the source
        meshes; its rig-space metrics compare the rig reconstructions of the fits
        with that of the ground-truth coefficients.
    resamples, fd_resamples, wind_resamples : int
        Bootstrap resamples of the per-sentence metrics, FD and WInD.
    workers : int
        Processes for the WInD fits and the per-sentence vertex and geometric lip-sync
        metrics (forked, single-threaded each: the scores do not depend on it).
    wind_cache : True, path or None
        Where the ground-truth WInD fits are kept (see :func:`latent_metrics`).
    progress : bool
        tqdm bars for every stage.
    mesh : bool or None
        Score the mesh space (against ``dataset.vertices``): None when the dataset
        can give its source meshes (a warning when it cannot), True always (an error
        when it cannot), False never.
    metrics : iterable of str, optional
        Compute only these registered metrics (e.g. ``("lve_rig", "fd")``); default all.

    Returns
    -------
    Scores
        ``{name: {"mean", "std", "ci95", "n", "higher_is_better", "unit", "label",
        "group"[, "sample_std"][, "replicates"]}}`` in table order: ``fd``, ``wind``,
        ``multimodality`` (S >= 2), ``energy_latent``; per reference space
        (``_rig``, ``_mesh``) ``lve``, ``lve_squared``, ``mve``, ``fdd``, ``energy``
        and ``apd``/``upd``/``lpd``/``mpd`` (S >= 2); ``av_offset_*``,
        ``av_offset_signed_*``, ``av_lag_bias_*`` and ``av_confidence_*`` of the
        geometric estimator and the SyncNet and expert ones when given. Set-level
        metrics carry their bootstrap ``replicates`` (paired across rows scored on the
        same split with the same seed). ``Scores.per_sentence`` rows,
        ``Scores.replicates`` (every metric's bootstrap replicates) and
        ``Scores.protocol`` (``fd_floor_probe``). The latent metrics are left out
        (with a warning) when the split's ground truth has fewer than 2 windows of
        120 frames.
    """
    names = tuple(dataset.names)
    keys = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    if not keys:
        raise ValueError(f"evaluate_split: split {split!r} of {dataset!r} has no sentences")
    wanted = _requested(metrics)

    def want(*candidates) -> bool:
        return wanted is None or any(c in wanted for c in candidates)

    def want_suffix(suffix) -> bool:
        return wanted is None or any(name.endswith(suffix) for name in wanted)

    generated = _check_generated(generated, keys, len(names))
    ground_truth = {k: dataset.coeffs(*k) for k in keys}
    n_real = sum(len(window_starts(len(v), drop_last=GT_DROP_LAST)) for v in ground_truth.values())
    results, values, replicates, protocol = {}, {}, {}, {}
    if want("fd", "wind", "multimodality", "energy_latent"):
        if n_real >= 2:
            extractor = _resolve_extractor(extractor)
            latent = _latent(ground_truth, generated, extractor, samples_for_multimodality=samples_for_multimodality,
                             wind_components=wind_components, wind_repeats=wind_repeats, seed=seed,
                             fd_resamples=fd_resamples, wind_resamples=wind_resamples, wind_workers=workers,
                             wind_cache=wind_cache, progress=progress, wind=want("wind"))
            results.update(latent.entries)
            replicates.update(latent.replicates)
            values["energy_latent"] = {k: float(v.mean()) for k, v in latent.energy.items()}
            protocol["fd_floor_probe"] = fd_floor_probe(latent.real, ground_truth, extractor)
        else:
            # sentences shorter than 122 frames give no 120-frame window: no latent metric
            warnings.warn(f"evaluate_split: split {split!r} has {n_real} ground-truth windows of 120 frames; "
                          "FD, WInD, multimodality and the latent energy score are not computed", stacklevel=2)
    spaces = tuple(space for space in ("mesh", "rig") if want_suffix(f"_{space}"))
    lipsync = lipsync and any(want(n) for n in _LIPSYNC_NAMES)
    if (vertex and spaces) or lipsync:
        rigs = {s: dataset.rig(s) for s in {k[0] for k in generated}}
    if vertex and spaces:
        if "mesh" in spaces:
            mesh_vertices = dataset.vertices if vertices is not None else _source_meshes(dataset, keys, mesh)
            if mesh_vertices is None:
                spaces = tuple(s for s in spaces if s != "mesh")
        else:
            mesh_vertices = None
        own = None if vertices is None else _Subset(vertices, list(generated))
        if spaces:
            values.update(_vertex_values(ground_truth, generated, rigs, names, progress, workers,
                                         mesh_vertices=mesh_vertices, own_vertices=own, spaces=spaces))
    if lipsync:
        syncnet, sync_expert = _load_models(syncnet, sync_expert)
        audio = {k: dataset.audio(*k) for k in generated}
        values.update(_lipsync_values(generated, rigs, audio, names, syncnet=syncnet, sync_expert=sync_expert,
                                      progress=progress, workers=workers, ground_truth=ground_truth))
    entries, rows, sentence_replicates = _sentence_entries(values, seed=seed, resamples=resamples)
    results.update(entries)
    replicates.update(sentence_replicates)
    if wanted is not None:
        results = {name: entry for name, entry in results.items() if name in wanted}
    for name, entry in results.items():
        if name in METRICS and METRICS[name].level == "set" and name in replicates:
            entry["replicates"] = [float(f"{v:.7g}") for v in replicates[name]]
    per_sentence = [{"subject": k[0], "sentence": k[1],
                     **{n: v for n, v in rows.get(k, {}).items() if wanted is None or n in wanted}}
                    for k in keys if k in generated]
    scores = Scores({name: results[name] for name in ordered_metrics(list(results))}, per_sentence)
    scores.replicates = {name: replicates[name] for name in scores if name in replicates}
    scores.protocol = protocol
    return scores


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
