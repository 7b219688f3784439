"""What is sent: a coefficient track read from a file, or generated from a WAV by a method.

:func:`track_from_file` reads a BlendVOCA / SAiD coefficient CSV (60 fps unless told),
a Live Link Face take (its rate from its timecodes, its head and eye rotations kept)
or a ``.npy`` that ``python -m benchmark.generate`` wrote. :func:`track_from_method`
animates a WAV through ``benchmark.generate``'s :func:`~benchmark.generate.generate_file`
(the project's one generate path, every check included) into a temporary folder; a
vertex method's meshes are solved to the rig's shape weights with the streaming solver
(:class:`blendvoca.fit.StreamingSolver`, docs/streaming.md).
"""

from __future__ import annotations

import csv
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.coeffs import IGNORED_COLUMNS, read_coeffs_csv
from blendvoca.io.livelink import read_livelink_take
from blendvoca.names import BLENDVOCA_NAMES, arkit_name

#: The rate of a coefficient CSV that states none (BlendVOCA's and SAiD's tracks).
DEFAULT_FPS = 60.0


@dataclass(frozen=True)
class Track:
    """A track to send.

    Attributes
    ----------
    values : (T, K) float64 ndarray
    names : tuple of K str (camelCase ARKit names)
    fps : float
    pose : (T, 9) float64 ndarray or None
        Head and eye rotations (a Live Link Face take's), None without.
    source : str
        Where it came from, for messages.
    """

    values: np.ndarray
    names: tuple[str, ...]
    fps: float
    pose: np.ndarray | None = None
    source: str = ""

    def __len__(self) -> int:
        return len(self.values)


def _header(path: Path) -> list[str]:
    with open(path, newline="", encoding="utf-8-sig") as f:
        try:
            first = f.readline()
        except UnicodeDecodeError as error:
            raise DataError(f"{path}: not a UTF-8 text CSV ({error.reason} at byte {error.start})") from None
    if not first.strip():
        raise DataError(f"{path}: empty file; expected a header row of blendshape names")
    return [h.strip() for h in next(csv.reader([first.rstrip("\r\n")]))]


def _checked_fps(fps, where: str) -> float | None:
    if fps is None:
        return None
    if not (isinstance(fps, (int, float)) and np.isfinite(fps) and 0 < fps <= 1000):
        raise UserError(f"{where}: expected a frame rate in (0, 1000] frames per second, got {fps!r}")
    return float(fps)


def track_from_file(path, *, fps: float | None = None, carries: str = "the output") -> Track:
    """The track in ``path`` (``.csv`` or ``.npy``); ``fps`` overrides the file's rate.

    Parameters
    ----------
    carries : str
        What the protocol carries, for the message naming columns that are no ARKit shapes.

    Raises
    ------
    UserError
        No such file, another suffix, columns that are no ARKit shapes (named), a bad ``fps``.
    DataError
        A file whose content is wrong (naming it and the position).
    """
    fps = _checked_fps(fps, "--fps")
    path = Path(os.fspath(path)).expanduser()
    if not path.is_file():
        raise UserError(f"--coeffs {path}: no such file; expected a coefficient CSV (BlendVOCA, SAiD or Live Link "
                        "Face layout) or a .npy that benchmark.generate wrote")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return _track_from_npy(path, fps)
    if suffix != ".csv":
        raise UserError(f"--coeffs {path}: unknown suffix {suffix or '(none)'!r}; expected .csv or .npy")
    header = _header(path)
    if "timecode" in (h.lower() for h in header):
        take = read_livelink_take(path)
        return Track(take.weights, tuple(take.names), fps or take.fps, take.pose, str(path))
    unknown = [h for h in header if h.lower() not in IGNORED_COLUMNS and arkit_name(h) is None]
    if unknown:
        raise UserError(f"--coeffs {path}: columns {unknown} are no ARKit shapes, which {carries} has no place for; "
                        "rename them to ARKit names (python -m blendvoca.names shows the conventions)")
    values, names = read_coeffs_csv(path)
    return Track(values, tuple(names), fps or DEFAULT_FPS, None, str(path))


def _track_from_npy(path: Path, fps: float | None) -> Track:
    try:
        array = np.load(path, allow_pickle=False)
    except ValueError as error:
        raise DataError(f"{path}: not a .npy array ({error})") from None
    if array.ndim == 3 and array.shape[0] >= 1:
        array = array[0]  # benchmark.generate's (S, T, 32): the first sample
    if array.ndim != 2 or array.shape[1] != len(BLENDVOCA_NAMES):
        raise DataError(f"{path}: array of shape {array.shape}; expected (T, {len(BLENDVOCA_NAMES)}) or "
                        f"(S, T, {len(BLENDVOCA_NAMES)}) BlendVOCA coefficients (vertices go through --method "
                        "with --rig)")
    values = np.asarray(array, dtype=np.float64)
    if not np.all(np.isfinite(values)):
        t = int(np.argwhere(~np.isfinite(values))[0, 0])
        raise DataError(f"{path}: frame {t} holds a value that is no finite number")
    return Track(values, tuple(BLENDVOCA_NAMES), fps or DEFAULT_FPS, None, str(path))


def track_from_method(method: str, audio, *, checkpoint=None, style: str | None = None, rig=None,
                      config=None, data=None, device: str | None = "cpu", seed: int = 0,
                      fps: float | None = None) -> Track:
    """Animate the WAV ``audio`` with ``method`` through :func:`benchmark.generate.generate_file`.

    A coefficient method gives BlendVOCA's 32 shapes at 60 fps. A vertex method's meshes
    (the first sample) are solved frame by frame by :class:`blendvoca.fit.StreamingSolver` on
    ``rig`` (a ``.npz`` or SAiD folder with the method's topology), giving the rig's shapes.

    Raises
    ------
    UserError
        What ``benchmark.generate`` refuses (unknown method, missing checkpoint, missing or bad
        WAV, ...), a vertex method without ``rig``, ``rig`` given to a coefficient method.
    MethodError
        The method failed or broke the contract.
    """
    # Imported here: blendvoca.live sits below benchmark's commands (docs/architecture.md), and a
    # track read from a file needs neither torch nor the benchmark.
    from benchmark.generate import generate_file
    from benchmark.methods import FPS, OUTPUT_VERTICES, get_method

    fps = _checked_fps(fps, "--fps")
    kind = getattr(get_method(method), "output", "coefficients")
    if kind == OUTPUT_VERTICES and rig is None:
        raise UserError(f"method {method!r} outputs vertices; give --rig RIG (.npz or a SAiD folder of OBJ files "
                        "with the method's topology) to solve them to shape weights with the streaming solver")
    if kind != OUTPUT_VERTICES and rig is not None:
        raise UserError(f"--rig {rig}: method {method!r} outputs coefficients already; leave --rig out")
    audio_path = Path(os.fspath(audio)).expanduser()
    if not audio_path.is_file():
        raise UserError(f"--audio {audio_path}: no such file; expected a WAV recording")
    with tempfile.TemporaryDirectory(prefix="blendvoca-live-") as folder:
        out = Path(folder) / ("track.npy" if kind == OUTPUT_VERTICES else "track.csv")
        generate_file(method, audio_path, out, checkpoint=checkpoint, style=style, seed=seed, config=config,
                      data=data, device=device)
        if kind != OUTPUT_VERTICES:
            values, names = read_coeffs_csv(out)
            return Track(values, tuple(names), fps or float(FPS), None, f"{method} on {audio_path}")
        frames = np.load(out)[0]
    values, names = solved_vertices(frames, rig)
    return Track(values, names, fps or float(FPS), None, f"{method} on {audio_path}, solved on {rig}")


def solved_vertices(frames, rig) -> tuple[np.ndarray, tuple[str, ...]]:
    """``(T, K)`` shape weights of vertex frames ``(T, V, 3)`` solved causally, frame by frame, by the
    streaming solver on ``rig`` (a path or a :class:`blendvoca.rig.Rig`), and the rig's names."""
    from blendvoca.fit.streaming import StreamingSolver
    from blendvoca.rig import Rig, load_rig

    rig = rig if isinstance(rig, Rig) else load_rig(rig)
    solver = StreamingSolver.from_rig(rig)
    return solver.solve_sequence(np.asarray(frames, dtype=np.float64)), tuple(rig.names)

