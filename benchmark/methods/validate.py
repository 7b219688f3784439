"""Checks on what a plug-in returns, with messages naming method, subject and sentence."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import MethodError, MethodOutputError

__all__ = ["MethodError", "MethodOutputError", "validated_tracks", "validated_vertices"]


def _where(method: str, subject: str, sentence: str | None) -> str:
    where = f"method {method!r}, subject {subject!r}"
    if sentence is not None:
        where += f", sentence {sentence!r}"
    return where


def _real_array(output, where: str, expected: tuple, kind: str) -> np.ndarray:
    """What ``generate`` returned as an array of real numbers (a torch tensor copied to
    the CPU); MethodOutputError naming ``where`` and the ``expected`` shape otherwise."""
    if output is None:
        raise MethodOutputError(f"{where}: generate returned None, expected a {expected} {kind}")
    try:
        array = np.asarray(output.detach().cpu().numpy() if hasattr(output, "detach") else output)
    except Exception as exc:
        raise MethodOutputError(f"{where}: generate returned {type(output).__name__}, which is not an array "
                                f"({exc})") from exc
    dtype = array.dtype
    if dtype == object or not np.issubdtype(dtype, np.number) or np.issubdtype(dtype, np.complexfloating):
        raise MethodOutputError(f"{where}: expected a real-valued {kind}, got dtype {array.dtype}")
    return array


def validated_tracks(
    output,
    *,
    method: str,
    subject: str,
    sentence: str | None,
    num_frames: int,
    samples: int,
    num_coeffs: int = 32,
    clip: bool = False,
):
    """The generated tracks as float64, after checking them against the contract.

    Parameters
    ----------
    output : array-like
        What ``Method.generate`` returned; expected ``(samples, num_frames, num_coeffs)``.
    method, subject, sentence : str
        Named in error messages.
    num_frames : int
        Expected ``T`` (60 fps frames of the ground-truth track).
    samples : int
        Expected ``S``.
    num_coeffs : int
        Expected number of coefficients (32).
    clip : bool
        If True, values outside [0, 1] are clipped instead of refused (non-finite
        values are always refused).

    Returns
    -------
    tracks : (S, T, K) float64 ndarray
    n_clipped : int
        Number of entries clipped into [0, 1] (0 unless ``clip``).

    Raises
    ------
    MethodOutputError
        Not an array of numbers, wrong number of dimensions, samples, frames or
        coefficients, NaN/inf values, or values outside [0, 1] when ``clip`` is False.
    """
    where = _where(method, subject, sentence)
    expected = (samples, num_frames, num_coeffs)
    tracks = _real_array(output, where, expected, "array")
    if tracks.ndim != 3:
        raise MethodOutputError(f"{where}: expected shape (S, T, K) = {expected}, got {tracks.ndim}-d shape {tracks.shape}")
    if tracks.shape[0] != samples:
        raise MethodOutputError(f"{where}: expected {samples} sample(s) (axis 0), got {tracks.shape[0]} (shape {tracks.shape})")
    if tracks.shape[1] != num_frames:
        raise MethodOutputError(
            f"{where}: wrong frame count: expected {num_frames} frames at 60 fps (axis 1), got {tracks.shape[1]} "
            f"(shape {tracks.shape})"
        )
    if tracks.shape[2] != num_coeffs:
        raise MethodOutputError(
            f"{where}: expected {num_coeffs} blendshape coefficients (axis 2), got {tracks.shape[2]} (shape {tracks.shape})"
        )
    tracks = tracks.astype(np.float64)
    bad = ~np.isfinite(tracks)
    if bad.any():
        s, t, k = np.argwhere(bad)[0]
        raise MethodOutputError(
            f"{where}: {int(bad.sum())} non-finite value(s) (NaN or inf), first at sample {s}, frame {t}, coefficient {k}"
        )
    outside = (tracks < 0.0) | (tracks > 1.0)
    if outside.any():
        if clip:
            return np.clip(tracks, 0.0, 1.0), int(outside.sum())
        s, t, k = np.argwhere(outside)[0]
        raise MethodOutputError(
            f"{where}: {int(outside.sum())} value(s) outside [0, 1] (min {tracks.min():.6g}, max {tracks.max():.6g}), "
            f"first at sample {s}, frame {t}, coefficient {k}: {tracks[s, t, k]:.6g}; pass clip=True (--clip) to clip them"
        )
    return tracks, 0


def validated_vertices(output, *, method: str, subject: str, sentence: str | None, num_frames: int, samples: int,
                       num_vertices: int):
    """The generated vertices as float64, after checking them against the contract.

    Parameters
    ----------
    output : array-like
        What ``Method.generate`` returned for an ``output = "vertices"`` method;
        expected ``(samples, num_frames, num_vertices, 3)`` metres.
    method, subject, sentence : str
        Named in error messages.
    num_frames : int
        Expected ``T`` (60 fps frames).
    samples : int
        Expected ``S``.
    num_vertices : int
        Vertices of the speaker's topology (5023 for FLAME).

    Returns
    -------
    (S, T, V, 3) float64 ndarray

    Raises
    ------
    MethodOutputError
        Not an array of numbers, wrong shape, NaN/inf values, or coordinates larger
        than 10 m (the output is not in metres).
    """
    where = _where(method, subject, sentence)
    expected = (samples, num_frames, num_vertices, 3)
    verts = _real_array(output, where, expected, "vertex array")
    if verts.ndim != 4:
        raise MethodOutputError(f"{where}: expected vertices of shape (S, T, V, 3) = {expected}, got {verts.ndim}-d "
                                f"shape {verts.shape}")
    for axis, (got, want, what) in enumerate(zip(verts.shape, expected,
                                                 ("sample(s)", "frames at 60 fps", "vertices (the speaker's topology)",
                                                  "coordinates"))):
        if got != want:
            raise MethodOutputError(f"{where}: expected {want} {what} (axis {axis}), got {got} (shape {verts.shape}, "
                                    f"expected {expected})")
    verts = verts.astype(np.float64)
    bad = ~np.isfinite(verts)
    if bad.any():
        s, t, v, _ = np.argwhere(bad)[0]
        raise MethodOutputError(f"{where}: {int(bad.sum())} non-finite vertex coordinate(s) (NaN or inf), first at "
                                f"sample {s}, frame {t}, vertex {v}")
    largest = float(np.abs(verts).max())
    if largest > 10.0:
        raise MethodOutputError(f"{where}: vertex coordinates up to {largest:.4g}; expected metres (a head is ~0.2 m), "
                                f"convert millimetres or centimetres before returning")
    return verts
