"""Structure-exploiting interior-point solver for the temporally constrained fit.

The QP over a whole sentence (n = T K unknowns)::

    minimise   sum_t  1/2 u_t^T G u_t - c_t . u_t
    subject to lower <= u <= upper,  -delta <= u_{t+1} - u_t <= delta

has a block-diagonal Hessian ``kron(I_T, G)`` and rate constraints that only
couple a coefficient with itself in the next frame.  In a primal-dual
interior-point method (Mehrotra predictor-corrector) every Newton system is
therefore ``kron(I_T, G) + diag(.) + D^T diag(.) D``: a symmetric positive
definite *banded* matrix with half-bandwidth K.  One LAPACK banded Cholesky
(``pbtrf``, O(T K^3)) and two banded solves per iteration make the cost linear
in T, and the memory O(T K^2) (no n x n matrix ever exists).

The interior-point iterates are driven to a relative duality gap and KKT
residual of ``tol`` (1e-10 by default), so the result is the optimum of the QP to
solver precision, not an approximation of it (the tests compare it with a dense
exact solver).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dpbtrf, dpbtrs

from ._checks import as_float_array, check_delta


@dataclass(frozen=True)
class QPSolution:
    """Solution of the temporally constrained QP and its certificates.

    Attributes
    ----------
    coeffs : (T, K) ndarray
        The minimiser.
    iterations : int
        Interior-point iterations used.
    converged : bool
        Whether the KKT residuals reached the tolerance.
    lower_multipliers, upper_multipliers : (T, K) ndarray or None
        Lagrange multipliers of the bound constraints (None without bounds).
    rate_multipliers : (T - 1, K) ndarray or None
        Multipliers of ``u_{t+1} - u_t <= delta`` minus those of
        ``u_{t+1} - u_t >= -delta`` (None without rate constraints).
    kkt_residual : float
        Max of the scaled stationarity, feasibility and complementarity residuals.
    solver : str
        Name of the method that produced it.
    """

    coeffs: np.ndarray
    iterations: int
    converged: bool
    lower_multipliers: np.ndarray | None
    upper_multipliers: np.ndarray | None
    rate_multipliers: np.ndarray | None
    kkt_residual: float
    solver: str


def _broadcast_bound(value, shape, name):
    if value is None:
        return None
    array = np.broadcast_to(np.asarray(value, dtype=np.float64), shape)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"solve_banded_qp: {name} must be finite (use None for no bound)")
    return np.ascontiguousarray(array)


def _diff(x):
    return x[1:] - x[:-1]


def _diff_t(y):
    """``D^T y`` for the forward-difference operator D: (T-1, K) -> (T, K)."""
    out = np.zeros((y.shape[0] + 1, y.shape[1]))
    out[1:] += y
    out[:-1] -= y
    return out


class _Problem:
    """The scaled QP with its constraint groups ``A_g x + s_g = b_g, s_g >= 0``.

    Groups: ``lower`` (A = -I), ``upper`` (A = I), ``rate+`` (A = D),
    ``rate-`` (A = -D); D is the forward difference over frames.
    """

    def __init__(self, gram, rhs, lo, hi, delta):
        self.num_frames, self.k = rhs.shape
        self.g = gram
        self.c = rhs
        self.groups = {}
        if lo is not None:
            self.groups["lower"] = -lo
        if hi is not None:
            self.groups["upper"] = hi
        if delta is not None and self.num_frames > 1:
            b_rate = np.full((self.num_frames - 1, self.k), delta)
            self.groups["rate+"] = b_rate
            self.groups["rate-"] = b_rate
        # Upper banded storage (K + 1, T K) of kron(I_T, G), built once.
        k = self.k
        block = np.zeros((k + 1, k))
        rows, cols = np.triu_indices(k)
        block[k + rows - cols, cols] = gram[rows, cols]
        self.band_g = np.tile(block, (1, self.num_frames))

    @staticmethod
    def apply(name, x):
        if name == "lower":
            return -x
        if name == "upper":
            return x
        if name == "rate+":
            return _diff(x)
        return -_diff(x)

    @staticmethod
    def apply_t(name, y):
        if name == "lower":
            return -y
        if name == "upper":
            return y
        if name == "rate+":
            return _diff_t(y)
        return -_diff_t(y)

    def factor(self, weights):
        """Banded Cholesky of ``kron(I, G) + sum_g A_g^T diag(w_g) A_g``."""
        k = self.k
        ab = self.band_g.copy()
        diag = np.zeros((self.num_frames, k))
        for name in ("lower", "upper"):
            if name in weights:
                diag += weights[name]
        if "rate+" in weights:
            v = weights["rate+"] + weights["rate-"]
            diag[:-1] += v
            diag[1:] += v
            ab[0, k:] = -v.ravel()
        # A tiny ridge keeps the factorization defined for a singular G with an
        # unconstrained coefficient; it is far below every tolerance used here.
        ab[k] += diag.ravel() + 1e-13
        chol, info = dpbtrf(np.asfortranarray(ab), lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded Cholesky failed (info={info})")
        return chol

    def solve(self, chol, vec):
        x, info = dpbtrs(chol, vec.ravel(), lower=0)
        if info != 0:  # pragma: no cover - dpbtrs only fails on bad arguments
            raise np.linalg.LinAlgError(f"banded solve failed (info={info})")
        return x.reshape(self.num_frames, self.k)

    def residual(self, name, x):
        """``A_g x - b_g`` (<= 0 when feasible)."""
        return self.apply(name, x) - self.groups[name]


def _step_to_boundary(values, steps):
    """Largest alpha in (0, 1] with ``values + alpha * steps >= 0`` for all groups."""
    alpha = 1.0
    for v, d in zip(values, steps):
        ratios = np.where(d < 0, v / np.where(d < 0, -d, 1.0), np.inf)
        alpha = min(alpha, float(ratios.min()))
    return alpha


def _interior_point(prob, x, tol, max_iter):
    """Mehrotra predictor-corrector iterations; returns x, slacks, duals, its, kkt."""
    names = list(prob.groups)
    slacks = {n: np.maximum(-prob.residual(n, x), 1e-2) for n in names}
    duals = {n: np.ones_like(s) for n, s in slacks.items()}
    num_constraints = sum(s.size for s in slacks.values())
    norm_c = 1.0 + float(np.max(np.abs(prob.c)))
    kkt = np.inf
    its = 0
    for its in range(max_iter + 1):
        r_d = x @ prob.g - prob.c
        for n in names:
            r_d = r_d + prob.apply_t(n, duals[n])
        r_p = {n: prob.residual(n, x) + slacks[n] for n in names}
        gap = sum(float(np.vdot(slacks[n], duals[n])) for n in names)
        mu = gap / num_constraints
        kkt = max(
            float(np.max(np.abs(r_d))) / norm_c,
            max(float(np.max(np.abs(r))) for r in r_p.values()),
            mu,
        )
        if kkt <= tol or its == max_iter:
            break
        try:
            chol = prob.factor({n: duals[n] / slacks[n] for n in names})
        except np.linalg.LinAlgError:
            break

        def newton(r_c):
            # (G + A^T W A) dx = -r_d - A^T ((z r_p - r_c) / s); ds, dz follow.
            rhs_x = -r_d
            for n in names:
                rhs_x = rhs_x - prob.apply_t(n, (duals[n] * r_p[n] - r_c[n]) / slacks[n])
            dx = prob.solve(chol, rhs_x)
            ds = {n: -r_p[n] - prob.apply(n, dx) for n in names}
            dz = {n: -(r_c[n] + duals[n] * ds[n]) / slacks[n] for n in names}
            return dx, ds, dz

        r_c = {n: slacks[n] * duals[n] for n in names}
        _, ds_a, dz_a = newton(r_c)
        alpha_a = min(
            _step_to_boundary(slacks.values(), ds_a.values()),
            _step_to_boundary(duals.values(), dz_a.values()),
        )
        gap_a = sum(
            float(np.vdot(slacks[n] + alpha_a * ds_a[n], duals[n] + alpha_a * dz_a[n]))
            for n in names
        )
        sigma = (gap_a / gap) ** 3 if gap > 0 else 0.0
        r_c = {n: r_c[n] + ds_a[n] * dz_a[n] - sigma * mu for n in names}
        dx, ds, dz = newton(r_c)
        alpha = min(
            1.0,
            0.995 * _step_to_boundary(slacks.values(), ds.values()),
            0.995 * _step_to_boundary(duals.values(), dz.values()),
        )
        x = x + alpha * dx
        slacks = {n: slacks[n] + alpha * ds[n] for n in names}
        duals = {n: duals[n] + alpha * dz[n] for n in names}
    return x, slacks, duals, its, kkt


def _polish(prob, active, multipliers, *, rho=1e5, max_alm=40, max_rounds=10, feas_tol=1e-9):
    """Exact solution for a guessed active set, corrected until the KKT conditions hold.

    With the active constraints as equalities, the QP is solved by the
    augmented Lagrangian method, whose Hessian ``kron(I, G) + rho A^T A`` has the
    same band as the interior-point systems (one factorization, a few banded
    solves); its fixed point is the exact equality-constrained minimiser.
    The candidate is then checked: every constraint feasible, every active
    multiplier non-negative.  Violated constraints join the active set and
    negative multipliers leave it (a primal-dual active-set correction) until
    the checks pass.

    Returns
    -------
    x : (T, K) ndarray or None
        The certified optimum, or None when no certified point was found.
    multipliers : dict
    rounds : int
    """
    names = list(prob.groups)
    dual_tol = 1e-10 * (1.0 + float(np.max(np.abs(prob.c))))
    for rounds in range(1, max_rounds + 1):
        weights = {n: rho * active[n] for n in names}
        try:
            chol = prob.factor(weights)
        except np.linalg.LinAlgError:
            return None, multipliers, rounds
        lam = {n: np.where(active[n], np.maximum(multipliers[n], 0.0), 0.0) for n in names}
        x = None
        for _ in range(max_alm):
            rhs = prob.c.copy()
            for n in names:
                rhs -= prob.apply_t(n, lam[n] - weights[n] * prob.groups[n])
            x = prob.solve(chol, rhs)
            eq_violation = 0.0
            for n in names:
                r = np.where(active[n], prob.residual(n, x), 0.0)
                lam[n] = lam[n] + rho * r
                eq_violation = max(eq_violation, float(np.max(np.abs(r))))
            if eq_violation <= 1e-14:
                break
        violated = {n: (~active[n]) & (prob.residual(n, x) > feas_tol) for n in names}
        negative = {n: active[n] & (lam[n] < -dual_tol) for n in names}
        multipliers = lam
        if not any(v.any() for v in violated.values()) and not any(
            v.any() for v in negative.values()
        ):
            return x, lam, rounds
        active = {n: (active[n] | violated[n]) & ~negative[n] for n in names}
    return None, multipliers, max_rounds


def solve_banded_qp(
    gram,
    rhs,
    *,
    lower=0.0,
    upper=1.0,
    delta=0.1,
    warm_start=None,
    tol: float = 1e-8,
    max_iter: int = 60,
    polish: bool = True,
) -> QPSolution:
    """Solve the temporally constrained blendshape QP by a banded interior-point method.

    Parameters
    ----------
    gram : (K, K) array_like
        Symmetric positive (semi)definite Hessian block ``B^T B``.
    rhs : (T, K) array_like
        Linear terms ``c_t = B^T (p_t - n)``.
    lower, upper : float or (T, K) array_like or None, optional
        Box bounds on the coefficients; None drops that bound.
    delta : float or None, optional
        Bound on ``|u_{t+1} - u_t|``; None drops the rate constraints.
    warm_start : (T, K) array_like, optional
        Initial primal point (moved into the interior).
    tol : float, optional
        Interior-point stopping tolerance (scaled KKT residuals and mean
        complementarity) before polishing.
    max_iter : int, optional
        Interior-point iteration limit.
    polish : bool, optional
        Identify the active set and return the exact optimum for it, certified
        by the KKT conditions (falls back to more interior-point iterations,
        then to the interior-point iterate, when the certificate fails).

    Returns
    -------
    QPSolution
    """
    where = "solve_banded_qp"
    gram = as_float_array(gram, "gram", 2, where)
    rhs = as_float_array(rhs, "rhs", 2, where)
    num_frames, k = rhs.shape
    if gram.shape != (k, k):
        raise ValueError(
            f"{where}: gram must be ({k}, {k}) to match rhs {rhs.shape}, got {gram.shape}"
        )
    delta = check_delta(delta, where)
    lo = _broadcast_bound(lower, rhs.shape, "lower")
    hi = _broadcast_bound(upper, rhs.shape, "upper")
    if lo is not None and hi is not None and np.any(lo > hi):
        raise ValueError(f"{where}: every lower bound must not exceed its upper bound")

    # Scale the objective so that the Hessian diagonal is at most 1: tolerances
    # are then meaningful whatever the mesh units (metres give ~1e-3 entries).
    scale = float(np.max(np.abs(np.diag(gram)))) or 1.0
    prob = _Problem(0.5 * (gram + gram.T) / scale, rhs / scale, lo, hi, delta)

    if warm_start is not None:
        x0 = as_float_array(warm_start, "warm_start", 2, where).copy()
        if x0.shape != rhs.shape:
            raise ValueError(f"{where}: warm_start must be {rhs.shape}, got {x0.shape}")
    else:
        x0 = np.linalg.solve(prob.g + 1e-12 * np.eye(k), prob.c.T).T
    if lo is not None:
        x0 = np.maximum(x0, lo)
    if hi is not None:
        x0 = np.minimum(x0, hi)
    if not prob.groups:
        x = prob.solve(prob.factor({}), prob.c)
        return QPSolution(x, 0, True, None, None, None, 0.0, "banded-ipm")

    total_its = 0
    x, slacks, duals, its, kkt = _interior_point(prob, x0, tol, max_iter)
    total_its += its
    converged = kkt <= tol
    solver = "banded-ipm"
    multipliers = duals
    if polish:
        # The active set is guessed from the interior point iterate; when the
        # certificate fails, tighten the interior point and guess again.
        for tighter in (tol, tol * 1e-3, tol * 1e-6):
            if tighter < tol:
                x, slacks, duals, its, kkt = _interior_point(prob, x, tighter, max_iter)
                total_its += its
            active = {n: duals[n] > slacks[n] for n in prob.groups}
            x_pol, lam, _ = _polish(prob, active, duals)
            if x_pol is not None:
                x, multipliers, converged, solver = x_pol, lam, True, "banded-ipm+polish"
                kkt = 0.0
                break
            multipliers = duals
    if lo is not None:
        x = np.maximum(x, lo)
    if hi is not None:
        x = np.minimum(x, hi)
    lower_mult = multipliers["lower"] * scale if "lower" in multipliers else None
    upper_mult = multipliers["upper"] * scale if "upper" in multipliers else None
    rate_mult = (
        (multipliers["rate+"] - multipliers["rate-"]) * scale if "rate+" in multipliers else None
    )
    return QPSolution(x, total_its, converged, lower_mult, upper_mult, rate_mult, kkt, solver)
