"""Fit a mesh sequence with a rig frame by frame, as a stream (Audio2Face-3D's blendshape solve).

``python -m blendvoca.fit --rig RIG --frames FRAMES.npy --out coeffs.csv [--config a2f.json]``

Each frame is solved from itself and the previous frame's answer only
(:class:`blendvoca.fit.StreamingSolver`): bounded least squares with the SDK's L1, L2,
symmetry and previous-frame terms, cancel pairs, masks, multipliers and offsets.

``--config FILE`` reads an Audio2Face-3D blendshape solver configuration (the SDK's
``bs_skin_config.json`` layout, an object ``"blendshape_params"``; ``--pose-names`` gives
the pose order of its arrays to apply them by name); ``--config KEY=VALUE`` sets a field
of ``StreamingSolverConfig`` (``rate_bound=0.1``, ``objective=a2f``, ``temporal=1``,
``cancel_pairs=[]``, ...), over the file or over ``--preset`` (``sdk``: the SDK's
defaults with the left/right pairs of the rig's names; ``bounded-least-squares``: no
regulariser). The frames are unposed (no head pose is removed), in the order they
were captured, either of the rig's full topology ``(T, V, 3)`` or of its fitted head
crop ``(T, 4580, 3)`` on a FLAME rig. The coefficient CSV (BlendVOCA's layout, the
rig's shape names as header) is written atomically. See docs/streaming.md.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

from blendvoca import cli
from blendvoca.errors import DataError, UserError
from blendvoca.io.coeffs import write_coeffs_csv
from blendvoca.rig import load_rig

from .streaming import StreamingSolver, StreamingSolverConfig


def load_frames(path: Path) -> np.ndarray:
    """The ``(T, N, 3)`` array of a ``.npy`` file (read-only memory map: frames are read as solved)."""
    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"--frames: no such file: {path}")
    with open(path, "rb") as f:
        magic = f.read(6)
    if magic != b"\x93NUMPY" and magic[:2] != b"PK":
        raise DataError(f"--frames {path}: not a NumPy .npy file (it starts with {magic!r}, a .npy with "
                        "b'\\x93NUMPY'); expected a .npy array of shape (T, V, 3) (numpy.save)")
    try:
        frames = np.load(path, allow_pickle=False, mmap_mode="r")
    except ValueError as error:  # pickled objects, or a broken header
        raise DataError(f"--frames {path}: expected a .npy array of shape (T, V, 3), {error}") from None
    if isinstance(frames, np.lib.npyio.NpzFile):
        frames.close()
        raise DataError(f"--frames {path}: expected a .npy array of shape (T, V, 3), got an .npz archive")
    if not (np.issubdtype(frames.dtype, np.floating) or np.issubdtype(frames.dtype, np.integer)):
        raise DataError(f"--frames {path}: expected real numbers (float32 or float64), got dtype {frames.dtype}")
    if frames.ndim != 3 or frames.shape[2] != 3 or frames.shape[0] == 0:
        raise DataError(f"--frames {path}: expected an array of shape (T >= 1, V, 3), got {frames.shape}")
    return frames


def read_names(path: Path) -> tuple[str, ...]:
    """Pose names, one per line (blank lines skipped)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise DataError(f"--pose-names {path}: expected a UTF-8 text file of names, one per line "
                        f"({error.reason} at byte {error.start})") from None
    return tuple(line.strip() for line in text.splitlines() if line.strip())


#: ``--preset``: where the settings start from (``--config`` entries then change them).
PRESETS = {
    "sdk": StreamingSolverConfig,
    "bounded-least-squares": StreamingSolverConfig.bounded_least_squares,
}

#: Fields a ``--config KEY=VALUE`` entry may set (the others come from an SDK file).
CONFIG_KEYS = tuple(f.name for f in dataclasses.fields(StreamingSolverConfig) if f.name not in ("pose_names", "num_poses"))


def solver_config(entries, preset: str | None, pose_names: Path | None) -> StreamingSolverConfig:
    """The configuration of ``--config`` entries (at most one SDK file, any KEY=VALUE) over ``--preset``."""
    files = [e for e in entries if "=" not in e]
    pairs = [e for e in entries if "=" in e]
    if len(files) > 1:
        raise UserError(f"--config: at most one Audio2Face-3D configuration file, got {files}")
    if pose_names is not None and not files:
        raise UserError("--pose-names: only with a --config file (it names the poses of that file's arrays)")
    if files and preset is not None:
        raise UserError(f"--preset {preset}: not with a --config file, whose settings are complete")
    changes = cli.parse_config(pairs)
    unknown = sorted(set(changes) - set(CONFIG_KEYS))
    if unknown:
        raise UserError(f"--config: unknown keys {unknown}; expected a file (an Audio2Face-3D blendshape solver "
                        f"configuration) or KEY=VALUE with KEY one of {list(CONFIG_KEYS)}")
    if files:
        names = read_names(pose_names) if pose_names is not None else None
        return StreamingSolverConfig.from_a2f(Path(files[0]), names=names, **changes)
    if preset is not None and preset not in PRESETS:
        raise UserError(f"--preset: expected one of {list(PRESETS)}, got {preset!r}")
    return PRESETS[preset or "sdk"](**changes)


def _refuse_overwriting_an_input(args) -> None:
    """UserError when ``--out`` is one of the command's inputs (the write would replace it)."""
    inputs = {"--rig": args.rig, "--frames": args.frames, "--pose-names": args.pose_names,
              **{"--config": Path(e) for e in args.config if "=" not in e}}
    out = Path(os.fspath(args.out)).expanduser().resolve()
    for flag, path in inputs.items():
        if path is not None and Path(os.fspath(path)).expanduser().resolve() == out:
            raise UserError(f"--out {args.out}: is the {flag} input; writing the coefficients there would "
                            "replace it; give another --out path (a .csv)")


def scale_checked(frames, rig, where: str) -> None:
    """DataError naming the first frame with a vertex farther from the rig's neutral than 100 times the
    rig's size (frames in other units, or a broken frame: the solve would give meaningless weights).
    The frames are read in blocks (they may be a memory map larger than memory)."""
    neutral = np.asarray(rig.neutral, dtype=np.float64)
    size = float(np.linalg.norm(np.ptp(neutral, axis=0)))
    centre = neutral.mean(axis=0)
    for start in range(0, frames.shape[0], 256):
        block = np.asarray(frames[start:start + 256], dtype=np.float64)
        if frames.shape[1] != len(neutral):
            reach = np.abs(block - centre).max(axis=(1, 2))
        else:
            reach = np.abs(block - neutral).max(axis=(1, 2))
        bad = np.flatnonzero(reach > 100 * size)  # a non-finite frame is the solver's to name (with its vertex)
        if bad.size:
            t = start + int(bad[0])
            raise DataError(f"{where}: frame {t} has a vertex {reach[bad[0]]:.3g} from the rig's neutral, the "
                            f"rig is {size:.3g} across; expected frames in the rig's units and pose")


@cli.command
def main(argv=None) -> int:
    p = cli.parser("blendvoca.fit", __doc__, epilog=(
        "--config FILE reads an Audio2Face-3D blendshape solver configuration (JSON, 'blendshape_params'); "
        f"--config KEY=VALUE sets a solver setting, KEY one of {', '.join(CONFIG_KEYS)} "
        "(e.g. --config rate_bound=0.1 --config objective=a2f). See docs/streaming.md."))
    p.add_argument("--rig", type=Path, required=True, help="rig: .npz (Rig.save) or a SAiD folder of OBJ files")
    p.add_argument("--frames", type=Path, required=True,
                   help="unposed frames as .npy, (T, V, 3) on the rig's topology or (T, S, 3) on its fitted crop")
    p.add_argument("--out", type=Path, required=True, help="coefficient CSV to write (header: the rig's shape names)")
    p.add_argument("--pose-names", type=Path, default=None,
                   help="the SDK pose names of the --config file's arrays, one per line, to apply them by name "
                        "(default: by index, in the rig's shape order)")
    cli.add_config_options(p, preset_help=f"settings to start from: {' or '.join(PRESETS)} (default sdk: the "
                                          "Audio2Face-3D SDK's defaults)")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    _refuse_overwriting_an_input(args)

    config = solver_config(args.config, args.preset, args.pose_names)
    rig = load_rig(args.rig)
    frames = load_frames(args.frames)
    solver = StreamingSolver.from_rig(rig, config)
    if frames.shape[1] not in (solver.num_vertices, solver.num_fitted):
        crop = "" if solver.num_fitted == solver.num_vertices else f" or (T, {solver.num_fitted}, 3) (its fitted crop)"
        raise DataError(f"--frames {args.frames}: expected (T, {solver.num_vertices}, 3) (the vertices of the rig "
                        f"{args.rig}){crop}, got {frames.shape}")
    scale_checked(frames, rig, f"--frames {args.frames}")
    start = time.perf_counter()
    try:
        coeffs = solver.solve_sequence(frames)
    except UserError as error:  # a non-finite vertex: the file's content
        raise DataError(f"--frames {args.frames}: {error}") from None
    elapsed = time.perf_counter() - start

    write_coeffs_csv(args.out, coeffs, rig.names)
    if not args.quiet:
        print(f"{frames.shape[0]} frames solved ({1000 * elapsed / frames.shape[0]:.2f} ms per frame), "
              f"{len(rig.names)} shapes written to {args.out}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
