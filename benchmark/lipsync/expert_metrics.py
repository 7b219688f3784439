"""Per-sample scores of generated coefficient tracks by a learned sync expert."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from blendvoca.errors import DataError
from blendvoca.runtime.progress import bar


def expert_sync_metrics(generated: Mapping, audio: Mapping, expert) -> dict:
    """AV offset and confidence of every generated sample by a sync expert.

    Parameters
    ----------
    generated : mapping
        ``{(subject, sentence): (S, T, 32) tracks}`` (or a list of ``(T, 32)``),
        columns in ``expert.names`` order, 60 fps.
    audio : mapping
        ``{(subject, sentence): (samples (N,) float32, rate)}``.
    expert : SyncExpert or path
        A loaded expert (:func:`benchmark.lipsync.load_expert`) or its checkpoint path.

    Returns
    -------
    dict
        ``"av_offset_expert"`` : (n,) absolute offsets in 60 fps frames (one per
        sample; opposite errors must not cancel), ``"av_confidence_expert"`` :
        (n,) confidences (median - min distance; higher is better),
        ``"offsets"`` : (n,) signed offsets (positive: motion after audio),
        ``"keys"`` : list of ``(subject, sentence, sample)``, ``"trained_on"`` :
        the checkpoint's provenance (data, split, steps, seconds).
    """
    if not hasattr(expert, "sync"):
        from benchmark.lipsync.expert import load_expert

        expert = load_expert(expert)
    offsets, conf, keys = [], [], []
    for (subject, sentence), tracks in bar(generated.items(), desc="sync expert"):
        if (subject, sentence) not in audio:
            raise DataError(f"expert_sync_metrics: no audio for {subject}/{sentence}")
        samples, rate = audio[(subject, sentence)]
        for s, track in enumerate(tracks):
            est = expert.sync(np.asarray(track, dtype=np.float64), samples, rate)
            offsets.append(est.offset)
            conf.append(est.confidence)
            keys.append((subject, sentence, s))
    offsets = np.asarray(offsets, dtype=np.int64)
    return {"av_offset_expert": np.abs(offsets).astype(np.float64), "av_confidence_expert": np.asarray(conf),
            "offsets": offsets, "keys": keys, "trained_on": dict(getattr(expert, "trained_on", {}))}
