"""Blendshape coefficient tracks as CSV, the way SAiD and its tools read them:
header = blendshape names, one row per frame at 60 fps, no index column.

Columns are always mapped by name (Live Link Face, for one, orders jawRight before
jawLeft), never by position.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.io.atomic import atomic_write


def read_coeffs_csv(path, names: Sequence[str] | None = None) -> tuple[np.ndarray, tuple[str, ...]]:
    """Read a coefficient CSV.

    Parameters
    ----------
    path : path-like
    names : sequence of str, optional
        Wanted columns, in the wanted order. Columns of the file that are not in
        ``names`` are ignored (Live Link Face exports carry head rotation and a
        timecode column); a wanted name that is missing raises.

    Returns
    -------
    coeffs : (T, K) float64 ndarray
    names : tuple of str, the column names of ``coeffs``
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"coefficient file not found: {path}")
    with open(path, newline="", encoding="utf-8-sig") as f:
        reader = csv.reader(f)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise ValueError(f"{path}: empty file; expected a header row of blendshape names") from None
        rows = [row for row in reader if row]
    if len(set(header)) != len(header):
        raise ValueError(f"{path}: repeated column names in the header: {header}")
    wanted = tuple(header) if names is None else tuple(names)
    missing = [n for n in wanted if n not in header]
    if missing:
        raise ValueError(f"{path}: missing columns {missing}; the header has {header}")
    columns = [header.index(n) for n in wanted]
    data = np.empty((len(rows), len(wanted)), dtype=np.float64)
    for t, row in enumerate(rows):
        if len(row) != len(header):
            raise ValueError(f"{path}: row {t + 2} has {len(row)} fields, the header has {len(header)}")
        try:
            data[t] = [float(row[c]) for c in columns]
        except ValueError as error:
            raise ValueError(f"{path}: row {t + 2} (frame {t}): {error}") from None
    return data, wanted


def format_coeffs_csv(coeffs: np.ndarray, names: Sequence[str]) -> str:
    """The CSV text of a ``(T, K)`` track: deterministic formatting (%.6f, '\\n')."""
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2 or coeffs.shape[1] != len(names):
        raise ValueError(f"coefficients must be (T, {len(names)}) for {len(names)} names, got shape {coeffs.shape}")
    if not np.all(np.isfinite(coeffs)):
        bad = np.argwhere(~np.isfinite(coeffs))[0]
        raise ValueError(f"coefficients contain NaN/inf (first at frame {bad[0]}, column {names[bad[1]]!r})")
    out = io.StringIO()
    out.write(",".join(names) + "\n")
    # %.6f keeps 1e-6 resolution (far below any visible motion) and, with
    # -0.000000 normalised, makes files byte-identical across runs and platforms.
    for row in coeffs:
        out.write(",".join(("%.6f" % v).replace("-0.000000", "0.000000") for v in row) + "\n")
    return out.getvalue()


def write_coeffs_csv(path, coeffs: np.ndarray, names: Sequence[str]) -> None:
    """Write a ``(T, K)`` track with header ``names``, atomically."""
    text = format_coeffs_csv(coeffs, names)
    with atomic_write(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
