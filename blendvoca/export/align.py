"""Map a coefficient track's columns onto the shapes a target format or rig carries.

The mapping is :func:`blendvoca.names.remap` (by name, values copied): every
format's column order is a convention of :mod:`blendvoca.names` or a rig's names.
"""

from __future__ import annotations

from collections.abc import Sequence
import warnings
from dataclasses import dataclass

import numpy as np

from blendvoca.errors import UserError
from blendvoca.io.arrays import float_array
from blendvoca.names import MissingShapesWarning, arkit_name, canonical_names, convention_names, remap, remap_columns


@dataclass(frozen=True)
class AlignedTrack:
    """A track with one column per target shape.

    Attributes
    ----------
    coeffs : (T, K) float64 ndarray, columns in ``names`` order
    names : tuple of K str, the target's shape names
    missing : tuple of str, target shapes the track lacks (their column is 0)
    dropped : tuple of str, track columns the target has no shape for
    clipped : int, values of the track that were outside [0, 1] and clipped into it
    """

    coeffs: np.ndarray
    names: tuple[str, ...]
    missing: tuple[str, ...]
    dropped: tuple[str, ...]
    clipped: int = 0

    def notes(self) -> list[str]:
        """Human-readable notes on missing and dropped shapes (empty when none)."""
        out = []
        if self.missing:
            out.append(f"note: the track has no column for {len(self.missing)} shapes of the target; they are 0: "
                       + ", ".join(self.missing))
        if self.dropped:
            out.append(f"note: the target has no shape for {len(self.dropped)} track columns; they are left out: "
                       + ", ".join(self.dropped))
        if self.clipped:
            out.append(f"note: {self.clipped} value(s) outside [0, 1] were clipped into it")
        return out


def check_track(coeffs, names: Sequence[str], *, where: str) -> tuple[np.ndarray, tuple[str, ...]]:
    """A ``(T, K)`` finite float64 track and its camelCase ARKit column names.

    Raises
    ------
    UserError
        Naming ``where``, the expected and the received shape, or the unknown names or first bad frame;
        also when ``coeffs`` are not real numbers (any float or integer dtype converts).
    """
    coeffs = float_array(coeffs, where=where, name="coeffs", shape=f"(T, {len(names)})")
    names = tuple(str(n) for n in names)
    if coeffs.ndim != 2 or coeffs.shape[1] != len(names):
        raise UserError(f"{where}: expected a (T, {len(names)}) track for {len(names)} names, got shape {coeffs.shape}")
    if len(coeffs) == 0:
        raise UserError(f"{where}: the track has no frames")
    canonical = canonical_names(names, where=where)
    if not np.all(np.isfinite(coeffs)):
        t, k = np.argwhere(~np.isfinite(coeffs))[0]
        raise UserError(f"{where}: NaN/inf at frame {t}, column {names[k]!r}")
    return coeffs, canonical


def unit_range_track(coeffs, names: Sequence[str], *, where: str, clip: bool = False) -> tuple[np.ndarray, int]:
    """The track with its weights in [0, 1], the range every blendshape format means.

    Parameters
    ----------
    coeffs : (T, K) array_like, finite (:func:`check_track`)
    names : K names, the columns of ``coeffs``
    where : str
        What the track is, for the message.
    clip : bool
        Clip values outside [0, 1] instead of refusing them.

    Returns
    -------
    coeffs : (T, K) float64 ndarray
    clipped : int
        How many values were moved into [0, 1] (0 unless ``clip``).

    Raises
    ------
    UserError
        A value outside [0, 1] and ``clip`` is False: naming how many, the first
        frame and column and its value.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    outside = (coeffs < 0.0) | (coeffs > 1.0)
    if not outside.any():
        return coeffs, 0
    if clip:
        return np.clip(coeffs, 0.0, 1.0), int(outside.sum())
    t, k = (int(i) for i in np.argwhere(outside)[0])
    raise UserError(f"{where}: {int(outside.sum())} value(s) outside [0, 1] (min {coeffs.min():.6g}, max "
                    f"{coeffs.max():.6g}), first at frame {t}, column {names[k]!r}: {coeffs[t, k]:.6g}; blendshape "
                    f"weights are in [0, 1]: pass --clip (clip=True) to clip them")


def align_track(coeffs, names: Sequence[str], target, *, where: str = "track") -> AlignedTrack:
    """Reorder a track's columns to ``target`` by name; target shapes it lacks are 0.

    Parameters
    ----------
    coeffs : (T, K) array_like
    names : K ARKit names (any case), the track's columns
    target : K' ARKit names, the wanted columns, or a convention name of
        :mod:`blendvoca.names` (``"livelink"``, ``"a2f52"``, ...)

    Returns
    -------
    AlignedTrack with ``coeffs`` of shape (T, K'); its ``missing`` names the
    zero-filled shapes (the notes report them, so the remap's warning is not repeated)
    """
    coeffs, names = check_track(coeffs, names, where=where)
    target = convention_names(target) if isinstance(target, str) else tuple(arkit_name(n) or n for n in target)
    _, missing, dropped = remap_columns(names, target)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MissingShapesWarning)
        out = remap(coeffs, names, target, missing="zero")
    return AlignedTrack(out, target, missing, dropped)
