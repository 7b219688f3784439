"""The latent family: FD, WInD, multimodality and the latent energy score over VAE
features of 120-frame windows, with their bootstrap intervals and metadata
(:data:`METRICS`), and the FD floor probe a result records beside FD."""

from __future__ import annotations

from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np

from benchmark.evaluation.entries import replicates_and_interval, sentence_entries
from benchmark.evaluation.settings import EvaluationSettings
from benchmark.metrics import (
    cached_gmm_components_many,
    cut_windows,
    feature_statistics,
    frechet_distance,
    frechet_distance_from_stats,
    gmm_components_many,
    multimodality,
    paired_samples,
    wind_from_gmms,
)
from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES, bootstrap_indices
from benchmark.metrics.energy import energy_scores
from benchmark.metrics.info import MetricInfo, declared
from blendvoca.assets import cache_dir
from blendvoca.runtime.progress import bar, progress_bars

__all__ = ["FD_FLOOR_SHIFT", "METRICS", "WIND_RESAMPLE_WINDOWS", "Latent", "fd_floor_probe", "latent_results",
           "latent_metrics", "resolve_extractor", "wind_cache_dir"]

#: The family's metrics, in table order within each group.
METRICS = declared(
    MetricInfo("multimodality", "Multimodality", "latent", True, "distribution",
               "std of the pair distances", min_samples=2, level="set"),
    MetricInfo("fd", "FD", "latent^2", False, "distribution", "none (one value for the set)", level="set"),
    MetricInfo("wind", "WInD", "latent^2", False, "distribution", "std over GMM refits", level="set"),
    MetricInfo("energy_latent", "Energy latent", "latent", False, "energy", "std over sentences (mean over windows)"),
)
#: Largest number of windows a WInD resample is fitted on (a seeded subsample beyond it).
WIND_RESAMPLE_WINDOWS = 20000
#: The constant added to the ground truth for :func:`fd_floor_probe`.
FD_FLOOR_SHIFT = 0.002
#: Windows encoded per progress step.
_ENCODE_CHUNK = 4096


def resolve_extractor(extractor):
    """``extractor`` itself, or the VAE it names (a path; None: the published VAE)."""
    from benchmark.features import load_published_vae  # torch: loaded only to encode

    if extractor is None or isinstance(extractor, (str, PathLike)):
        return load_published_vae(extractor)
    return extractor


def _encoded(extractor, windows, desc: str) -> np.ndarray:
    from benchmark.features import encode_windows  # torch: loaded only to encode

    chunks = range(0, len(windows), _ENCODE_CHUNK)
    return np.concatenate([encode_windows(extractor, windows[i:i + _ENCODE_CHUNK])
                           for i in bar(chunks, desc=desc, unit="chunk")])


def wind_cache_dir(wind_cache):
    """The folder of the ground-truth WInD fits (``True``: ``<user cache>/wind-gmm``) or None."""
    if wind_cache is True:
        return cache_dir() / "wind-gmm"
    return None if wind_cache in (None, False) else Path(wind_cache)


def _wind_with_replicates(fake, real, members, k, *, repeats, seed, resamples, workers, cache):
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
    fits = gmm_components_many(jobs, workers, desc="WInD fits")
    # warm starts from the seed-`seed` mixture (a resample with fewer windows than
    # components keeps its own k-means start)
    resample_jobs = [job + (fits[0],) if job[1] == k else job for job in resample_jobs]
    refits = gmm_components_many(resample_jobs, workers, desc="WInD refits")
    scores = np.array([wind_from_gmms(fits[r], real_gmms[r]) for r in range(repeats)])
    w_mean, w_std = float(scores.mean()), float(np.std(scores, ddof=1)) if repeats > 1 else 0.0
    resampled = np.array([wind_from_gmms(gmm, real_gmms[0]) for gmm in refits])
    return w_mean, w_std, resampled


@dataclass(frozen=True)
class Latent:
    """What the VAE-feature metrics of a split give: set-level entries with their
    bootstrap replicates, the latent energy score per window of each sentence and the
    encoded ground truth (for the FD floor probe)."""

    entries: dict
    replicates: dict
    energy: dict
    real: np.ndarray

    def sentence_values(self) -> dict:
        """The per-sentence metrics, ``{"energy_latent": {key: mean over the sentence's windows}}``."""
        return {"energy_latent": {k: float(v.mean()) for k, v in self.energy.items()}}


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


def latent_results(ground_truth, generated, extractor, settings: EvaluationSettings, *, wind: bool = True) -> Latent:
    """The set-level latent metrics (FD, WInD unless ``wind`` is False, multimodality where
    some window has >= 2 samples) and the latent energy scores of every window."""
    windows = cut_windows(ground_truth, generated)
    if len(windows.real) < 2 or len(windows.fake) < 2:
        raise ValueError(
            f"latent_metrics: need >= 2 windows on each side, got {len(windows.real)} ground-truth and "
            f"{len(windows.fake)} generated (sequences shorter than 120 frames give none)"
        )
    real = _encoded(extractor, windows.real, "encode ground-truth windows")
    fake = _encoded(extractor, windows.fake, "encode generated windows")
    sentence_of = {}
    owner = np.array([sentence_of.setdefault(key, len(sentence_of)) for key, _, _ in windows.fake_keys])
    n = len(sentence_of)
    members = [np.flatnonzero(owner == i) for i in range(n)]
    extra = {"windows": int(len(fake))}
    replicates = {}
    seed = settings.seed

    def resampled(name, statistic, point, count, resample_seed):
        rows = bootstrap_indices(n, count, resample_seed) if n >= 2 else np.empty((0, n), dtype=np.int64)
        values = [statistic(row) for row in bar(rows, desc=f"{METRICS[name].label} bootstrap", unit="resample")]
        replicates[name], ci = replicates_and_interval(point, values)
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
    out = {"fd": METRICS["fd"].entry(fd, None, n=n, ci95=resampled("fd", fd_of, fd, settings.fd_resamples, seed),
                                     **extra)}

    if wind:
        k = min(settings.wind_components, len(real), len(fake))
        w_mean, w_std, reps = _wind_with_replicates(fake, real, members, k, repeats=settings.wind_repeats, seed=seed,
                                                    resamples=settings.wind_resamples, workers=settings.workers,
                                                    cache=wind_cache_dir(settings.wind_cache))
        replicates["wind"], wind_ci = replicates_and_interval(w_mean, reps)
        out["wind"] = METRICS["wind"].entry(w_mean, w_std, n=n, ci95=wind_ci, **extra)

    pairs = settings.samples_for_multimodality
    groups = windows.fake_groups()
    sums_d, counts_d, all_d = np.zeros(n), np.zeros(n), []
    for i, m in enumerate(members):
        a, b = paired_samples(fake[m], [groups[j] for j in m], pairs)
        if len(a):
            d = np.linalg.norm(a - b, axis=1)
            sums_d[i], counts_d[i] = d.sum(), len(d)
            all_d.append(d)
    if all_d:
        dists = np.concatenate(all_d)
        value = multimodality(*paired_samples(fake, groups, pairs))

        def mm_of(rows):
            return sums_d[rows].sum() / max(counts_d[rows].sum(), 1.0)

        out["multimodality"] = METRICS["multimodality"].entry(
            value, dists.std(ddof=1) if len(dists) > 1 else None, n=n,
            ci95=resampled("multimodality", mm_of, value, BOOTSTRAP_RESAMPLES, seed + 2), **extra)
    energy = _latent_energy(real, windows.real_keys, fake, windows.fake_keys)
    return Latent(out, replicates, energy, real)


def latent_metrics(ground_truth: Mapping[Hashable, np.ndarray], generated: Mapping[Hashable, np.ndarray], extractor,
                   settings: EvaluationSettings = EvaluationSettings(), *, wind: bool = True) -> dict:
    """FD, WInD, multimodality and the latent energy score over VAE features of 120-frame
    windows, with bootstrap intervals.

    Parameters
    ----------
    ground_truth : key -> (T, C); generated : key -> (S, T, C)
    extractor : feature extractor (see :func:`benchmark.features.encode_windows`)
    settings : EvaluationSettings
        Read: ``samples_for_multimodality``, ``wind_components``, ``wind_repeats``,
        ``seed``, the bootstrap resamples over the generated sentences (the
        ground-truth set is fixed) of FD, WInD and the per-sentence latent energy
        score (``fd_resamples``, ``wind_resamples``, ``resamples``), ``workers`` (the
        WInD mixture fits; each is seeded and single-threaded, so the scores do not
        depend on it) and ``wind_cache`` (where the ground-truth fits are kept).
    wind : bool
        Compute WInD (the mixture fits are most of the cost).

    Returns
    -------
    dict of metric entries (multimodality only when some window has >= 2 samples);
    ``n`` = number of generated sentences, ``windows`` = generated windows.
    """
    result = latent_results(ground_truth, generated, extractor, settings, wind=wind)
    entries = dict(result.entries)
    energy = sentence_entries(result.sentence_values(), METRICS, seed=settings.seed, resamples=settings.resamples)[0]
    for entry in energy.values():
        entry["windows"] = result.entries["fd"]["windows"]
    entries.update(energy)
    return entries


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
    shifted = {k: np.clip(np.asarray(v, dtype=np.float64) + FD_FLOOR_SHIFT, 0.0, 1.0) for k, v in ground_truth.items()}
    windows = cut_windows(shifted)
    with progress_bars(False):
        features = _encoded(extractor, windows.real, "encode shifted windows")
    return float(frechet_distance(features, real_features))
