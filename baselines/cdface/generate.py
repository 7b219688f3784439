"""``python -m baselines.cdface``: CDFace samples for any WAV, diverse or with the lips fixed.

::

    python -m baselines.cdface --checkpoint CKPT --audio speech.wav --out samples.npy \\
        [--samples 5] [--seed 0] [--control lips [--reference ref.npy]] \\
        [--subject NAME | --template neutral.obj] [--style NAME] [--obj-dir DIR]

``CKPT`` is ``cdface.pt`` or the directory ``benchmark.run --checkpoint`` saved it
in. The output is ``(S, T, V, 3)`` float32 vertices in metres at 60 fps (T from
the audio length). ``--control lips`` gives every sample the same lips (one lip
sample, or the lip codes of ``--reference``, a ``(T, V, 3)`` ``.npy`` on the same
topology) and varies the upper face. ``--obj-dir`` also writes one OBJ per frame,
``DIR/sample_K/frame_NNNNN.obj``.

Plain generation is ``python -m benchmark.generate --method cdface --checkpoint DIR
--audio WAV [--style SPEAKER] --samples N --out FILE.npy`` (the same flags for every
method); used for it, this command prints a ``DeprecationWarning`` naming that one
(plain generation here is removed after 2027-06-30). What stays its own: ``--control
lips`` with ``--reference``, ``--template`` and ``--obj-dir``.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import numpy as np

from baselines.cdface.pipeline import CDFace
from baselines.common.chunking import chunk_plan, chunk_setting, generate_in_chunks
from benchmark.methods.contract import AUDIO_RATE, FPS
from blendvoca import cli
from blendvoca.errors import DataError, UserError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.audio import load_audio
from blendvoca.io.mesh import read_obj, write_obj

CHECKPOINT_FILE = "cdface.pt"


def checkpoint_file(path: str | os.PathLike) -> Path:
    """``cdface.pt`` itself, or inside the directory ``path``.

    Raises
    ------
    UserError
        Neither the file nor a directory holding it.
    """
    path = Path(os.fspath(path)).expanduser()
    if path.is_dir():
        path = path / CHECKPOINT_FILE
    if not path.is_file():
        raise UserError(f"--checkpoint: expected cdface.pt or a directory holding it, got {path} (not found)")
    return path


def chunk_lengths(config: dict) -> tuple[int, int]:
    """``(chunk_frames, chunk_overlap)`` of a CDFace config: ``chunk_frames`` and ``chunk_overlap`` where it
    sets them, by default 10 training windows (480 frames, 8 s, for ``cpu-demo``; 600 for ``paper``, which
    trains on whole sentences) and one window, the context a chunk's autoregressive queries saw in training."""
    window = int(config.get("training", {}).get("window") or 60)
    return chunk_setting(config, "chunk_frames", 10 * window), chunk_setting(config, "chunk_overlap", window)


def reference_motion(path: str | os.PathLike) -> np.ndarray:
    """The ``(T, V, 3)`` array of a ``--reference`` ``.npy`` file.

    Raises
    ------
    DataError
        The file is not a ``.npy`` array (a missing file is the ``OSError`` of ``np.load``).
    """
    try:
        return np.load(path, allow_pickle=False)
    except ValueError as exc:  # np.load's "cannot load file ..." / "pickled data" for what is not a .npy array
        raise DataError(f"--reference {os.fspath(path)}: expected a .npy array, {exc}") from exc


def generate_file(audio_path: str | os.PathLike, out_path: str | os.PathLike, *, checkpoint: str | os.PathLike,
                  samples: int = 1, seed: int = 0, control: str = "none", reference: str | os.PathLike | None = None,
                  subject: str | None = None, template: str | os.PathLike | None = None, style: str | None = None,
                  obj_dir: str | os.PathLike | None = None) -> Path:
    """Write the samples of one WAV to ``out_path`` (``.npy``, atomically); return the path.

    Paths are ``str`` or ``os.PathLike``; ``checkpoint`` is ``cdface.pt`` or its directory.

    Raises
    ------
    UserError
        A missing checkpoint, an ambiguous speaker, ``obj_dir`` without ``template``,
        or a bad option of :meth:`~baselines.cdface.pipeline.CDFace.generate`.
    DataError
        Empty audio, a reference or template of another topology.
    """
    cdface = CDFace.load(checkpoint_file(checkpoint))
    audio = load_audio(audio_path, AUDIO_RATE)
    if audio.size == 0:
        raise DataError(f"--audio {os.fspath(audio_path)}: no samples")
    num_frames = max(1, int(round(audio.shape[0] / AUDIO_RATE * FPS)))
    faces = None
    if template is not None:
        template, faces = read_obj(template)
    elif subject is None:
        if len(cdface.templates) != 1:
            raise UserError(f"give --subject (one of {sorted(cdface.templates)}) or --template")
        subject = next(iter(cdface.templates))
    ref = None if reference is None else reference_motion(reference)
    options = {"subject": subject, "template": template, "samples": samples, "seed": seed, "control": control,
               "style": style}
    chunk_frames, overlap = chunk_lengths(cdface.config)
    plan = chunk_plan(num_frames, chunk_frames, overlap)
    if plan.chunked and ref is None:  # a long WAV: chunk by chunk (a reference fixes the lips of the whole track)
        verts = generate_in_chunks(lambda wav, frames, _index: cdface.generate(wav, frames, **options),
                                   audio, num_frames, plan)
    else:
        verts = cdface.generate(audio, num_frames, reference=ref, **options)
    out_path = Path(os.fspath(out_path))
    with atomic_write(out_path, "wb") as fh:
        np.save(fh, verts.astype(np.float32))
    if obj_dir is not None:
        if faces is None:
            raise UserError("--obj-dir needs the triangles of --template (an OBJ)")
        for k, sample in enumerate(verts):
            for t, frame in enumerate(sample):
                write_obj(Path(os.fspath(obj_dir)) / f"sample_{k}" / f"frame_{t:05d}.obj", frame, faces)
    return out_path


#: When plain generation through this command goes.
REMOVED_AFTER = "2027-06-30"


def warn_plain_generation(subject) -> None:
    """One ``DeprecationWarning`` naming ``python -m benchmark.generate``."""
    style = f" --style {subject}" if subject else ""
    with warnings.catch_warnings():
        if not sys.warnoptions:
            warnings.simplefilter("default", DeprecationWarning)
        warnings.warn(f"plain generation with python -m baselines.cdface is removed after {REMOVED_AFTER}: use "
                      f"python -m benchmark.generate --method cdface --checkpoint DIR (the folder benchmark.run --checkpoint "
                      f"saved){style} --audio WAV "
                      "--samples N --out FILE.npy (the same flags for every method); this command keeps "
                      "--control lips, --reference, --template and --obj-dir", DeprecationWarning, stacklevel=2)


@cli.command
def main(argv=None) -> int:
    """Command line entry point (see the module docstring)."""
    p = cli.parser("baselines.cdface", __doc__)
    p.add_argument("--checkpoint", required=True, help="cdface.pt or its directory")
    p.add_argument("--audio", required=True, help="input WAV (any rate, mono or stereo)")
    p.add_argument("--out", required=True, help="output .npy, (S, T, V, 3) float32 metres")
    p.add_argument("--samples", type=int, default=5)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--control", choices=("none", "lips"), default="none")
    p.add_argument("--reference", default=None, help="(T, V, 3) .npy whose lips every sample gets (--control lips)")
    p.add_argument("--subject", default=None, help="speaker whose stored template is animated")
    p.add_argument("--template", default=None, help="neutral mesh OBJ on the training topology")
    p.add_argument("--style", default=None, help="training speaker whose style token is used (default the first)")
    p.add_argument("--obj-dir", default=None, help="also write one OBJ per frame here (needs --template)")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    if args.samples < 1:
        p.error(f"--samples: expected >= 1, got {args.samples}")
    if args.reference is not None and args.control != "lips":
        p.error("--reference fixes the lips: add --control lips")
    path = generate_file(args.audio, args.out, checkpoint=args.checkpoint, samples=args.samples, seed=args.seed,
                         control=args.control, reference=args.reference, subject=args.subject,
                         template=args.template, style=args.style, obj_dir=args.obj_dir)
    print(path)
    if args.control == "none" and args.template is None and args.obj_dir is None and args.style is None:
        warn_plain_generation(args.subject)  # after the file: a mistake stays one error line
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
