"""Structure-exploiting interior-point solver for the temporally constrained fit.

The QP over a whole sentence (n = T K unknowns)::

    minimise   sum_t  1/2 u_t^T G u_t - c_t . u_t
    subject to lower <= u <= upper,  -rate_bound <= u_{t+1} - u_t <= rate_bound

has a block-diagonal Hessian ``kron(I_T, G)`` and rate constraints that only
couple a coefficient with itself in the next frame.  In a primal-dual
interior-point method (Mehrotra predictor-corrector) every Newton system is
therefore ``kron(I_T, G) + diag(.) + D^T diag(.) D``: a symmetric positive
definite *banded* matrix with half-bandwidth K.  One LAPACK banded Cholesky
(``pbtrf``, O(T K^3)) and two banded solves per iteration make the cost linear
in T, and the memory O(T K^2) (no n x n matrix ever exists).

The interior point runs until the active set can be read off its iterate
(scaled KKT residuals and mean complementarity below ``IDENTIFY_TOL``); that set
is then solved exactly and certified by the KKT conditions, with corrections
until the certificate holds (and a tighter interior point if it never does), so
the result is the optimum of the QP to solver precision, not an approximation of
it (the tests compare it with a dense exact solver).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.linalg.lapack import dpbtrf, dpbtrs

from blendvoca.errors import UserError

from ._checks import as_float_array, check_rate_bound, check_system
from ._renamed import renamed_keywords


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
        Multipliers of ``u_{t+1} - u_t <= rate_bound`` minus those of
        ``u_{t+1} - u_t >= -rate_bound`` (None without rate constraints).
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
        raise UserError(f"solve_banded_qp: {name} must be finite (use None for no bound)")
    return np.ascontiguousarray(array)


#: Largest fraction of rate constraints the clipped unconstrained track may break
#: for the active-set start to be tried before the interior point.
ACTIVE_SET_MAX_RATE = 0.02
#: Active-set corrections tried from that start.
ACTIVE_SET_ROUNDS = 10
#: Interior-point starting point (scaled units: Hessian diagonal <= 1, coefficients in [0, 1]).
START_SLACK = 0.1
START_DUAL = 0.1
#: Interior-point tolerance at which the polish first reads off the active set.
#: Iterating further rarely fixes the few ambiguous constraints (the
#: certificate's corrections do), so it would only add factorizations; a failed
#: certificate still tightens the interior point down to ``tol * 1e-6``.
IDENTIFY_TOL = 1e-5


class _Problem:
    """The scaled QP with its constraints ``A x + s = b, s >= 0`` in one flat vector.

    Constraint groups (each a contiguous slice of the flat vectors): ``lower``
    (A = -I), ``upper`` (A = I), ``rate+`` (A = D), ``rate-`` (A = -D); D is the
    forward difference over frames.  Slacks, multipliers and residuals of all
    groups live in flat arrays so that every interior-point operation is a few
    whole-array numpy calls.
    """

    def __init__(self, gram, rhs, lo, hi, rate_bound):
        self.num_frames, self.k = rhs.shape
        self.g = gram
        self.c = rhs
        size = rhs.size
        rate_size = (self.num_frames - 1) * self.k
        self.slices = {}
        parts = []
        offset = 0
        for name, bound, length in (
            ("lower", None if lo is None else -lo, size),
            ("upper", hi, size),
            ("rate+", None if rate_bound is None or self.num_frames < 2 else rate_bound, rate_size),
            ("rate-", None if rate_bound is None or self.num_frames < 2 else rate_bound, rate_size),
        ):
            if bound is None:
                continue
            self.slices[name] = slice(offset, offset + length)
            parts.append(np.broadcast_to(np.asarray(bound, dtype=np.float64).ravel(), (length,)))
            offset += length
        self.b = np.concatenate(parts) if parts else np.zeros(0)
        self.num_constraints = offset
        # Upper banded storage (K + 1, T K) of kron(I_T, G), Fortran order for LAPACK.
        k = self.k
        block = np.zeros((k + 1, k))
        rows, cols = np.triu_indices(k)
        block[k + rows - cols, cols] = gram[rows, cols]
        self.band_g = np.asfortranarray(np.tile(block, (1, self.num_frames)))
        self._work = np.empty_like(self.band_g, order="F")

    @property
    def groups(self):
        """Names of the constraint groups present."""
        return tuple(self.slices)

    def part(self, flat, name):
        """View of group ``name`` of a flat constraint vector, shaped (T, K) or (T-1, K)."""
        return flat[self.slices[name]].reshape(-1, self.k)

    def apply(self, x):
        """``A x`` as a flat vector."""
        out = np.empty(self.num_constraints)
        s = self.slices
        if "lower" in s:
            np.negative(x.ravel(), out=out[s["lower"]])
        if "upper" in s:
            out[s["upper"]] = x.ravel()
        if "rate+" in s:
            d = out[s["rate+"]].reshape(-1, self.k)
            np.subtract(x[1:], x[:-1], out=d)
            np.negative(d.ravel(), out=out[s["rate-"]])
        return out

    def apply_t(self, y):
        """``A^T y`` as a (T, K) array."""
        s = self.slices
        out = np.zeros((self.num_frames, self.k))
        if "lower" in s:
            out -= self.part(y, "lower")
        if "upper" in s:
            out += self.part(y, "upper")
        if "rate+" in s:
            v = self.part(y, "rate+") - self.part(y, "rate-")
            out[1:] += v
            out[:-1] -= v
        return out

    def factor(self, weights):
        """Banded Cholesky of ``kron(I, G) + A^T diag(weights) A`` (weights flat)."""
        k = self.k
        s = self.slices
        ab = self._work
        ab[...] = self.band_g
        diag = np.zeros((self.num_frames, k))
        if "lower" in s:
            diag += self.part(weights, "lower")
        if "upper" in s:
            diag += self.part(weights, "upper")
        if "rate+" in s:
            v = self.part(weights, "rate+") + self.part(weights, "rate-")
            diag[:-1] += v
            diag[1:] += v
            ab[0, k:] = -v.ravel()
        # A tiny ridge keeps the factorization defined for a singular G with an
        # unconstrained coefficient; it is far below every tolerance used here.
        diag += 1e-13
        ab[k] += diag.ravel()
        chol, info = dpbtrf(ab, lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded Cholesky failed (info={info})")
        return chol

    def solve(self, chol, vec):
        x, info = dpbtrs(chol, vec.ravel(), lower=0, overwrite_b=1)
        if info != 0:  # pragma: no cover - dpbtrs only fails on bad arguments
            raise np.linalg.LinAlgError(f"banded solve failed (info={info})")
        return x.reshape(self.num_frames, self.k)

    def residual(self, x):
        """``A x - b`` (<= 0 where feasible), flat."""
        out = self.apply(x)
        out -= self.b
        return out


def _least_squares(gram, rhs):
    """``G^-1 c_t`` for every frame (a tiny ridge for a singular G)."""
    k = gram.shape[0]
    factor = cho_factor(gram + 1e-12 * np.eye(k), check_finite=False)
    return cho_solve(factor, rhs.T, check_finite=False).T


def _clip(x, lo, hi):
    if lo is not None:
        x = np.maximum(x, lo)
    if hi is not None:
        x = np.minimum(x, hi)
    return x


def _active_set_guess(prob, x_free, x_clipped):
    """Active constraints guessed from the unconstrained and the clipped solution.

    Returns None when the guess is unlikely to be close (more than
    ``ACTIVE_SET_MAX_RATE`` of the rate constraints broken by the clipped
    track): the interior point then goes first.
    """
    active = np.zeros(prob.num_constraints, dtype=bool)
    fixed = np.zeros(x_free.shape, dtype=bool)
    for name in ("lower", "upper"):
        if name in prob.slices:
            part = prob.part(active, name)
            part[...] = prob.part(prob.residual(x_free), name) > 0.0
            fixed |= part
    if "rate+" in prob.slices:
        broken = prob.residual(x_clipped) > 0.0
        free_edge = ~(fixed[1:] & fixed[:-1])
        rate_broken = 0
        for name in ("rate+", "rate-"):
            part = prob.part(active, name)
            part[...] = prob.part(broken, name) & free_edge
            rate_broken += int(part.sum())
        if rate_broken > ACTIVE_SET_MAX_RATE * free_edge.size:
            return None
    return active


def _step_to_boundary(values, steps):
    """Largest alpha in (0, 1] with ``values + alpha * steps >= 0`` (flat arrays)."""
    if steps.size == 0:
        return 1.0
    # values > 0: the binding ratio is the most negative steps / values.
    worst = -float(np.min(np.divide(steps, values)))
    return 1.0 if worst <= 1.0 else 1.0 / worst


def _interior_point(prob, x, tol, max_iter, slacks=None, duals=None):
    """Mehrotra predictor-corrector iterations; returns x, slacks, duals, its, kkt.

    The constraint-length vectors (slacks, multipliers, steps, residuals) are
    the bulk of the work outside the banded factorization, so each iteration
    updates them in place in preallocated buffers.
    """
    if slacks is None:
        # Slacks of the warm start kept away from zero, small uniform
        # multipliers: the fewest iterations on speech tracks (scaled problem).
        slacks = np.maximum(-prob.residual(x), START_SLACK)
        duals = np.full_like(slacks, START_DUAL)
    else:
        slacks, duals = slacks.copy(), duals.copy()
    m = prob.num_constraints
    norm_c = 1.0 + float(np.max(np.abs(prob.c)))
    kkt = np.inf
    its = 0
    inv_s = np.empty(m)
    r_c = np.empty(m)
    work = np.empty(m)
    ds = np.empty(m)
    dz = np.empty(m)
    for its in range(max_iter + 1):
        r_d = x @ prob.g - prob.c + prob.apply_t(duals)
        r_p = prob.residual(x)
        r_p += slacks
        gap = float(slacks @ duals)
        mu = gap / m
        kkt = max(float(np.max(np.abs(r_d))) / norm_c, float(np.max(np.abs(r_p))), mu)
        if kkt <= tol or its == max_iter:
            break
        np.divide(1.0, slacks, out=inv_s)
        np.multiply(duals, inv_s, out=work)
        try:
            chol = prob.factor(work)
        except np.linalg.LinAlgError:
            break
        z_rp = duals * r_p

        def newton(r_c):
            # (G + A^T W A) dx = -r_d - A^T ((z r_p - r_c) / s); ds, dz follow.
            np.subtract(z_rp, r_c, out=work)
            np.multiply(work, inv_s, out=work)
            dx = prob.solve(chol, -r_d - prob.apply_t(work))
            np.negative(r_p, out=ds)
            np.subtract(ds, prob.apply(dx), out=ds)
            np.multiply(duals, ds, out=dz)
            np.add(dz, r_c, out=dz)
            np.multiply(dz, inv_s, out=dz)
            np.negative(dz, out=dz)
            return dx

        np.multiply(slacks, duals, out=r_c)
        newton(r_c)
        alpha_a = min(_step_to_boundary(slacks, ds), _step_to_boundary(duals, dz))
        # gap after the affine step: sum (s + a ds)(z + a dz), expanded.
        gap_a = gap + alpha_a * (float(ds @ duals) + float(slacks @ dz)) + alpha_a ** 2 * float(ds @ dz)
        sigma = (max(gap_a, 0.0) / gap) ** 3 if gap > 0 else 0.0
        np.multiply(ds, dz, out=work)
        r_c += work
        r_c -= sigma * mu
        dx = newton(r_c)
        alpha = min(
            1.0, 0.995 * _step_to_boundary(slacks, ds), 0.995 * _step_to_boundary(duals, dz)
        )
        x = x + alpha * dx
        ds *= alpha
        slacks += ds
        dz *= alpha
        duals += dz
    return x, slacks, duals, its, kkt


def _without_conflicts(prob, active):
    """Drop active rate constraints between two bound-active coefficients.

    Both ends are fixed already; keeping the rate equality as well would make
    the equality-constrained problem over-determined (or infeasible).
    """
    if "rate+" not in prob.slices:
        return active
    fixed = np.zeros((prob.num_frames, prob.k), dtype=bool)
    for name in ("lower", "upper"):
        if name in prob.slices:
            fixed |= prob.part(active, name)
    both = fixed[1:] & fixed[:-1]
    prob.part(active, "rate+")[both] = False
    prob.part(active, "rate-")[both] = False
    return active


def _polish(prob, active, multipliers, *, rho=1e5, max_alm=40, max_rounds=10, feas_tol=1e-9,
            drop_conflicts=False):
    """Exact solution for a guessed active set, corrected until the KKT conditions hold.

    With the active constraints as equalities, the QP is solved by the
    augmented Lagrangian method, whose Hessian ``kron(I, G) + rho A^T A`` has the
    same band as the interior-point systems (one factorization, a few banded
    solves); its fixed point is the exact equality-constrained minimiser.
    The candidate is then checked: every constraint feasible, every active
    multiplier non-negative.  Violated constraints join the active set and
    negative multipliers leave it (a primal-dual active-set correction) until
    the checks pass.  With ``drop_conflicts`` (a rough starting guess), rate
    constraints between two bound-active coefficients leave the set after
    every correction.

    Returns
    -------
    x : (T, K) ndarray or None
        The certified optimum, or None when no certified point was found.
    multipliers : (m,) ndarray
    rounds : int
    """
    dual_tol = 1e-10 * (1.0 + float(np.max(np.abs(prob.c))))
    for rounds in range(1, max_rounds + 1):
        # The active set as a 0/1 float vector: multiplying by it is several
        # times faster than boolean-mask indexing on the constraint vectors.
        on = active.astype(np.float64)
        weights = rho * on
        try:
            chol = prob.factor(weights)
        except np.linalg.LinAlgError:
            return None, multipliers, rounds
        lam = np.maximum(multipliers, 0.0)
        lam *= on
        wb = weights * prob.b
        x = None
        for _ in range(max_alm):
            x = prob.solve(chol, prob.c - prob.apply_t(lam - wb))
            r = prob.residual(x)
            r *= on
            worst = float(np.max(np.abs(r), initial=0.0))
            r *= rho
            lam += r
            if worst <= 1e-14:
                break
        residual = prob.residual(x)
        violated = ~active & (residual > feas_tol)
        negative = active & (lam < -dual_tol)
        multipliers = lam
        if not violated.any() and not negative.any():
            return x, lam, rounds
        active = (active | violated) & ~negative
        if drop_conflicts:
            active = _without_conflicts(prob, active)
    return None, multipliers, max_rounds


@renamed_keywords(delta="rate_bound")
def solve_banded_qp(
    gram,
    rhs,
    *,
    lower=0.0,
    upper=1.0,
    rate_bound=0.1,
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
    rate_bound : float or None, optional
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
    gram, rhs = check_system(gram, rhs, where)
    rate_bound = check_rate_bound(rate_bound, where)
    lo = _broadcast_bound(lower, rhs.shape, "lower")
    hi = _broadcast_bound(upper, rhs.shape, "upper")
    if lo is not None and hi is not None and np.any(lo > hi):
        raise UserError(f"{where}: every lower bound must not exceed its upper bound")

    # Scale the objective so that the Hessian diagonal is at most 1: tolerances
    # are then meaningful whatever the mesh units (metres give ~1e-3 entries).
    scale = float(np.max(np.abs(np.diag(gram)))) or 1.0
    prob = _Problem(0.5 * (gram + gram.T) / scale, rhs / scale, lo, hi, rate_bound)

    # The unconstrained minimiser u_t = G^-1 c_t of every frame, from the one
    # K x K Cholesky factor of G: the warm start and the active-set guess.
    x_free = _least_squares(prob.g, prob.c)
    if warm_start is not None:
        x0 = as_float_array(warm_start, "warm_start", 2, where).copy()
        if x0.shape != rhs.shape:
            raise UserError(f"{where}: warm_start must be {rhs.shape}, got {x0.shape}")
    else:
        x0 = x_free
    x0 = _clip(x0, lo, hi)
    if not prob.groups:
        return QPSolution(x_free, 0, True, None, None, None, 0.0, "banded-ipm")

    def solution(x, multipliers, its, converged, kkt, solver):
        x = _clip(x, lo, hi)

        def scaled(name):
            return prob.part(multipliers, name) * scale if name in prob.slices else None

        rate_mult = scaled("rate+") - scaled("rate-") if "rate+" in prob.slices else None
        return QPSolution(x, its, converged, scaled("lower"), scaled("upper"), rate_mult, kkt, solver)

    if polish:
        # Speech tracks mostly sit on the lower bound and rarely hit the rate
        # limit: then the active set read off the clipped unconstrained
        # solution is nearly right, and a few certified active-set corrections
        # (one banded factorization each) replace the interior point.
        guess = _active_set_guess(prob, x_free, x0)
        if guess is not None and not guess.any():
            # Nothing broken: the unconstrained minimiser is the optimum.
            return solution(x_free, np.zeros(prob.num_constraints), 0, True, 0.0, "least-squares")
        if guess is not None:
            x_pol, lam, _ = _polish(prob, guess, np.zeros(prob.num_constraints),
                                    max_rounds=ACTIVE_SET_ROUNDS, drop_conflicts=True)
            if x_pol is not None:
                return solution(x_pol, lam, 0, True, 0.0, "banded-active-set")

    total_its = 0
    first_tol = max(tol, IDENTIFY_TOL) if polish else tol
    x, slacks, duals, its, kkt = _interior_point(prob, x0, first_tol, max_iter)
    total_its += its
    converged = kkt <= tol
    solver = "banded-ipm"
    multipliers = duals
    if polish:
        # The active set is guessed from the interior point iterate; when the
        # certificate fails, tighten the interior point and guess again.
        for tighter in sorted({first_tol, tol, tol * 1e-3, tol * 1e-6}, reverse=True):
            if tighter < first_tol:
                x, slacks, duals, its, kkt = _interior_point(prob, x, tighter, max_iter, slacks, duals)
                total_its += its
            active = duals > slacks
            x_pol, lam, _ = _polish(prob, active, duals)
            if x_pol is not None:
                x, multipliers, converged, solver = x_pol, lam, True, "banded-ipm+polish"
                kkt = 0.0
                break
            multipliers = duals
    return solution(x, multipliers, total_its, converged, kkt, solver)
