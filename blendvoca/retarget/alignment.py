"""Similarity alignment (scale, rotation, translation) from landmark pairs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blendvoca.errors import UserError

from ._checks import as_vertices


@dataclass(frozen=True)
class Similarity:
    """``x -> scale * rotation @ x + translation`` and how well it fits the landmarks.

    Attributes
    ----------
    scale : float
    rotation : (3, 3) float64 ndarray
        Proper rotation (determinant +1).
    translation : (3,) float64 ndarray
    residuals : (N,) float64 ndarray
        Distance from each transformed source landmark to its target landmark,
        in the target's units.
    """

    scale: float
    rotation: np.ndarray
    translation: np.ndarray
    residuals: np.ndarray

    @property
    def linear(self) -> np.ndarray:
        """The (3, 3) linear part ``scale * rotation``."""
        return self.scale * self.rotation

    @property
    def rms_residual(self) -> float:
        """Root mean square landmark residual."""
        return float(np.sqrt(np.mean(self.residuals**2)))

    @property
    def max_residual(self) -> float:
        """Largest landmark residual."""
        return float(self.residuals.max())

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform ``(..., 3)`` points."""
        return np.asarray(points, dtype=np.float64) @ self.linear.T + self.translation

    def apply_vectors(self, vectors: np.ndarray) -> np.ndarray:
        """Transform ``(..., 3)`` displacement vectors (no translation)."""
        return np.asarray(vectors, dtype=np.float64) @ self.linear.T


def similarity_transform(source_points: np.ndarray, target_points: np.ndarray) -> Similarity:
    """Least-squares similarity taking ``source_points`` onto ``target_points`` (Umeyama 1991).

    Parameters
    ----------
    source_points, target_points : (N, 3) float ndarray
        Corresponding landmarks, N >= 3 and not collinear.

    Returns
    -------
    Similarity
        Minimises ``sum ||s R p_i + t - q_i||^2`` over ``s > 0``, proper rotations
        ``R`` and ``t``; carries the per-landmark residuals of that fit.
    """
    P = as_vertices(source_points, "similarity_transform", name="source_points")
    Q = as_vertices(target_points, "similarity_transform", name="target_points")
    if P.shape != Q.shape:
        raise UserError(
            f"similarity_transform: source_points {P.shape} and target_points {Q.shape} must pair up"
        )
    if len(P) < 3:
        raise UserError(f"similarity_transform: need at least 3 landmark pairs, got {len(P)}")
    mp, mq = P.mean(axis=0), Q.mean(axis=0)
    Pc, Qc = P - mp, Q - mq
    var_p = np.sum(Pc**2) / len(P)
    cov = Qc.T @ Pc / len(P)
    U, S, Vt = np.linalg.svd(cov)
    if var_p <= 0 or S[1] <= 1e-12 * max(S[0], 1e-300):
        raise UserError("similarity_transform: landmarks are coincident or collinear; the rotation is undetermined")
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0
    R = U @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / var_p)
    t = mq - s * R @ mp
    residuals = np.linalg.norm(P @ (s * R).T + t - Q, axis=1)
    return Similarity(scale=s, rotation=R, translation=t, residuals=residuals)
