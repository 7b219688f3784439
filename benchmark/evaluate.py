"""Evaluation protocol: every metric of a method's generated tracks on a split.

``evaluate_split(generated, dataset, split="test")`` where
``generated[(subject, sentence)]`` is an ``(S, T, 32)`` array (S samples, 60 fps,
BlendVOCA column order) returns ``{metric: {"mean", "std", "higher_is_better",
"unit"}}``. See docs/metrics.md for the definitions and the window protocol.
"""

from __future__ import annotations

import warnings
from collections.abc import Hashable, Mapping
from os import PathLike

import numpy as np
from tqdm import tqdm

from benchmark.metrics.multimodality import PAIRS_PER_WINDOW
from benchmark.metrics.windows import GT_DROP_LAST, window_starts

MetricDict = dict


def _entry(mean, std, higher_is_better: bool, unit: str) -> dict:
    return {"mean": float(mean), "std": None if std is None else float(std),
            "higher_is_better": bool(higher_is_better), "unit": unit}


def _spread(values) -> tuple[float, float | None]:
    values = np.asarray(values, dtype=np.float64)
    return float(values.mean()), (float(values.std(ddof=1)) if len(values) > 1 else None)


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


def latent_metrics(ground_truth: Mapping[Hashable, np.ndarray], generated: Mapping[Hashable, np.ndarray], extractor,
                   *, samples_for_multimodality: int = PAIRS_PER_WINDOW, wind_components: int = 5,
                   wind_repeats: int = 10, seed: int = 0) -> dict:
    """FD, WInD and multimodality over VAE features of 120-frame windows.

    Parameters
    ----------
    ground_truth : key -> (T, C); generated : key -> (S, T, C)
    extractor : feature extractor (see :func:`benchmark.features.encode_windows`)

    Returns
    -------
    dict of metric entries (multimodality only when some window has >= 2 samples).
    """
    from benchmark.features import encode_windows
    from benchmark.metrics import cut_windows, frechet_distance, multimodality, paired_samples, wind

    windows = cut_windows(ground_truth, generated)
    if len(windows.real) < 2 or len(windows.fake) < 2:
        raise ValueError(
            f"latent_metrics: need >= 2 windows on each side, got {len(windows.real)} ground-truth and "
            f"{len(windows.fake)} generated (sequences shorter than 120 frames give none)"
        )
    real = encode_windows(extractor, windows.real)
    fake = encode_windows(extractor, windows.fake)
    out = {"fd": _entry(frechet_distance(fake, real), None, False, "latent^2")}
    k = min(wind_components, len(real), len(fake))
    w_mean, w_std = wind(fake, real, n_components=k, repeats=wind_repeats, seed=seed)
    out["wind"] = _entry(w_mean, w_std, False, "latent^2")
    a, b = paired_samples(fake, windows.fake_groups(), samples_for_multimodality)
    if len(a):
        dists = np.linalg.norm(a - b, axis=1)
        out["multimodality"] = _entry(multimodality(a, b), dists.std(ddof=1) if len(dists) > 1 else None, True, "latent")
    return out


def vertex_metrics(ground_truth, generated, rigs: Mapping, names) -> dict:
    """LVE, MVE, FDD and the diversity measures through each speaker's rig.

    Parameters
    ----------
    ground_truth : (subject, sentence) -> (T, C); generated : same keys -> (S, T, C)
    rigs : subject -> rig with ``neutral``, ``deltas``, ``names``
    names : column names of the tracks

    Returns
    -------
    dict of metric entries; spread = std over sequences.
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # small matrix products: one BLAS thread is faster here
        return _vertex_metrics(ground_truth, generated, rigs, names)


def _vertex_metrics(ground_truth, generated, rigs, names) -> dict:
    from benchmark.metrics import regions, vertex

    per_seq = {k: [] for k in ("lve", "lve_squared", "mve", "fdd", "apd", "upd", "lpd", "mpd")}
    cache = {}
    for (subject, sentence), tracks in generated.items():
        if subject not in cache:
            rig = rigs[subject]
            neutral = np.asarray(rig.neutral, dtype=np.float64)
            deltas = _rig_deltas(rig, names)
            cache[subject] = (neutral, deltas, regions.lip_vertices(deltas, names),
                              regions.upper_face_vertices(neutral))
        neutral, deltas, lip, upper = cache[subject]
        gt_v = vertex.rig_vertices(neutral, deltas, ground_truth[(subject, sentence)])
        preds = np.stack([vertex.rig_vertices(neutral, deltas, t) for t in tracks])
        lve, lve_sq, mve, fdd = [], [], [], []
        for p in preds:
            lve.append(vertex.lip_vertex_error(p, gt_v, lip))
            lve_sq.append(vertex.lip_vertex_error(p, gt_v, lip, squared=True))
            mve.append(vertex.mean_vertex_error(p, gt_v))
            # |FDD| per sequence: CodeTalker's signed mean lets too-lively and
            # too-still sequences cancel, and a ranking needs "closer to 0 is better".
            fdd.append(abs(vertex.upper_face_dynamics_deviation(p, gt_v, neutral, upper)))
        per_seq["lve"].append(np.mean(lve))
        per_seq["lve_squared"].append(np.mean(lve_sq))
        per_seq["mve"].append(np.mean(mve))
        per_seq["fdd"].append(np.mean(fdd))
        if len(preds) >= 2:
            for name, value in vertex.diversity_metrics(preds, upper, lip).items():
                per_seq[name].append(value)
    spec = {"lve": (False, "mm"), "lve_squared": (False, "mm^2"), "mve": (False, "mm"), "fdd": (False, "mm^2"),
            "apd": (True, "mm"), "upd": (True, "mm"), "lpd": (True, "mm"), "mpd": (True, "mm")}
    return {k: _entry(*_spread(v), *spec[k]) for k, v in per_seq.items() if v}


def _rig_deltas(rig, names) -> np.ndarray:
    rig_names = tuple(rig.names)
    if tuple(names) == rig_names:
        return np.asarray(rig.deltas, dtype=np.float64)
    missing = [n for n in names if n not in rig_names]
    if missing:
        raise ValueError(f"evaluate_split: the rig lacks the blendshapes {missing}")
    return np.asarray(rig.deltas, dtype=np.float64)[[rig_names.index(n) for n in names]]


def lipsync_metrics(generated, rigs: Mapping, audio: Mapping, names, *, syncnet=None, max_lag: int = 15,
                    progress: bool = False) -> dict:
    """Geometric (weight-free) and, with a SyncNet model, SyncNet AV offset/confidence.

    Offsets are averaged as absolute values (opposite errors must not cancel):
    geometric in 60 fps frames over every sample, SyncNet in 25 fps frames over
    the first sample of each sentence.
    """
    from benchmark.lipsync import geometric_sync, mouth_activity, syncnet_sync_track
    from benchmark.metrics import regions, vertex

    geo_off, geo_conf, sn_off, sn_conf = [], [], [], []
    for (subject, sentence), tracks in tqdm(generated.items(), disable=not progress, desc="lip sync"):
        rig = rigs[subject]
        neutral = np.asarray(rig.neutral, dtype=np.float64)
        deltas = _rig_deltas(rig, names)
        lip = regions.lip_vertices(deltas, names)
        samples, rate = audio[(subject, sentence)]
        for s, track in enumerate(tracks):
            verts = vertex.rig_vertices(neutral, deltas, track)
            est = geometric_sync(mouth_activity(verts, neutral, lip), samples, rate, 60.0, max_lag)
            geo_off.append(abs(est.offset))
            geo_conf.append(est.confidence)
            if syncnet is not None and s == 0:
                est = syncnet_sync_track(syncnet, verts, rig.faces, samples, rate)
                sn_off.append(abs(est.offset))
                sn_conf.append(est.confidence)
    out = {"av_offset_geometric": _entry(*_spread(geo_off), False, "frames@60fps"),
           "av_confidence_geometric": _entry(*_spread(geo_conf), True, "correlation")}
    if sn_off:
        out["av_offset_syncnet"] = _entry(*_spread(sn_off), False, "frames@25fps")
        out["av_confidence_syncnet"] = _entry(*_spread(sn_conf), True, "distance")
    return out


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
    vertex: bool = True,
    lipsync: bool = True,
    progress: bool = False,
) -> dict:
    """Score generated tracks against a split's ground truth.

    Parameters
    ----------
    generated : mapping (subject, sentence) -> (S, T, 32) array_like
        S samples per sentence (S = 1 for deterministic methods), 60 fps,
        columns ``dataset.names``. Keys outside the split are ignored; split
        sentences without an entry are not scored.
    dataset : benchmark.data.BlendVOCADataset (or any object with ``split``,
        ``sentences``, ``coeffs``, ``audio``, ``rig``, ``names``)
    split : str
    extractor : feature extractor, path to a VAE state_dict, or None for the
        published VAE (asset ``said-vae``).
    samples_for_multimodality : int
        Pairs per window for multimodality (36).
    wind_components, wind_repeats, seed : int
        WInD mixture size, number of repeated fits and first seed.
    syncnet : SyncNet module, path to weights, True (the manifest asset
        ``syncnet-weights``), or None (skip SyncNet).
    vertex, lipsync : bool
        Compute vertex-space and lip-sync metrics.
    progress : bool

    Returns
    -------
    dict
        ``{name: {"mean": float, "std": float | None, "higher_is_better": bool,
        "unit": str}}`` with names ``fd``, ``wind``, ``multimodality`` (S >= 2),
        ``lve``, ``lve_squared``, ``mve``, ``fdd``, ``apd``/``upd``/``lpd``/``mpd``
        (S >= 2), ``av_offset_geometric``, ``av_confidence_geometric``,
        ``av_offset_syncnet``, ``av_confidence_syncnet`` (with ``syncnet``).
        The latent metrics are left out (with a warning) when the split's
        ground truth has fewer than 2 windows of 120 frames.
    """
    names = tuple(dataset.names)
    keys = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    if not keys:
        raise ValueError(f"evaluate_split: split {split!r} of {dataset!r} has no sentences")
    generated = _check_generated(generated, keys, len(names))
    ground_truth = {k: dataset.coeffs(*k) for k in keys}
    n_real = sum(len(window_starts(len(v), drop_last=GT_DROP_LAST)) for v in ground_truth.values())
    if n_real >= 2:
        results = latent_metrics(ground_truth, generated, _resolve_extractor(extractor),
                                 samples_for_multimodality=samples_for_multimodality, wind_components=wind_components,
                                 wind_repeats=wind_repeats, seed=seed)
    else:
        # sentences shorter than 122 frames give no 120-frame window: no latent metric
        warnings.warn(f"evaluate_split: split {split!r} has {n_real} ground-truth windows of 120 frames; "
                      "FD, WInD and multimodality are not computed", stacklevel=2)
        results = {}
    if vertex or lipsync:
        rigs = {s: dataset.rig(s) for s in {k[0] for k in generated}}
    if vertex:
        results.update(vertex_metrics(ground_truth, generated, rigs, names))
    if lipsync:
        if syncnet is True or isinstance(syncnet, (str, PathLike)):
            from benchmark.lipsync import load_syncnet

            syncnet = load_syncnet(None if syncnet is True else syncnet)
        audio = {k: dataset.audio(*k) for k in generated}
        results.update(lipsync_metrics(generated, rigs, audio, names, syncnet=syncnet, progress=progress))
    return results
