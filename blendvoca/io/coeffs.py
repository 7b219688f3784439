"""Blendshape coefficient tracks as CSV, the way SAiD and its tools read them:
header = blendshape names, one row per frame at 60 fps, no index column.

Columns are always mapped by name, never by position, and names match in any case:
Live Link Face's exports (``Timecode``, ``BlendShapeCount``, the 52 shapes in
PascalCase with ``JawRight`` before ``JawLeft``, then head and eye rotations) read
into camelCase ARKit columns; their timecode, count and rotation columns are ignored
(a take's frame rate and head pose are read by the format's owner, :mod:`blendvoca.io.livelink`).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.io.atomic import atomic_write
from blendvoca.names import LIVELINK_ROTATION_COLUMNS, arkit_name, convention_names

# Columns that carry no blendshape weight: Live Link Face's timecode, shape count and
# head/eye rotations.
IGNORED_COLUMNS: frozenset[str] = frozenset(c.lower() for c in ("Timecode", "BlendShapeCount") + LIVELINK_ROTATION_COLUMNS)


def _column_name(header: str) -> str | None:
    """The ARKit name a header cell stands for, the cell itself when it is no ARKit
    name, or None for a column to ignore."""
    if header.lower() in IGNORED_COLUMNS:
        return None
    return arkit_name(header) or header


def read_coeffs_csv(path, names: Sequence[str] | str | None = None, *,
                    missing: str = "error") -> tuple[np.ndarray, tuple[str, ...]]:
    """Read a coefficient CSV (BlendVOCA/SAiD layout or a Live Link Face export).

    Parameters
    ----------
    path : str or os.PathLike
    names : sequence of str or str, optional
        Wanted columns, in the wanted order (ARKit names in any case), or the name of
        a convention of :mod:`blendvoca.names` (``"arkit52"``, ``"said32"``, ...) for its
        columns in its order. Columns of the
        file that are not in ``names`` are ignored. Without ``names``, every column
        but the ignored Live Link ones, which must then all be ARKit names.
    missing : {"error", "zero"}
        A wanted name the file lacks raises, or (``"zero"``) reads as a column of 0.

    Returns
    -------
    coeffs : (T, K) float64 ndarray
    names : tuple of str, the (camelCase ARKit) column names of ``coeffs``

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    DataError
        Naming the file, and the missing or unknown columns, or the row and frame of a bad value.
    """
    if missing not in ("error", "zero"):
        raise UserError(f"read_coeffs_csv: missing must be 'error' or 'zero', got {missing!r}")
    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"coefficient file not found: {path}")
    lines = _text_lines(path)
    header = _header(lines, path)
    body = [line for line in lines[1:] if line]
    mapped = [_column_name(h) for h in header]
    kept = [m for m in mapped if m is not None]
    repeated = sorted({m for m in kept if kept.count(m) > 1})
    if repeated:
        raise DataError(f"{path}: repeated columns in the header (names match in any case): {repeated}")
    unknown = [h for h, m in zip(header, mapped) if m is not None and arkit_name(m) is None]
    if names is None:
        if unknown:
            raise DataError(f"{path}: unknown columns {unknown}; expected ARKit blendshape names "
                             "(any case) plus optionally Live Link Face's Timecode, BlendShapeCount and rotation columns")
        wanted = tuple(kept)
    else:
        if isinstance(names, str):
            names = convention_names(names)
        wanted = tuple(arkit_name(n) or str(n) for n in names)
    absent = [n for n in wanted if n not in kept]
    if absent and missing == "error":
        extra = f"; columns with no ARKit name: {unknown}" if unknown else ""
        raise DataError(f"{path}: missing columns {absent}; the header has {header}{extra}")
    columns = [mapped.index(n) if n in kept else -1 for n in wanted]
    present = [(k, c) for k, c in enumerate(columns) if c >= 0]
    fast = _parsed_columns(body, len(header), [c for _, c in present])
    if fast is not None:
        data = np.zeros((len(body), len(wanted)), dtype=np.float64)
        data[:, [k for k, _ in present]] = fast
        return data, wanted
    # A quoted, short or malformed row: read row by row, to name the row.
    rows = [row for row in csv.reader(body) if row]
    data = np.zeros((len(rows), len(wanted)), dtype=np.float64)
    for t, row in enumerate(rows):
        if len(row) != len(header):
            raise DataError(f"{path}: row {t + 2} has {len(row)} fields, the header has {len(header)}")
        try:
            for k, c in present:
                data[t, k] = float(row[c])
        except ValueError as error:
            raise DataError(f"{path}: row {t + 2} (frame {t}): {error}") from None
    return data, wanted


def _parsed_columns(body: list[str], num_fields: int, columns: list[int]) -> np.ndarray | None:
    """``(T, len(columns))`` float64 of plain comma-separated ``body`` lines (numpy's C parser, the values
    ``float()`` gives); None when a line is quoted, has another number of fields or a bad value."""
    if not columns or any('"' in line or line.count(",") != num_fields - 1 for line in body):
        return None
    if not body:
        return np.zeros((0, len(columns)))
    try:
        return np.loadtxt(body, delimiter=",", usecols=columns, ndmin=2, dtype=np.float64)
    except ValueError:
        return None


def _text_lines(path: Path) -> list[str]:
    """The lines of a UTF-8 text file (a BOM dropped), or a DataError naming the file."""
    with open(path, newline="", encoding="utf-8-sig") as f:
        try:
            return f.read().splitlines()
        except UnicodeDecodeError as error:
            raise DataError(f"{path}: not a UTF-8 text CSV ({error.reason} at byte {error.start})") from None


def _header(lines: list[str], path: Path) -> list[str]:
    """The header cells (stripped) of a CSV's ``lines``, or a DataError for an empty file."""
    try:
        return [h.strip() for h in next(csv.reader(lines[:1]))]
    except StopIteration:
        raise DataError(f"{path}: empty file; expected a header row of blendshape names") from None


def missing_columns(path, names: Sequence[str]) -> tuple[str, ...]:
    """Which of ``names`` (ARKit names, any case) a coefficient CSV's header lacks.

    Raises
    ------
    DataError
        The file is not UTF-8 text (naming the file); an empty file lacks every name.
    """
    path = Path(os.fspath(path))
    with open(path, newline="", encoding="utf-8-sig") as f:
        try:
            first = f.readline()
        except UnicodeDecodeError as error:
            raise DataError(f"{path}: not a UTF-8 text CSV ({error.reason} at byte {error.start})") from None
    header = next(csv.reader([first.rstrip("\r\n")]), []) if first else []
    have = {_column_name(h.strip()) for h in header}
    return tuple(n for n in names if (arkit_name(n) or n) not in have)


def format_coeffs_csv(coeffs: np.ndarray, names: Sequence[str]) -> str:
    """The CSV text of a ``(T, K)`` track (any real dtype): deterministic formatting (%.6f, '\\n')."""
    coeffs = float_array(coeffs, where="format_coeffs_csv", name="coeffs", shape=f"(T, {len(names)})")
    if coeffs.ndim != 2 or coeffs.shape[1] != len(names):
        raise UserError(f"coefficients must be (T, {len(names)}) for {len(names)} names, got shape {coeffs.shape}")
    if not np.all(np.isfinite(coeffs)):
        bad = np.argwhere(~np.isfinite(coeffs))[0]
        raise UserError(f"coefficients contain NaN/inf (first at frame {bad[0]}, column {names[bad[1]]!r})")
    # %.6f keeps 1e-6 resolution (far below any visible motion) and, with
    # -0.000000 normalised, makes files byte-identical across runs and platforms.
    # One %-format over all rows: a field starts at its "-", so the replace only
    # ever touches whole "-0.000000" fields.
    rows = ((",".join(["%.6f"] * coeffs.shape[1]) + "\n") * coeffs.shape[0]) % tuple(coeffs.ravel().tolist())
    return ",".join(names) + "\n" + rows.replace("-0.000000", "0.000000")


def write_coeffs_csv(path, coeffs: np.ndarray, names: Sequence[str]) -> None:
    """Write a ``(T, K)`` track with header ``names``, atomically."""
    text = format_coeffs_csv(coeffs, names)
    with atomic_write(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
