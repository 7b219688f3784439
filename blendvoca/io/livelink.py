"""Live Link Face CSV: the one owner of the file Epic's iOS app writes for a take.

Layout (checked against takes exported by the app): a header ``Timecode,
BlendShapeCount`` (app versions spell it ``BlendshapeCount`` too), the 52 ARKit
shapes in PascalCase in the app's order (:data:`blendvoca.names.LIVELINK_SHAPE_COLUMNS`:
``JawRight`` before ``JawLeft``), then the 9 head and eye rotations ``HeadYaw`` ...
``RightEyeRoll`` (:data:`blendvoca.names.LIVELINK_ROTATION_COLUMNS`); every row a
timecode, the count (61) and 61 values with 10 decimals. Columns are found by name
(any case), so a file with its columns in another order reads the same.

Timecodes are ``HH:MM:SS:FF.fff``: the clock's hours, minutes and seconds, ``FF`` the
frame within the second counted at the timecode's rate and ``.fff`` the fraction of a
frame (drop-frame timecodes, ``HH:MM:SS;FF``, label frames at 29.97 or 59.94 fps as
SMPTE ST 12-1 defines: frames 0 and 1, or 0 to 3, are skipped at the start of every
minute not divisible by ten). The file states no rate, so :func:`read_livelink_take`
tells two from the timecodes:

* the timecode's rate (what ``FF`` counts at): of the standard rates above the largest
  ``FF``, the one under which the rows are the most evenly spaced. A wrong rate puts a
  jump at every second boundary (the app's own takes carry a 60 fps clock with the
  fraction of a frame; this project's writer counts ``FF`` at the take's rate, 59.94
  included);
* the take's frame rate: rows over seconds between the first and last timecode (a
  take the app measured at 59.94 fps spaces its rows 16.68 ms apart; read as 60 fps it
  drifts 1.2 frames over 20 s), snapped to a standard rate (24, 25, 30, 48, 50, 60, 100,
  120 and their NTSC x1000/1001 rates) within :data:`RATE_SNAP`.

Rows are placed on the take's frame grid; a frame the capture dropped (a gap of more
than one frame in the timecodes) is interpolated from its neighbours and counted.
Nothing is resampled here: the build does that (:mod:`blendvoca.datasets.livelink`).
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.coeffs import _header, _text_lines
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_ROTATION_COLUMNS, LIVELINK_SHAPE_COLUMNS, arkit_name

#: The header's first two cells as the app writes them (``BlendshapeCount`` occurs too).
TIMECODE_COLUMN, COUNT_COLUMN = "Timecode", "BlendShapeCount"


def _ntsc(rate: int) -> float:
    return rate * 1000 / 1001


#: Rates a timecode's ``FF`` counts at (non-drop-frame), ascending.
TIMECODE_RATES: tuple[float, ...] = (_ntsc(24), 24.0, 25.0, _ntsc(30), 30.0, _ntsc(48), 48.0, 50.0, _ntsc(60), 60.0,
                                     100.0, _ntsc(120), 120.0)
#: Rates of drop-frame timecodes (SMPTE defines drop-frame for these two).
DROP_FRAME_RATES: tuple[float, ...] = (_ntsc(30), _ntsc(60))
#: Frame rates a take's measured rate snaps to.
FRAME_RATES: tuple[float, ...] = TIMECODE_RATES + (90.0,)
#: Largest relative difference between a measured rate and the standard rate it is taken
#: for: 3e-4, a third of the 1/1001 between 59.94 and 60 (a phone's clock is off by tens of ppm).
RATE_SNAP = 3e-4

_TIMECODE = re.compile(r"^(\d{1,4})[:;](\d{2})[:;](\d{2})([:;])(\d{1,3})(?:\.(\d{1,9}))?$")


@dataclass(frozen=True)
class LiveLinkTake:
    """A Live Link Face take as read by :func:`read_livelink_take`.

    Attributes
    ----------
    weights : (T, 52) float64 ndarray
        The ARKit weights on the take's frame grid, columns in ARKit's order (``names``).
    names : tuple of 52 str
        :data:`blendvoca.names.ARKIT_FACE_ORDER` (camelCase).
    pose : (T, 9) float64 ndarray or None
        The head and eye rotations as the app wrote them (``pose_names``), None for a
        file without rotation columns.
    pose_names : tuple of 9 str
        :data:`blendvoca.names.LIVELINK_ROTATION_COLUMNS`.
    fps : float
        The take's frame rate (59.94 is ``60000 / 1001``).
    times : (R,) float64 ndarray
        Seconds of each row's timecode (R rows; ``R <= T``).
    timecode_rate : float
        The rate the timecodes' ``FF`` counts at.
    drop_frame : bool
        Whether the timecodes are drop-frame (``HH:MM:SS;FF``).
    filled : int
        Frames missing from the timecodes, interpolated (``T - R``).
    """

    weights: np.ndarray
    names: tuple[str, ...]
    pose: np.ndarray | None
    pose_names: tuple[str, ...]
    fps: float
    times: np.ndarray
    timecode_rate: float
    drop_frame: bool
    filled: int = 0


# ----------------------------------------------------------------------------- timecodes


def livelink_timecode(frame: int, fps: float, *, drop_frame: bool = False) -> str:
    """The timecode of frame ``frame`` of a take at ``fps``.

    Non-drop-frame: ``HH:MM:SS:FF.fff``, the clock time of the frame (``frame / fps``
    seconds), ``FF`` the frames into the second at ``fps`` and ``.fff`` the fraction of
    a frame (0 for a rate of whole frames per second). Drop-frame (``fps`` 29.97 or
    59.94): SMPTE's label ``HH:MM:SS;FF`` of frame number ``frame``.
    """
    if fps <= 0:
        raise UserError(f"livelink_timecode: fps must be positive, got {fps}")
    if drop_frame:
        return _drop_frame_label(int(frame), fps)
    seconds_total = math.floor(frame / fps + 1e-9)
    within = frame - seconds_total * fps  # frames into the second, may be fractional
    whole = math.floor(within + 1e-9)
    sub = int(round((within - whole) * 1000))
    if sub == 1000:
        whole, sub = whole + 1, 0
    h, rem = divmod(seconds_total, 3600)
    m, s = divmod(rem, 60)
    return f"{h:02d}:{m:02d}:{s:02d}:{whole:02d}.{sub:03d}"


def _drop_frame_label(frame: int, fps: float) -> str:
    """SMPTE's drop-frame label of frame number ``frame`` at 29.97 or 59.94 fps."""
    nominal = int(round(fps))
    if nominal not in (30, 60) or abs(fps - _ntsc(nominal)) > 1e-2:
        raise UserError(f"livelink_timecode: drop-frame timecodes exist at 29.97 and 59.94 fps, got {fps}")
    drop = nominal // 15  # 2 labels at 29.97, 4 at 59.94
    per_ten_minutes = 600 * nominal - 9 * drop
    per_minute = 60 * nominal - drop
    tens, rest = divmod(frame, per_ten_minutes)
    if rest >= drop:
        frame += 9 * drop * tens + drop * ((rest - drop) // per_minute)
    else:
        frame += 9 * drop * tens
    ff = frame % nominal
    s = frame // nominal % 60
    m = frame // (nominal * 60) % 60
    h = frame // (nominal * 3600)
    return f"{h:02d}:{m:02d}:{s:02d};{ff:02d}"


def parse_livelink_timecode(text: str, fps: float) -> float:
    """Seconds of one ``HH:MM:SS:FF[.fff]`` timecode whose ``FF`` counts at ``fps``
    (drop-frame ``HH:MM:SS;FF`` at 29.97 or 59.94)."""
    parts = _timecode_parts([text], where="parse_livelink_timecode")
    return float(_timecode_seconds(parts, fps)[0])


@dataclass(frozen=True)
class _Parts:
    """The fields of R timecodes: whole seconds of the clock, ``FF``, its fraction, minutes, drop-frame."""

    seconds: np.ndarray
    ff: np.ndarray
    sub: np.ndarray
    minutes: np.ndarray
    drop_frame: bool


def _timecode_parts(texts: Sequence[str], *, where: str, rows: Sequence[int] | None = None) -> _Parts:
    """The fields of timecodes; a DataError naming ``where`` and the row of an unparseable one."""
    fields = np.zeros((len(texts), 5), dtype=np.int64)
    sub = np.zeros(len(texts))
    drop = set()
    for i, text in enumerate(texts):
        match = _TIMECODE.match(text.strip())
        if not match or int(match.group(2)) > 59 or int(match.group(3)) > 59:
            at = f"row {rows[i]} (frame {i}): " if rows is not None else ""
            raise DataError(f"{where}: {at}not a Live Link timecode: {text!r}; expected HH:MM:SS:FF.fff "
                            "(or drop-frame HH:MM:SS;FF)")
        h, m, s, sep, ff, frac = match.groups()
        fields[i] = (int(h), int(m), int(s), int(ff), 0)
        sub[i] = float("0." + frac) if frac else 0.0
        drop.add(sep == ";")
    if len(drop) > 1:
        raise DataError(f"{where}: drop-frame (HH:MM:SS;FF) and non-drop-frame (HH:MM:SS:FF) timecodes mixed; "
                        "expected one kind in a take")
    minutes = fields[:, 0] * 60 + fields[:, 1]
    return _Parts(minutes * 60 + fields[:, 2], fields[:, 3], sub, minutes, drop == {True})


def _timecode_seconds(parts: _Parts, rate: float) -> np.ndarray:
    """Seconds of timecodes whose ``FF`` counts at ``rate``."""
    if not parts.drop_frame:
        return parts.seconds + (parts.ff + parts.sub) / rate
    nominal = int(round(rate))
    drop = nominal // 15
    frames = parts.seconds * nominal + parts.ff - drop * (parts.minutes - parts.minutes // 10)
    return (frames + parts.sub) / rate


def _check_drop_frame_labels(parts: _Parts, rate: float, *, where: str, rows: Sequence[int]) -> None:
    """Refuse a drop-frame label SMPTE skips (``SS`` 0, ``FF`` below the drop, a minute not divisible by ten)."""
    drop = int(round(rate)) // 15
    skipped = (parts.seconds % 60 == 0) & (parts.ff < drop) & (parts.minutes % 10 != 0)
    if np.any(skipped):
        i = int(np.argmax(skipped))
        raise DataError(f"{where}: row {rows[i]} (frame {i}): drop-frame label with FF {parts.ff[i]} at the start of "
                        f"minute {parts.minutes[i]}, which drop-frame timecode at {rate:.2f} fps skips "
                        f"(FF 0 to {drop - 1} of every minute not divisible by ten)")


def _evenness(seconds: np.ndarray) -> float:
    """Mean absolute deviation of the row spacing from its median, in medians (0: evenly spaced)."""
    steps = np.diff(seconds)
    median = float(np.median(steps))
    return float(np.mean(np.abs(steps - median)) / median) if median > 0 else math.inf


def timecode_rate(parts: _Parts, *, where: str, fps: float | None = None) -> float:
    """The rate the timecodes' ``FF`` counts at: of the standard rates above the largest
    ``FF``, the one that spaces the rows the most evenly.

    Raises
    ------
    DataError
        ``FF`` beyond every standard rate, or timecodes that never pass a second
        boundary (every rate spaces such rows alike) when ``fps`` does not say.
    """
    ff_max = int(parts.ff.max())
    rates = [r for r in (DROP_FRAME_RATES if parts.drop_frame else TIMECODE_RATES) if ff_max < r]
    if not rates:
        kind = "drop-frame timecodes count at 29.97 or 59.94" if parts.drop_frame else "no standard rate counts that far"
        raise DataError(f"{where}: timecode frame field up to {ff_max}; {kind}")
    if len(np.unique(parts.seconds)) < 2:
        if fps is not None and ff_max < fps:
            return float(fps)
        raise DataError(f"{where}: the {len(parts.ff)} timecodes stay within one second, which cannot tell the "
                        "take's frame rate; a take needs at least 1 s of frames")
    scores = [_evenness(_timecode_seconds(parts, r)) for r in rates]
    return rates[int(np.argmin(scores))]


def snap_frame_rate(rate: float) -> float:
    """``rate`` as the standard frame rate within :data:`RATE_SNAP` of it, else ``rate`` itself."""
    nearest = min(FRAME_RATES, key=lambda r: abs(rate / r - 1))
    return nearest if abs(rate / nearest - 1) <= RATE_SNAP else float(rate)


def frame_grid(times: np.ndarray, *, where: str) -> tuple[float, np.ndarray]:
    """The take's frame rate and each row's frame on its grid.

    Rows over seconds, with each row's frame ``round((t - t0) / period)`` for the
    median spacing ``period`` (so a gap of dropped frames counts its frames), snapped
    by :func:`snap_frame_rate`.

    Raises
    ------
    DataError
        Two rows on one frame of the grid (closer than half a frame).
    """
    period = float(np.median(np.diff(times)))
    index = np.rint((times - times[0]) / period).astype(np.int64)
    rate = snap_frame_rate(index[-1] / (times[-1] - times[0]))
    index = np.rint((times - times[0]) * rate).astype(np.int64)
    same = np.diff(index) < 1
    if np.any(same):
        i = int(np.argmax(same)) + 1
        raise DataError(f"{where}: frames {i - 1} and {i} are {1000 * (times[i] - times[i - 1]):.2f} ms apart, "
                        f"less than half a frame at {rate:.3f} fps; expected one row per frame")
    return rate, index


# ----------------------------------------------------------------------------- reading


def read_livelink_take(path, *, fps: float | None = None) -> LiveLinkTake:
    """Read a Live Link Face CSV: its ARKit weights, head and eye rotations and frame rate.

    Parameters
    ----------
    path : str or os.PathLike
    fps : float, optional
        The rate to take for a file whose timecodes stay within one second (too few
        rows to tell it); without it such a file is refused.

    Returns
    -------
    LiveLinkTake

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    DataError
        Naming the file and what was expected: no ``Timecode`` column, an ARKit shape
        missing or repeated, a row with another number of fields or a value that is no
        number, an unparseable timecode, timecodes that do not increase, too few rows.
    """
    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"Live Link take not found: {path}")
    lines = _text_lines(path)
    header = _header(lines, path)
    time_column, shape_columns, pose_columns = _columns(header, path)
    body = [(n + 2, line) for n, line in enumerate(lines[1:]) if line.strip()]
    if len(body) < 2 and fps is None:
        raise DataError(f"{path}: {len(body)} row(s) of frames; a take needs at least 1 s of frames")
    if not body:
        raise DataError(f"{path}: no rows of frames after the header")
    rows = [n for n, _ in body]
    fields = _fields([line for _, line in body], rows, len(header), path)
    values = _numbers(fields, shape_columns + pose_columns, rows, header, path)
    parts = _timecode_parts([f[time_column] for f in fields], where=str(path), rows=rows)
    if len(body) > 1:
        key = parts.seconds * 1000.0 + parts.ff + parts.sub  # FF never reaches 1000
        back = np.diff(key) <= 0
        if np.any(back):
            i = int(np.argmax(back)) + 1
            raise DataError(f"{path}: row {rows[i]} (frame {i}): timecode {fields[i][time_column]} does not come "
                            f"after {fields[i - 1][time_column]}; expected increasing timecodes")
    rate = timecode_rate(parts, where=str(path), fps=fps)
    if parts.drop_frame:
        _check_drop_frame_labels(parts, rate, where=str(path), rows=rows)
    times = _timecode_seconds(parts, rate)
    back = np.diff(times) <= 0
    if np.any(back):  # in order as written, out of order at the rate (a frame field past the rate)
        i = int(np.argmax(back)) + 1
        raise DataError(f"{path}: row {rows[i]} (frame {i}): timecode {fields[i][time_column]} is not after "
                        f"{fields[i - 1][time_column]} at {rate:.3f} fps; expected increasing timecodes")
    if len(times) < 2:
        take_rate, index = float(fps), np.zeros(1, dtype=np.int64)
    else:
        take_rate, index = frame_grid(times, where=str(path))
    grid = _on_grid(values, index)
    weights = grid[:, : len(shape_columns)]
    pose = grid[:, len(shape_columns):] if pose_columns else None
    return LiveLinkTake(weights=weights, names=tuple(ARKIT_FACE_ORDER), pose=pose,
                        pose_names=tuple(LIVELINK_ROTATION_COLUMNS), fps=take_rate, times=times,
                        timecode_rate=rate, drop_frame=parts.drop_frame, filled=int(len(grid) - len(values)))


def _columns(header: list[str], path: Path) -> tuple[int, list[int], list[int]]:
    """Positions of the timecode, the 52 ARKit shapes (ARKit's order) and the 9 rotations
    (the app's order; empty when the file has none) in ``header``."""
    lower = [h.lower() for h in header]
    rotations = {r.lower(): r for r in LIVELINK_ROTATION_COLUMNS}
    mapped = [TIMECODE_COLUMN if h == "timecode" else COUNT_COLUMN if h == "blendshapecount"
              else rotations.get(h) or arkit_name(h) for h in lower]
    named = [m for m in mapped if m is not None]
    repeated = sorted({m for m in named if named.count(m) > 1})
    if repeated:
        raise DataError(f"{path}: columns repeated in the header (names match in any case): {repeated}; "
                        "expected each of Live Link Face's columns once")
    if TIMECODE_COLUMN not in mapped:
        raise DataError(f"{path}: no Timecode column; expected Live Link Face's header Timecode, BlendShapeCount, "
                        f"the 52 ARKit shapes ({LIVELINK_SHAPE_COLUMNS[0]}, ...) and the 9 rotations")
    missing = [n for n in ARKIT_FACE_ORDER if n not in mapped]
    if missing:
        raise DataError(f"{path}: missing ARKit shape columns {missing}; expected all 52 of Live Link Face's "
                        f"({', '.join(LIVELINK_SHAPE_COLUMNS[:3])}, ...)")
    present = [r for r in LIVELINK_ROTATION_COLUMNS if r in mapped]
    if present and len(present) < len(LIVELINK_ROTATION_COLUMNS):
        absent = [r for r in LIVELINK_ROTATION_COLUMNS if r not in mapped]
        raise DataError(f"{path}: rotation columns {absent} missing while {present} are there; expected all 9 "
                        "head and eye rotations or none")
    return (mapped.index(TIMECODE_COLUMN), [mapped.index(n) for n in ARKIT_FACE_ORDER],
            [mapped.index(r) for r in present])


def _fields(lines: list[str], rows: list[int], width: int, path: Path) -> list[list[str]]:
    """Each line's fields (the csv module's reading for a line with quotes); a DataError for a
    line with another number of fields than the header."""
    out = []
    for n, line in zip(rows, lines):
        fields = next(csv.reader([line])) if '"' in line else line.split(",")
        if len(fields) != width:
            raise DataError(f"{path}: row {n} has {len(fields)} fields, the header has {width}")
        out.append(fields)
    return out


def _numbers(fields: list[list[str]], columns: list[int], rows: list[int], header: list[str],
             path: Path) -> np.ndarray:
    """``(R, len(columns))`` float64 of the given columns; a DataError naming the row, frame and column of a
    value that is no finite number."""
    try:
        values = np.array([[f[c] for c in columns] for f in fields], dtype=np.float64)
    except ValueError:
        values = None
    if values is not None and np.all(np.isfinite(values)):
        return values
    for i, f in enumerate(fields):
        for c in columns:
            try:
                ok = math.isfinite(float(f[c]))
            except ValueError:
                ok = False
            if not ok:
                raise DataError(f"{path}: row {rows[i]} (frame {i}): {header[c]} is {f[c].strip()!r}; expected a "
                                "finite number")
    raise AssertionError("unreachable")  # pragma: no cover


def _on_grid(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Rows at frames ``index`` of a grid, the grid's other frames interpolated linearly."""
    if len(index) == index[-1] + 1:
        return values
    grid = np.arange(index[-1] + 1)
    return np.stack([np.interp(grid, index, values[:, k]) for k in range(values.shape[1])], axis=1)


# ----------------------------------------------------------------------------- writing


def format_livelink_csv(weights, names: Sequence[str], fps: float = 60.0, *, pose=None,
                        drop_frame: bool = False) -> str:
    """The text of a take in Live Link Face's layout.

    Parameters
    ----------
    weights : (T, 52) array_like
        One column per ARKit shape, in any order (``names``).
    names : 52 ARKit names (any case)
    fps : float
        The take's frame rate (the timecodes: :func:`livelink_timecode`).
    pose : (T, 9) array_like, optional
        Head and eye rotations (:data:`blendvoca.names.LIVELINK_ROTATION_COLUMNS`); 0 without.
    drop_frame : bool
        Write drop-frame timecodes (``fps`` 29.97 or 59.94).
    """
    weights = np.asarray(weights, dtype=np.float64)
    canonical = [arkit_name(n) for n in names]
    if weights.ndim != 2 or weights.shape[1] != len(names) or sorted(map(str, canonical)) != sorted(ARKIT_FACE_ORDER):
        raise UserError(f"format_livelink_csv: expected (T, 52) weights with the 52 ARKit names, got shape "
                        f"{weights.shape} and {len(names)} names")
    order = [canonical.index(arkit_name(c)) for c in LIVELINK_SHAPE_COLUMNS]
    pose = np.zeros((len(weights), len(LIVELINK_ROTATION_COLUMNS))) if pose is None else np.asarray(pose, float)
    if pose.shape != (len(weights), len(LIVELINK_ROTATION_COLUMNS)):
        raise UserError(f"format_livelink_csv: expected ({len(weights)}, 9) rotations, got shape {pose.shape}")
    header = (TIMECODE_COLUMN, COUNT_COLUMN) + LIVELINK_SHAPE_COLUMNS + LIVELINK_ROTATION_COLUMNS
    count = len(LIVELINK_SHAPE_COLUMNS) + len(LIVELINK_ROTATION_COLUMNS)
    values = np.concatenate([weights[:, order], pose], axis=1)
    lines = [",".join(header)]
    for t, row in enumerate(values):
        numbers = ",".join(("%.10f" % v).replace("-0.0000000000", "0.0000000000") for v in row)
        lines.append(f"{livelink_timecode(t, fps, drop_frame=drop_frame)},{count},{numbers}")
    return "\n".join(lines) + "\n"


def write_livelink_take(path, weights, names: Sequence[str], fps: float = 60.0, *, pose=None,
                        drop_frame: bool = False) -> None:
    """Write a take in Live Link Face's layout (:func:`format_livelink_csv`), atomically."""
    text = format_livelink_csv(weights, names, fps, pose=pose, drop_frame=drop_frame)
    with atomic_write(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
