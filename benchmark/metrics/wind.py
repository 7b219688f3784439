"""WInD: the Wasserstein distance between Gaussian mixtures fitted to features.

Each side is summarised by a GMM (K = 5 full-covariance components); the ground
cost between two components is their Frechet distance; WInD is the optimal
transport cost between the component weights (a small LP). GMM fitting depends on
its initialisation, so it is repeated with different seeds and reported as mean
and standard deviation.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import linprog

from blendvoca.runtime.processes import process_map
from blendvoca.runtime.threads import limited_threads

from benchmark.metrics.frechet import _as_features, frechet_distance_from_stats


def gmm_components(x, n_components: int = 5, seed: int = 0, init=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fit a full-covariance Gaussian mixture to features.

    Parameters
    ----------
    x : (N, D) array_like
    n_components : int
    seed : int
        ``random_state`` of the k-means initialisation.
    init : tuple (weights (K,), means (K, D), covariances (K, D, D)), optional
        A mixture to start EM from instead of the k-means initialisation (a warm
        start: EM from a mixture already fitted to similar features converges in a
        few iterations). ``seed`` is then unused, unless scikit-learn rejects the
        start (a covariance too close to singular): the k-means start of ``seed``.

    Returns
    -------
    weights : (K,) ndarray
    means : (K, D) ndarray
    covariances : (K, D, D) ndarray
    """
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.mixture import GaussianMixture

    x = _as_features(x, "gmm_components")
    if n_components < 1 or n_components > len(x):
        raise ValueError(f"gmm_components: n_components must be in [1, N={len(x)}], got {n_components}")
    # EM on a few thousand 64-d points is small work: with BLAS/OpenMP threads on a
    # shared CPU the thread hand-offs cost 10x more than the arithmetic (measured)
    start = {}
    if init is not None:
        weights, means, covariances = (np.asarray(a, dtype=np.float64) for a in init)
        if len(weights) != n_components or means.shape != (n_components, x.shape[1]):
            raise ValueError(f"gmm_components: init has {len(weights)} components of dimension "
                             f"{means.shape[1:]}, expected {n_components} of ({x.shape[1]},)")
        # precisions through the Cholesky factors, symmetrised: a plain inverse of a
        # nearly singular covariance need not pass scikit-learn's symmetry check
        inv_chol = np.linalg.inv(np.linalg.cholesky(covariances))
        precisions = np.swapaxes(inv_chol, 1, 2) @ inv_chol
        start = {"weights_init": weights / weights.sum(), "means_init": means,
                 "precisions_init": 0.5 * (precisions + np.swapaxes(precisions, 1, 2))}
    with limited_threads(1), warnings.catch_warnings():
        # a generator with fewer distinct outputs than components (a constant row: one)
        # makes the k-means start warn; the fit of such points is what WInD scores
        warnings.filterwarnings("ignore", message="Number of distinct clusters", category=ConvergenceWarning)
        try:
            gmm = GaussianMixture(n_components=n_components, covariance_type="full", random_state=seed,
                                  **start).fit(x)
        except ValueError:
            if not start:
                raise
            # a start scikit-learn rejects (precisions not positive definite in its
            # check): the cold, k-means start of this seed
            gmm = GaussianMixture(n_components=n_components, covariance_type="full", random_state=seed).fit(x)
    return gmm.weights_.copy(), gmm.means_.copy(), gmm.covariances_.copy()


def _fit_job(job):
    return gmm_components(*job)


def gmm_components_many(jobs, workers: int = 1, desc: str | None = None) -> list:
    """`gmm_components` of every ``(x, n_components, seed)`` job, in order.

    Each fit is seeded and single-threaded, so the results do not depend on
    ``workers`` (bit-identical); ``workers > 1`` runs them in that many forked
    processes (Linux; elsewhere, or for a single job, in this process).

    Parameters
    ----------
    jobs : sequence of ((N, D) array_like, int, int) or of ((N, D), int, int, init)
        The arguments of `gmm_components`.
    workers : int
    desc : str, optional
        Title of a progress bar over the fits (none without it).

    Returns
    -------
    list of (weights (K,), means (K, D), covariances (K, D, D))
    """
    return list(process_map(_fit_job, list(jobs), workers=workers, desc=desc, unit="fit"))


def gmm_fit_key(x, n_components: int, seed: int) -> str:
    """Identity of one `gmm_components` fit: sha256 of the features' bytes, shape and
    dtype, ``n_components``, ``seed`` and the scikit-learn and numpy versions (a fit
    is bit-reproducible for these)."""
    import hashlib

    import sklearn

    x = np.ascontiguousarray(_as_features(x, "gmm_fit_key"))
    digest = hashlib.sha256(f"{x.shape}|{x.dtype.str}|{int(n_components)}|{int(seed)}|"
                            f"sklearn {sklearn.__version__}|numpy {np.__version__}|".encode())
    digest.update(x.tobytes())
    return digest.hexdigest()


def cached_gmm_components_many(jobs, cache, workers: int = 1, desc: str | None = None) -> list:
    """`gmm_components_many` with the fits stored in the folder ``cache``.

    A fit is looked up by :func:`gmm_fit_key` (``<key>.npz``); the missing ones are
    fitted (in ``workers`` processes) and written atomically, so a second call on
    the same features returns the same mixtures bit for bit without fitting.
    ``cache=None`` fits everything and stores nothing.

    Returns
    -------
    list of (weights (K,), means (K, D), covariances (K, D, D)), in job order
    """
    from pathlib import Path

    jobs = list(jobs)
    if cache is None:
        return gmm_components_many(jobs, workers, desc)
    cache = Path(cache)
    paths = [cache / f"{gmm_fit_key(*job)}.npz" for job in jobs]
    out = [None] * len(jobs)
    for i, path in enumerate(paths):
        try:
            with np.load(path) as f:
                out[i] = (f["weights"], f["means"], f["covariances"])
        except (OSError, KeyError, ValueError):  # absent or unreadable: fitted again
            pass
    missing = [i for i, fit in enumerate(out) if fit is None]
    from blendvoca.io.atomic import atomic_write

    unwritable = None
    for i, fit in zip(missing, gmm_components_many([jobs[i] for i in missing], workers, desc)):
        out[i] = fit
        if unwritable is not None:
            continue
        try:
            with atomic_write(paths[i]) as f:
                np.savez(f, weights=fit[0], means=fit[1], covariances=fit[2])
        except OSError as error:  # a cache only saves time: a read-only home keeps the numbers
            unwritable = error
            import warnings

            warnings.warn(f"WInD: the fit cache {cache} cannot be written ({error}); the mixtures are fitted "
                          "without it (set BLENDVOCA_CACHE to a writable folder to keep them)", stacklevel=2)
    return out


def transport_cost(cost, a, b) -> float:
    """Optimal transport cost between discrete distributions (the WInD LP).

    Parameters
    ----------
    cost : (K, L) array_like
        Ground cost between atoms.
    a : (K,) array_like, b : (L,) array_like
        Non-negative weights, each summing to 1.

    Returns
    -------
    float
        ``min sum_ij P_ij cost_ij`` over ``P >= 0`` with row sums ``a`` and column sums ``b``.
    """
    cost = np.asarray(cost, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    k, l = cost.shape
    if a.shape != (k,) or b.shape != (l,):
        raise ValueError(f"transport_cost: cost {cost.shape} does not match weights {a.shape}, {b.shape}")
    if np.any(a < 0) or np.any(b < 0) or not np.isclose(a.sum(), 1.0) or not np.isclose(b.sum(), 1.0):
        raise ValueError(f"transport_cost: weights must be non-negative and sum to 1, got sums {a.sum()}, {b.sum()}")
    b = b * (a.sum() / b.sum())
    rows = np.kron(np.eye(k), np.ones((1, l)))
    cols = np.kron(np.ones((1, k)), np.eye(l))
    res = linprog(
        cost.ravel(),
        A_eq=np.vstack([rows, cols])[:-1],  # one constraint is redundant
        b_eq=np.concatenate([a, b])[:-1],
        bounds=(0, None),
        method="highs",
    )
    if not res.success:
        raise RuntimeError(f"transport_cost: LP failed: {res.message}")
    return float(res.fun)


def wind_from_gmms(gmm1, gmm2) -> float:
    """WInD between two fitted mixtures.

    Parameters
    ----------
    gmm1, gmm2 : tuple (weights (K,), means (K, D), covariances (K, D, D))

    Returns
    -------
    float
    """
    w1, m1, c1 = gmm1
    w2, m2, c2 = gmm2
    cost = np.array([[frechet_distance_from_stats(m1[i], c1[i], m2[j], c2[j]) for j in range(len(w2))]
                     for i in range(len(w1))])
    return transport_cost(cost, w1, w2)


def wind_scores(x, y, n_components: int = 5, repeats: int = 10, seed: int = 0, workers: int = 1) -> np.ndarray:
    """WInD of each repeat: repeat r fits both mixtures with seed ``seed + r``.

    ``workers``: processes for the fits (`gmm_components_many`; same result for any value).

    Returns
    -------
    (repeats,) ndarray
    """
    if repeats < 1:
        raise ValueError(f"wind: repeats must be >= 1, got {repeats}")
    x = _as_features(x, "wind (x)")
    y = _as_features(y, "wind (y)")
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"wind: feature dimensions differ: x {x.shape}, y {y.shape}")
    gmms = gmm_components_many([(data, n_components, seed + r) for r in range(repeats) for data in (x, y)],
                               workers)
    return np.array([wind_from_gmms(gmms[2 * r], gmms[2 * r + 1]) for r in range(repeats)])


def wind(x, y, n_components: int = 5, repeats: int = 10, seed: int = 0, workers: int = 1) -> tuple[float, float]:
    """WInD between two feature sets, mean and std over ``repeats`` GMM fits.

    Parameters
    ----------
    x : (N, D) array_like
    y : (M, D) array_like
    n_components : int
        Mixture components on each side (5 in the paper).
    repeats : int
        Number of fits with seeds ``seed, seed + 1, ...``.
    seed : int
    workers : int
        Processes for the GMM fits (the result does not depend on it).

    Returns
    -------
    mean : float
    std : float
        Sample standard deviation (ddof=1, as the published evaluation); 0.0 when
        ``repeats == 1``.
    """
    scores = wind_scores(x, y, n_components, repeats, seed, workers)
    std = float(np.std(scores, ddof=1)) if len(scores) > 1 else 0.0
    return float(np.mean(scores)), std
