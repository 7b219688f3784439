"""Generate blendshape coefficient CSVs for a WAV file with a trained SAiD checkpoint.

Plain generation is ``python -m benchmark.generate --method said --checkpoint DIR
--audio WAV --out FILE`` (the same flags for every method); used for it, this command
prints a ``DeprecationWarning`` naming that one (plain generation here is removed after
2027-06-30). What stays its own: editing (``--reference``/``--mask``), the authors'
weights' options, ``--export`` and ``--image``.

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

A WAV longer than the checkpoint's chunk length (10 training windows, 10 s for
``cpu-demo``) is sampled chunk by chunk and crossfaded, in memory that does not grow
with its length (:mod:`baselines.common.chunking`; editing with ``--reference`` and the
authors' weights sample the whole track in one chain).

The authors' published ``SAiD.pth`` is detected by its keys (``--official`` insists
on it) and samples as their inference script does (DDIM 1000, gamma 2 unless
``--steps``/``--guidance``), with ``--eta``, ``--guidance-rescale``, ``--strength``
(editing from ``--reference``), ``--intermediates DIR`` (the chain's states as
CSV + PNG, ``1`` = the last) and ``--image PNG`` (the coefficients as a labelled image:
a row per blendshape name, time in seconds, the method and the audio in its title, a
colour bar).
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

from baselines.common.checkpoint import load_checkpoint_file, old_format_hint
from baselines.common.device import torch_device
from baselines.said.checkpoint import FORMAT
from baselines.said.coeff_image import write_coefficient_image
from baselines.said.official import is_official_state, model_from_state
from baselines.said.official_pipeline import OfficialSAiD
from baselines.said.pipeline import SAiD
from blendvoca import cli
from blendvoca.builder.report import coefficient_strip_figure
from blendvoca.errors import DataError, UserError
from blendvoca.export import FORMATS, NEEDS_RIG, export_track, load_rig
from blendvoca.io.audio import load_audio
from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv

CHECKPOINT_ENV = "BLENDVOCA_SAID_CHECKPOINT"


def checkpoint_file(path: str | os.PathLike | None) -> Path:
    """Return the checkpoint file named by ``path`` (file or directory with ``said.pt``) or by the environment.

    Raises
    ------
    UserError
        Neither ``path`` nor ``$BLENDVOCA_SAID_CHECKPOINT``, or no checkpoint file there.
    """
    if path is None:
        path = os.environ.get(CHECKPOINT_ENV)
        if not path:
            raise UserError(
                f"SAiD generate: expected --checkpoint or ${CHECKPOINT_ENV}; train one with "
                "`python -m baselines.said.train --data DIR --out said.pt` (then --checkpoint said.pt) or "
                "`python -m benchmark.run --method said --checkpoint said-ckpt/` (then --checkpoint said-ckpt/)"
            )
    path = Path(os.fspath(path)).expanduser()
    if path.is_dir():
        path = path / "said.pt" if (path / "said.pt").is_file() or not (path / "SAiD.pth").is_file() else path / "SAiD.pth"
    if not path.is_file():
        raise UserError(f"SAiD generate: expected a checkpoint file at {path}, found none")
    return path


def load_pipeline(path: str | os.PathLike, official: bool | None = None):
    """Return the pipeline in ``path``: a ``said.pt`` checkpoint, or the authors' ``SAiD.pth`` (detected by its keys).

    Raises
    ------
    UserError
        No file at ``path``, or ``official`` and the file is not the authors'.
    DataError
        The file is neither a SAiD checkpoint nor the authors' weights.
    """
    path = Path(os.fspath(path))
    payload = load_checkpoint_file(path, where="SAiD generate", old_format_hint=old_format_hint(path))
    if is_official_state(payload):
        return OfficialSAiD(model_from_state(payload, where=str(path)))
    if official:
        raise UserError(f"SAiD generate: --official expects the authors' SAID_UNet1D state_dict, got a different file {path}")
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise DataError(f"SAiD generate: expected a {FORMAT} checkpoint or the authors' SAiD.pth at {path}")
    return SAiD.load(path)


def write_intermediates(directory: str | os.PathLike, states, names) -> None:
    """Write the chain's states (first sample) as ``<k>.csv`` and ``<k>.png``, ``k = 1`` being the last state."""
    directory = Path(os.fspath(directory))
    directory.mkdir(parents=True, exist_ok=True)
    for k, state in enumerate(reversed(states), start=1):
        write_coeffs_csv(directory / f"{k}.csv", state[0], names)
        write_coefficient_image(directory / f"{k}.png", state[0])


def output_paths(out: str | os.PathLike, samples: int) -> list[Path]:
    """Return the CSV paths for ``samples`` outputs: ``out`` itself, or ``<stem>-<k><suffix>``."""
    out = Path(os.fspath(out))
    if samples == 1:
        return [out]
    return [out.with_name(f"{out.stem}-{k}{out.suffix or '.csv'}") for k in range(samples)]


def generate_files(
    audio_path: str | os.PathLike,
    out_path: str | os.PathLike,
    *,
    checkpoint: str | os.PathLike | None = None,
    samples: int = 1,
    seed: int = 0,
    reference_path: str | os.PathLike | None = None,
    mask_path: str | os.PathLike | None = None,
    sampler: str | None = None,
    num_steps: int | None = None,
    guidance: float | None = None,
    export: str = "csv",
    rig=None,
    official: bool | None = None,
    eta: float | None = None,
    guidance_rescale: float | None = None,
    strength: float = 1.0,
    intermediates_dir: str | os.PathLike | None = None,
    image_path: str | os.PathLike | None = None,
    device: str = "cpu",
) -> list[Path]:
    """Read a WAV (and optional reference/mask CSVs), sample, write coefficient CSVs.

    ``export`` is a :data:`blendvoca.export.FORMATS` name; ``rig`` (a Rig or its path)
    is needed by ``glb`` and ``usd``; ``device`` (``auto``, ``cpu``, ``cuda``,
    ``cuda:N``) is where the network samples. Paths are ``str`` or ``os.PathLike``.

    Returns
    -------
    paths : list of Path
        The files written.

    Raises
    ------
    UserError
        A bad option, a missing checkpoint or options that need the other kind of weights.
    DataError
        A checkpoint that is not SAiD's, a mask of another shape than the reference.
    """
    if export not in FORMATS:
        raise UserError(f"SAiD generate: expected --export one of {FORMATS}, got {export!r}")
    if export in NEEDS_RIG and rig is None:
        raise UserError(f"SAiD generate: --export {export} needs --rig (a rig .npz or SAiD folder)")
    if isinstance(rig, (str, os.PathLike)):
        rig = load_rig(rig)

    device = torch_device(device)
    said = load_pipeline(checkpoint_file(checkpoint), official).to(device)
    authors_only = {"--guidance-rescale": guidance_rescale, "--intermediates": intermediates_dir,
                    "--strength": None if strength == 1.0 else strength}
    if not isinstance(said, OfficialSAiD) and any(v is not None for v in authors_only.values()):
        raise UserError(f"SAiD generate: {', '.join(k for k, v in authors_only.items() if v is not None)} "
                        "need the authors' weights (--official SAiD.pth)")
    audio = load_audio(audio_path, rate=16000)
    reference = mask = None
    num_frames = None
    if (reference_path is None) != (mask_path is None) and not (isinstance(said, OfficialSAiD) and mask_path is None):
        raise UserError("SAiD generate: expected both --reference and --mask, or neither")
    if reference_path is not None:
        reference, _ = read_coeffs_csv(reference_path, names=said.names)
        mask = reference * 0.0 if mask_path is None else read_coeffs_csv(mask_path, names=said.names)[0]
        if mask.shape != reference.shape:
            raise DataError(f"SAiD generate: expected the mask {os.fspath(mask_path)} to have the reference's shape "
                            f"{reference.shape}, got {mask.shape}")
        num_frames = reference.shape[0]
    extra = {}
    if isinstance(said, OfficialSAiD):
        extra = {"guidance_rescale": guidance_rescale, "strength": strength, "return_intermediates": intermediates_dir is not None}
    tracks = said.generate(
        audio, num_frames, samples=samples, seed=seed, reference=reference, mask=mask,
        sampler=sampler, num_steps=num_steps, guidance=guidance, eta=eta, **extra,
    )
    if intermediates_dir is not None:
        tracks, states = tracks
        write_intermediates(intermediates_dir, states, said.names)
    if image_path is not None:
        for k, (path, track) in enumerate(zip(output_paths(image_path, samples), tracks)):
            sample = f", sample {k} of {samples}" if samples > 1 else ""
            coefficient_strip_figure(path, track, said.names,
                                     title=f"SAiD: {Path(os.fspath(audio_path)).name}{sample}")
    paths = output_paths(out_path, samples)
    for path, track in zip(paths, tracks):
        path.parent.mkdir(parents=True, exist_ok=True)
        if export == "csv":
            write_coeffs_csv(path, track, said.names)
        else:
            export_track(path, track, said.names, export, rig=rig, fps=60.0, audio=audio_path)
    return paths


#: When plain generation through this command goes.
REMOVED_AFTER = "2027-06-30"


def warn_plain_generation() -> None:
    """One ``DeprecationWarning`` naming ``python -m benchmark.generate`` (shown also where
    DeprecationWarning is ignored by default)."""
    with warnings.catch_warnings():
        if not sys.warnoptions:
            warnings.simplefilter("default", DeprecationWarning)
        warnings.warn(f"plain generation with python -m baselines.said.generate is removed after {REMOVED_AFTER}: "
                      "use python -m benchmark.generate --method said --checkpoint DIR (the folder benchmark.run --checkpoint "
                      "saved) "
                      "--audio WAV --out FILE (the same flags for every method); this command keeps editing "
                      "(--reference/--mask), the authors' weights' options, --export and --image",
                      DeprecationWarning, stacklevel=2)


@cli.command
def main(argv=None) -> int:
    """Command line entry point (see the module docstring); a user mistake is one ``error:`` line and exit 2."""
    p = cli.parser("baselines.said.generate", __doc__)
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
    # the DDIM/DDPM sampling steps of generation, not a training budget
    p.add_argument("--steps", type=int, default=None, help="sampling steps (default: the checkpoint's)")
    p.add_argument("--guidance", type=float, default=None, help="classifier-free guidance gamma (default: the checkpoint's)")
    p.add_argument("--official", action="store_true", help="the checkpoint is the authors' SAiD.pth (detected anyway)")
    p.add_argument("--eta", type=float, default=None, help="DDIM eta in [0, 1] (default: the checkpoint's)")
    p.add_argument("--guidance-rescale", type=float, default=None, help="guidance rescale in [0, 1] (authors' weights)")
    p.add_argument("--strength", type=float, default=1.0, help="editing strength in (0, 1] with --reference (authors' weights)")
    p.add_argument("--intermediates", default=None, metavar="DIR", help="write the chain's states here (authors' weights)")
    p.add_argument("--image", default=None, metavar="PNG", help="also write the coefficients as a labelled image (blendshapes x time, colour bar)")
    cli.add_device_option(p, default="cpu")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    paths = generate_files(
        args.audio, args.out, checkpoint=args.checkpoint, samples=args.samples, seed=args.seed,
        reference_path=args.reference, mask_path=args.mask, sampler=args.sampler,
        num_steps=args.steps, guidance=args.guidance, export=args.export, rig=args.rig,
        official=args.official or None, eta=args.eta, guidance_rescale=args.guidance_rescale,
        strength=args.strength, intermediates_dir=args.intermediates, image_path=args.image,
        device=args.device,
    )
    for path in paths:
        print(path)
    own = (args.reference, args.mask, args.intermediates, args.image, args.guidance_rescale)
    if args.export == "csv" and not args.official and args.strength == 1.0 and all(v is None for v in own):
        warn_plain_generation()  # after the files: a mistake stays one error line
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
