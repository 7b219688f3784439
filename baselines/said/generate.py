"""Generate blendshape coefficient CSVs for a WAV file with a trained SAiD checkpoint.

    python -m baselines.said.generate --audio x.wav --out y.csv [--samples N]
        [--checkpoint PATH] [--reference ref.csv --mask mask.csv]

With ``--samples N > 1`` the files are ``y-0.csv ... y-<N-1>.csv``.  ``--export FMT``
writes another format of :mod:`blendvoca.export` instead of the CSV (``livelink``,
``arkit-json``, ``a2f-json``; ``glb`` and ``usd`` with ``--rig``), e.g. ``--export glb
--rig rigs/FaceTalk.npz --out y.glb``.  Editing: the
mask CSV has the reference's header and one row per frame, 1 where the reference
value is kept and 0 where it is generated (in-betweening: rows of ones at both ends;
per-blendshape constraints: columns of ones).  The checkpoint is a ``said.pt`` file or
a directory holding one (``benchmark.run`` output, ``python -m baselines.said.train``);
it defaults to ``$BLENDVOCA_SAID_CHECKPOINT``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from baselines.said.pipeline import SAiD

CHECKPOINT_ENV = "BLENDVOCA_SAID_CHECKPOINT"


def checkpoint_file(path: str | os.PathLike | None) -> Path:
    """Return the checkpoint file named by ``path`` (file or directory with ``said.pt``) or by the environment."""
    if path is None:
        path = os.environ.get(CHECKPOINT_ENV)
        if not path:
            raise ValueError(
                f"SAiD generate: expected --checkpoint or ${CHECKPOINT_ENV}; train one with "
                "`python -m baselines.said.train --data DIR --out said.pt` or `python -m benchmark.run --method said`"
            )
    path = Path(path).expanduser()
    if path.is_dir():
        path = path / "said.pt"
    if not path.is_file():
        raise ValueError(f"SAiD generate: expected a checkpoint file at {path}, found none")
    return path


def output_paths(out: str | os.PathLike, samples: int) -> list[Path]:
    """Return the CSV paths for ``samples`` outputs: ``out`` itself, or ``<stem>-<k><suffix>``."""
    out = Path(out)
    if samples == 1:
        return [out]
    return [out.with_name(f"{out.stem}-{k}{out.suffix or '.csv'}") for k in range(samples)]


def generate_files(
    audio_path,
    out_path,
    *,
    checkpoint=None,
    samples: int = 1,
    seed: int = 0,
    reference_path=None,
    mask_path=None,
    sampler: str | None = None,
    num_steps: int | None = None,
    guidance: float | None = None,
    progress: bool = True,
    export: str = "csv",
    rig=None,
) -> list[Path]:
    """Read a WAV (and optional reference/mask CSVs), sample, write coefficient CSVs.

    ``export`` is a :data:`blendvoca.export.FORMATS` name; ``rig`` (a Rig or its path)
    is needed by ``glb`` and ``usd``.

    Returns
    -------
    paths : list of Path
        The files written.
    """
    from blendvoca.export import FORMATS, NEEDS_RIG, export_track, load_rig
    from blendvoca.io.audio import load_audio
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv

    if export not in FORMATS:
        raise ValueError(f"SAiD generate: expected --export one of {FORMATS}, got {export!r}")
    if export in NEEDS_RIG and rig is None:
        raise ValueError(f"SAiD generate: --export {export} needs --rig (a rig .npz or SAiD folder)")
    if isinstance(rig, (str, os.PathLike)):
        rig = load_rig(rig)

    said = SAiD.load(checkpoint_file(checkpoint))
    audio = load_audio(audio_path, rate=16000)
    reference = mask = None
    num_frames = None
    if (reference_path is None) != (mask_path is None):
        raise ValueError("SAiD generate: expected both --reference and --mask, or neither")
    if reference_path is not None:
        reference, _ = read_coeffs_csv(reference_path, names=said.names)
        mask, _ = read_coeffs_csv(mask_path, names=said.names)
        if mask.shape != reference.shape:
            raise ValueError(f"SAiD generate: expected the mask {mask_path} to have the reference's shape {reference.shape}, got {mask.shape}")
        num_frames = reference.shape[0]
    tracks = said.generate(
        audio, num_frames, samples=samples, seed=seed, reference=reference, mask=mask,
        sampler=sampler, num_steps=num_steps, guidance=guidance, progress=progress,
    )
    paths = output_paths(out_path, samples)
    for path, track in zip(paths, tracks):
        path.parent.mkdir(parents=True, exist_ok=True)
        if export == "csv":
            write_coeffs_csv(path, track, said.names)
        else:
            export_track(path, track, said.names, export, rig=rig, fps=60.0, audio=audio_path)
    return paths


def main(argv=None) -> None:
    """Command line entry point (see the module docstring)."""
    p = argparse.ArgumentParser(prog="python -m baselines.said.generate", description=__doc__.split("\n\n")[0])
    p.add_argument("--audio", required=True, help="input WAV (any rate, mono or stereo)")
    p.add_argument("--out", required=True, help="output CSV (header = blendshape names, 60 fps) or --export file")
    p.add_argument("--export", default="csv", choices=("csv", "livelink", "arkit-json", "a2f-json", "glb", "usd"),
                   help="output format (default csv; glb and usd need --rig)")
    p.add_argument("--rig", default=None, help="rig .npz or SAiD folder for --export glb/usd")
    p.add_argument("--samples", type=int, default=1, help="number of samples (default 1)")
    p.add_argument("--checkpoint", default=None, help=f"said.pt or its directory (default ${CHECKPOINT_ENV})")
    p.add_argument("--reference", default=None, help="reference coefficient CSV for editing")
    p.add_argument("--mask", default=None, help="mask CSV for editing: 1 = keep the reference")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--sampler", choices=("ddim", "ddpm"), default=None, help="default: the checkpoint's")
    p.add_argument("--steps", type=int, default=None, help="sampling steps (default: the checkpoint's)")
    p.add_argument("--guidance", type=float, default=None, help="classifier-free guidance gamma (default: the checkpoint's)")
    args = p.parse_args(argv)
    paths = generate_files(
        args.audio, args.out, checkpoint=args.checkpoint, samples=args.samples, seed=args.seed,
        reference_path=args.reference, mask_path=args.mask, sampler=args.sampler,
        num_steps=args.steps, guidance=args.guidance, export=args.export, rig=args.rig,
    )
    for path in paths:
        print(path)


if __name__ == "__main__":
    main()
