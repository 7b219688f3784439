"""A closed-form linear ridge from log-mel frames with context to coefficients.

Not a benchmark row: a yardstick for how much of a corpus's motion a linear function
of the audio explains (the synthetic corpus's audio-determined share is read against
it, docs/synthetic.md). The features are the regression baseline's own log-mel
frames at the motion rate (:func:`baselines.regression.features.motion_rate_features`),
stacked over ``+-context`` frames (edges repeated), standardised on the training
sentences; the ridge is solved in closed form for every ``lambda`` of a grid and the
best one on the scored split is kept, so the figure is an optimistic one for a
linear model.
"""

from __future__ import annotations

import numpy as np

from baselines.regression.features import motion_rate_features

__all__ = ["LAMBDAS", "context_frames", "ridge_explained"]

#: The ridge penalties tried (features standardised, so one grid serves every corpus).
LAMBDAS = (1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7)


def context_frames(features: np.ndarray, context: int) -> np.ndarray:
    """``(T, F)`` frames stacked with their ``context`` neighbours on each side: ``(T, (2 context + 1) F)``,
    the edge frames repeated past the ends."""
    features = np.asarray(features)
    num_frames = len(features)
    padded = np.pad(features, ((context, context), (0, 0)), mode="edge")
    return np.concatenate([padded[k:k + num_frames] for k in range(2 * context + 1)], axis=1)


def _design(dataset, subject: str, sentence: str, context: int):
    audio, _ = dataset.audio(subject, sentence)
    target = dataset.coeffs(subject, sentence)
    return context_frames(motion_rate_features(audio, len(target)), context), target


def ridge_explained(dataset, *, fit_splits=("train", "val"), split: str = "test", context: int = 20,
                    lambdas=LAMBDAS) -> dict:
    """The share of ``split``'s coefficient variance a linear ridge on log-mel explains.

    Parameters
    ----------
    dataset : benchmark.data.BlendVOCADataset
    fit_splits : tuple of str
        Splits the ridge is fitted on.
    split : str
        Split it is scored on: ``1 - SS(truth - prediction) / SS(truth - its mean)``
        over all of the split's frames and coefficients.
    context : int
        Frames of context on each side (at 60 fps).
    lambdas : sequence of float

    Returns
    -------
    dict
        ``explained`` (the best over ``lambdas``), ``lambda`` (which one) and
        ``per_lambda`` ``{lambda: explained}``.
    """
    fit = [_design(dataset, s, q, context) for name in fit_splits for s in dataset.split(name)
           for q in dataset.sentences(s)]
    scored = [_design(dataset, s, q, context) for s in dataset.split(split) for q in dataset.sentences(s)]
    if not fit or not scored:
        raise ValueError(f"ridge_explained: expected sentences in {fit_splits} and in {split!r}, got "
                         f"{len(fit)} and {len(scored)}")
    x = np.concatenate([a for a, _ in fit])
    y = np.concatenate([b for _, b in fit])
    mean, scale = x.mean(axis=0), x.std(axis=0) + 1e-6
    x = (x - mean) / scale
    y_mean = y.mean(axis=0)
    x_scored = (np.concatenate([a for a, _ in scored]) - mean) / scale
    y_scored = np.concatenate([b for _, b in scored])
    total = float(((y_scored - y_scored.mean(axis=0)) ** 2).sum())
    gram, cross = x.T @ x, x.T @ (y - y_mean)
    per_lambda = {}
    for lam in lambdas:
        weights = np.linalg.solve(gram + lam * np.eye(len(gram)), cross)
        residual = y_scored - (x_scored @ weights + y_mean)
        per_lambda[float(lam)] = 1.0 - float((residual ** 2).sum()) / total
    best = max(per_lambda, key=per_lambda.get)
    return {"explained": per_lambda[best], "lambda": best, "per_lambda": per_lambda}
