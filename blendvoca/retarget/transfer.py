"""Deformation transfer (Sumner and Popovic 2004, section 4): one factorization, many solves.

For every target triangle paired with source triangles, the target's deformation
gradient is asked to equal each partner's; unpaired target triangles are asked to
stay undeformed (identity). The unknowns are the displacements of the target
vertices (the fourth vertices are eliminated exactly), one coordinate at a time
with the same matrix, so a target needs one sparse Cholesky factorization and every
blendshape is three right-hand sides of it. Solving for displacements from ``Q - I`` makes a neutral
source give an exactly zero (neutral) target.

Translation is not determined by gradients: every connected piece of the target
that has no fixed vertex is pinned at one vertex for the solve, then shifted by
`anchored_deltas` to agree best with a reference displacement (the source's own
displacement at the corresponding points).
"""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np
import scipy.sparse as sp

from blendvoca.errors import DataError

from ._checks import as_faces, as_indices, as_vertices
from .crop import connected_pieces
from .deformation_gradient import deformation_gradient_operator


@dataclass(frozen=True)
class TransferSystem:
    """A factorized deformation-transfer system for one target mesh and one correspondence.

    Attributes
    ----------
    n_vertices : int
        Target vertex count ``Vt``.
    n_source_faces : int
        Source face count ``Fs`` the correspondence refers to.
    pairs : (P, 2) int64 ndarray
        ``(source_face, target_face)`` correspondence.
    gather : (Ft, P) scipy.sparse.csr_matrix
        Sums, per target face, the source gradients of its partners.
    projected_operator : (3 Ft, Vt) scipy.sparse.csr_matrix
        The deformation-gradient operator with the fourth vertices eliminated.
    free : (N,) int64 ndarray
        Vertices solved for.
    factor : igl.min_quad_with_fixed_data
        Cholesky factors of the reduced normal matrix with the fixed vertices eliminated.
    pieces : (Vt,) int64 ndarray
        Connected piece of each target vertex whose translation is free (to be set by
        `anchored_deltas`), -1 where fixed vertices already determine it.
    """

    n_vertices: int
    n_source_faces: int
    pairs: np.ndarray
    gather: sp.csr_matrix
    projected_operator: sp.csr_matrix
    free: np.ndarray
    factor: igl.min_quad_with_fixed_data
    pieces: np.ndarray


def transfer_system(
    target_vertices: np.ndarray,
    target_faces: np.ndarray,
    pairs: np.ndarray,
    n_source_faces: int,
    *,
    fixed_vertices: np.ndarray | None = None,
    unpaired_weight: float = 1.0,
) -> TransferSystem:
    """Build and factorize the deformation-transfer system of a target.

    The energy is ``sum_f n_f ||Q_f(x) - mean of f's partners' Q||^2`` (``n_f`` the
    number of partners, or 1 and the identity for an unpaired face), which equals the
    paper's sum over pairs up to a constant. Every fourth vertex appears only in its
    own face's rows, so it is eliminated face by face (a Schur complement): the
    remaining system is over vertices only, with the sparsity of the mesh.

    Parameters
    ----------
    target_vertices : (Vt, 3) float ndarray
        Target rest shape.
    target_faces : (Ft, 3) int ndarray
    pairs : (P, 2) int ndarray
        ``(source_face, target_face)`` from `triangle_correspondence`.
    n_source_faces : int
        Face count of the source the pairs index.
    fixed_vertices : (N,) int ndarray, optional
        Target vertices that keep zero displacement in every shape (for example
        pieces with no counterpart on the source). Vertices in no face are always fixed.
    unpaired_weight : float
        Weight of the identity asked of every unpaired face, against 1 per pair.

    Returns
    -------
    TransferSystem
    """
    where = "transfer_system"
    Vt = as_vertices(target_vertices, where, name="target_vertices")
    Ft = as_faces(target_faces, len(Vt), where, name="target_faces")
    P = np.asarray(pairs)
    if P.ndim != 2 or P.shape[1] != 2:
        raise ValueError(f"{where}: expected pairs of shape (P, 2), got {P.shape}")
    if P.size and not np.issubdtype(P.dtype, np.integer):
        raise TypeError(f"{where}: expected integer pairs, got dtype {P.dtype}")
    P = P.astype(np.int64)
    if P.size and (P[:, 0].min() < 0 or P[:, 0].max() >= n_source_faces or P[:, 1].min() < 0 or P[:, 1].max() >= len(Ft)):
        raise ValueError(
            f"{where}: pairs index source faces up to {P[:, 0].max()} (of {n_source_faces}) "
            f"and target faces up to {P[:, 1].max()} (of {len(Ft)})"
        )
    nv, nf = len(Vt), len(Ft)
    fixed = np.zeros(nv, dtype=bool)
    if fixed_vertices is not None:
        fixed[as_indices(fixed_vertices, nv, where, name="fixed_vertices")] = True
    used = np.zeros(nv, dtype=bool)
    used[Ft.ravel()] = True
    fixed |= ~used

    A = deformation_gradient_operator(Vt, Ft).tocsc()
    Av, aw = A[:, :nv], A[:, nv:]
    # column f of aw holds the fourth vertex's coefficients a_f (3,) in rows 3f..3f+2
    a = np.asarray(aw.sum(axis=1)).reshape(nf, 3)
    a_hat = a / np.linalg.norm(a, axis=1, keepdims=True)
    blocks = np.eye(3)[None] - a_hat[:, :, None] * a_hat[:, None, :]  # (F, 3, 3)
    r = 3 * np.arange(nf)[:, None, None] + np.arange(3)[None, :, None]
    c = 3 * np.arange(nf)[:, None, None] + np.arange(3)[None, None, :]
    projector = sp.csr_matrix((blocks.ravel(), (np.broadcast_to(r, blocks.shape).ravel(),
                                                np.broadcast_to(c, blocks.shape).ravel())), shape=(3 * nf, 3 * nf))
    C = (projector @ Av).tocsr()
    counts = np.bincount(P[:, 1], minlength=nf).astype(np.float64)
    if not unpaired_weight > 0:
        raise ValueError(f"{where}: expected a positive unpaired_weight, got {unpaired_weight}")
    weight = np.where(counts > 0, counts, float(unpaired_weight))  # an unpaired face asks for the identity
    K = (C.T @ sp.diags(np.repeat(weight, 3)) @ C).tocsr()
    gather = sp.csr_matrix((np.ones(len(P)), (P[:, 1], np.arange(len(P)))), shape=(nf, len(P)))

    # pin one vertex of every piece whose translation nothing else fixes
    labels = connected_pieces(Ft, nv)
    has_fixed = np.zeros(labels.max() + 1, dtype=bool)
    np.logical_or.at(has_fixed, labels, fixed)
    floating = ~has_fixed[labels] & used
    pieces = np.where(floating, labels, -1)
    _, first = np.unique(np.where(floating, labels, labels.max() + 1), return_index=True)
    fixed[first[floating[first]]] = True

    free = np.flatnonzero(~fixed)
    # libigl's sparse Cholesky (Eigen) solves many right-hand sides far faster than
    # scipy's SuperLU here (0.3 s against 3 s for 153 columns on 3.5k vertices)
    factor = igl.min_quad_with_fixed_data()
    known = np.flatnonzero(fixed).astype(np.int64)
    try:
        igl.min_quad_with_fixed_precompute(K.tocsc(), known, sp.csc_matrix((0, nv)), True, factor)
    except RuntimeError:
        # Cholesky breaks down on a badly conditioned target (slivers): fall back to LU
        factor = igl.min_quad_with_fixed_data()
        try:
            igl.min_quad_with_fixed_precompute(K.tocsc(), known, sp.csc_matrix((0, nv)), False, factor)
        except RuntimeError as err:
            raise DataError(f"{where}: the deformation-transfer system of this target is singular; look for "
                            "degenerate (zero-area) or duplicated triangles in target_faces") from err
    return TransferSystem(n_vertices=nv, n_source_faces=int(n_source_faces), pairs=P, gather=gather,
                          projected_operator=C, free=free, factor=factor, pieces=pieces.astype(np.int64))


def transferred_deltas(system: TransferSystem, source_gradient_displacements: np.ndarray) -> np.ndarray:
    """Target displacements whose deformation gradients best match the source's.

    Parameters
    ----------
    system : TransferSystem
    source_gradient_displacements : (K, Fs, 3, 3) float ndarray
        ``Q - I`` per source blendshape and face (`deformation_gradient_displacements`),
        in the target's frame.

    Returns
    -------
    deltas : (K, Vt, 3) float64 ndarray
        Displacements of the target vertices; pieces listed in ``system.pieces`` are
        still pinned at one vertex (see `anchored_deltas`). Exactly zero for a zero
        source shape.
    """
    dQ = np.asarray(source_gradient_displacements, dtype=np.float64)
    if dQ.ndim != 4 or dQ.shape[1:] != (system.n_source_faces, 3, 3):
        raise ValueError(
            f"transferred_deltas: expected source gradients of shape (K, {system.n_source_faces}, 3, 3), got {dQ.shape}"
        )
    K = len(dQ)
    partner = dQ[:, system.pairs[:, 0]]  # (K, P, 3, 3) [k, p, r, c]
    summed = system.gather @ partner.transpose(1, 3, 0, 2).reshape(len(system.pairs), 9 * K)  # (Ft, [c, k, r])
    goal = summed.reshape(-1, 3 * K)  # rows 3f + c, columns (k, r)
    rhs = system.projected_operator.T @ goal  # (Vt, 3K)
    known = np.zeros((system.n_vertices - len(system.free), 3 * K))
    empty = np.zeros((0, 3 * K))
    # min_quad_with_fixed minimises 0.5 x'Kx + x'B: B = -rhs gives K x = rhs
    out = igl.min_quad_with_fixed_solve(system.factor, np.ascontiguousarray(-rhs), known, empty)
    out[~np.isin(np.arange(system.n_vertices), system.free)] = 0.0
    return out.reshape(system.n_vertices, K, 3).transpose(1, 0, 2).copy()


def anchored_deltas(
    deltas: np.ndarray,
    pieces: np.ndarray,
    reference_deltas: np.ndarray,
    weights: np.ndarray,
) -> np.ndarray:
    """Shift every floating piece so its displacement agrees best with a reference.

    Parameters
    ----------
    deltas : (K, V, 3) float ndarray
        Displacements, defined up to one translation per piece.
    pieces : (V,) int ndarray
        Piece label per vertex; -1 marks vertices that are not shifted.
    reference_deltas : (K, V, 3) float ndarray
        Displacements the pieces should follow on average (only where ``weights > 0``).
    weights : (V,) float ndarray
        Non-negative weight per vertex; a piece with zero total weight is not moved.

    Returns
    -------
    anchored : (K, V, 3) float64 ndarray
        ``deltas + t[k, piece]`` with ``t`` the weighted mean of
        ``reference_deltas - deltas`` over the piece: the translation minimising the
        weighted squared difference.
    """
    d = np.asarray(deltas, dtype=np.float64)
    ref = np.asarray(reference_deltas, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    lab = np.asarray(pieces, dtype=np.int64)
    if d.ndim != 3 or ref.shape != d.shape or w.shape != d.shape[1:2] or lab.shape != d.shape[1:2]:
        raise ValueError(
            f"anchored_deltas: expected deltas and reference (K, V, 3), weights and pieces (V,); "
            f"got {d.shape}, {ref.shape}, {w.shape}, {lab.shape}"
        )
    if np.any(w < 0):
        raise ValueError("anchored_deltas: weights must be non-negative")
    out = d.copy()
    for piece in np.unique(lab[lab >= 0]):
        members = lab == piece
        total = w[members].sum()
        if total <= 0:
            continue
        shift = np.einsum("kvc,v->kc", (ref - d)[:, members], w[members]) / total
        out[:, members] += shift[:, None, :]
    return out
