"""``python -m benchmark.generate``: any method of the registry animates one WAV.

::

    python -m benchmark.generate --method NAME [--checkpoint DIR] --audio WAV \\
        [--style S] [--samples N] [--seed K] --out FILE [--image PNG]

The same flags for every method (``python -m benchmark.run --list`` names them):

- ``--checkpoint DIR`` is a folder ``python -m benchmark.run --method NAME --checkpoint
  DIR`` trained and saved (or a released weights file the method reads, whose speakers'
  templates come from ``--data``, default the bundled build). A method that trains
  needs one; a method that trains nothing (``static``, ``random``) runs without.
- ``--audio`` is a WAV at any rate, mono or stereo (resampled to 16 kHz mono, as the
  methods take it); the animation has one 60 fps frame per 1/60 s of it.
- ``--style S`` is the speaker to animate, for methods whose output depends on the
  speaker (vertex methods: its template; an unknown name is refused with the list of
  the method's speakers); the default is the method's first (a training speaker).
- ``--samples N`` (default 1) samples of a stochastic method, drawn from ``--seed``; a
  deterministic method gives one.
- ``--out FILE``, format by suffix: a coefficient method writes ``.csv`` (the 32
  BlendVOCA names as header, 60 fps; with ``--samples N > 1`` the files
  ``<stem>-0.csv`` ... ``<stem>-<N-1>.csv``) or ``.npy`` (``(S, T, 32)`` float64); a
  vertex method writes ``.npy`` (``(S, T, V, 3)`` float32 metres, as
  ``python -m baselines.cdface`` does). ``python -m blendvoca.export`` turns a CSV into
  Live Link, ARKit or A2F JSON, glTF or USD.
- ``--image PNG`` (coefficient methods) also draws each sample as a labelled image: a
  row per blendshape name, time in seconds, the method and the audio file in the title,
  the values on a colour bar.

What is refused, as one ``error:`` line and exit status 2 with nothing written: an
unknown method, a method that looks its output up in the corpus (``ground-truth``,
the oracles, ``mesh-adapter``, ``corpus-meshes``), a missing or untrained checkpoint
for a method that trains, an audio file that is missing, empty or does not decode, an
unknown ``--style``, a suffix the method's output has no format for. A method whose
output breaks the contract is exit status 3, nothing written.
"""

from __future__ import annotations

import io
import os
import sys
from pathlib import Path

import numpy as np

from benchmark.methods import (
    AUDIO_RATE,
    COEFFICIENT_NAMES,
    FPS,
    OUTPUT_VERTICES,
    Budget,
    Method,
    Utterance,
    get_method,
    method_schema,
    validated_tracks,
    validated_vertices,
)
from benchmark.protocol.spec import default_data_root, open_data
from benchmark.protocol.training import make_method, prepared_method
from blendvoca import cli
from blendvoca.builder.report import coefficient_strip_figure
from blendvoca.errors import DataError, MethodError, UserError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.audio import load_audio
from blendvoca.io.coeffs import format_coeffs_csv

__all__ = ["OUTPUT_SUFFIXES", "generate_file", "generated_animation", "main", "output_paths", "ready_method"]

#: The ``--out`` suffixes of each output kind.
OUTPUT_SUFFIXES = {"coefficients": (".csv", ".npy"), "vertices": (".npy",)}


def trains(cls) -> bool:
    """Whether the method class learns its state in ``train`` (it needs a checkpoint to generate)."""
    return getattr(cls, "train", None) is not Method.train


def _checked_request(name: str, out, samples: int) -> type:
    """The method class of ``name``, after the checks that need no file read: it animates new
    audio, ``out``'s suffix is one its output kind has, ``samples`` is a count it gives."""
    cls = get_method(name)
    if not getattr(cls, "new_audio", True):
        raise UserError(f"method {name!r} looks its output up by subject and sentence in the corpus it read "
                        f"(a reference row of the benchmark): it cannot animate a new recording; choose a method "
                        f"that animates audio (python -m benchmark.run --list)")
    kind = getattr(cls, "output", "coefficients")
    suffix = Path(os.fspath(out)).suffix.lower()
    if suffix not in OUTPUT_SUFFIXES[kind]:
        raise UserError(f"--out {os.fspath(out)}: method {name!r} outputs {kind}, written as "
                        f"{' or '.join(OUTPUT_SUFFIXES[kind])}; got the suffix {suffix or '(none)'!r}")
    if isinstance(samples, bool) or int(samples) != samples or samples < 1:
        raise UserError(f"--samples: expected an integer >= 1, got {samples!r}")
    if samples > 1 and not getattr(cls, "stochastic", False):
        raise UserError(f"--samples {samples}: method {name!r} is deterministic (one animation per recording); "
                        "leave --samples out")
    return cls


def ready_method(name: str, *, checkpoint=None, config=None, data=None, device=None):
    """The method ``name`` ready to generate: loaded from ``checkpoint`` (a folder its
    ``save`` wrote, or a released weights file read with the build at ``data``, default
    the bundled one), or built from ``config`` when it trains nothing.

    Raises
    ------
    UserError
        No checkpoint for a method that trains; a checkpoint that is missing, empty, or
        another method's; a config the checkpoint was not trained with.
    MethodError
        The method failed to load its own checkpoint.
    """
    cls = get_method(name)
    config = dict(config or {})
    if checkpoint is None:
        if trains(cls):
            raise UserError(f"method {name!r} is trained: give --checkpoint DIR, a folder "
                            f"`python -m benchmark.run --method {name} --checkpoint DIR` trains and saves")
        return make_method(name, config)
    path = Path(os.fspath(checkpoint)).expanduser()
    if not path.exists():
        raise UserError(f"--checkpoint {path}: no such folder or file; train one with "
                        f"`python -m benchmark.run --method {name} --checkpoint {path}`")
    if path.is_dir() and not any(path.iterdir()):
        raise UserError(f"--checkpoint {path}: an empty folder, no trained method; train one with "
                        f"`python -m benchmark.run --method {name} --checkpoint {path}`")
    dataset = None
    if path.is_file():  # released weights: their ``train`` reads the speakers' templates from a build
        root = data if data is not None else default_data_root()
        dataset = open_data(root)
    method, _ = prepared_method(name, config, dataset, seed=0, budget=Budget(), checkpoint=path, device=device)
    return method


def _speaker(method, name: str, style: str | None) -> str:
    """The ``Utterance.subject`` for ``style``: one of the method's :meth:`~Method.styles` (the first
    by default), or a placeholder for a method whose output does not depend on the speaker."""
    styles = method.styles()
    if styles is None:
        if style is not None:
            raise UserError(f"--style {style}: method {name!r} animates no speaker style (its output does not "
                            "depend on the speaker); leave --style out")
        return "speaker"
    styles = tuple(styles)
    if not styles:
        raise UserError(f"method {name!r} holds no speaker to animate (an untrained checkpoint?)")
    if style is None:
        return styles[0]
    if style not in styles:
        raise UserError(f"--style {style}: method {name!r} knows no such speaker; expected one of {', '.join(styles)}")
    return style


def generated_animation(method, audio, *, name: str, style: str | None = None, samples: int = 1, seed: int = 0,
                        sentence: str = "input"):
    """``(S, T, 32)`` float64 coefficients or ``(S, T, V, 3)`` float64 vertices of ``method`` for
    16 kHz mono ``audio``, checked against the contract (``T`` = the audio's 60 fps frames).

    Raises
    ------
    UserError
        An unknown ``style``.
    MethodError
        The method raised, or its output breaks the contract (:class:`~blendvoca.errors.MethodOutputError`).
    """
    audio = np.asarray(audio, dtype=np.float32)
    num_frames = max(1, int(round(audio.shape[0] / AUDIO_RATE * FPS)))
    subject = _speaker(method, name, style)
    utterance = Utterance(subject=subject, sentence=sentence, split="test", audio=audio, num_frames=num_frames)
    try:
        output = method.generate(utterance, samples=int(samples), seed=int(seed))
    except (UserError, DataError):
        raise
    except Exception as exc:
        raise MethodError(f"method {name!r}: generate failed on {sentence}: {type(exc).__name__}: {exc}") from exc
    where = {"method": name, "subject": subject, "sentence": sentence, "num_frames": num_frames,
             "samples": int(samples)}
    if getattr(method, "output", "coefficients") == OUTPUT_VERTICES:
        shape = np.shape(output)
        return validated_vertices(output, num_vertices=shape[2] if len(shape) == 4 else -1, **where)
    tracks, _ = validated_tracks(output, num_coeffs=len(COEFFICIENT_NAMES), **where)
    return tracks


def output_paths(out, samples: int) -> list[Path]:
    """The files ``samples`` CSV samples go to: ``out`` itself for one, else ``<stem>-<k><suffix>``."""
    out = Path(os.fspath(out))
    if samples == 1:
        return [out]
    return [out.with_name(f"{out.stem}-{k}{out.suffix}") for k in range(samples)]


def _write(out: Path, animation: np.ndarray, kind: str) -> list[Path]:
    """Write ``animation`` in ``out``'s format (every file's bytes made before the first is written)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".npy":
        buffer = io.BytesIO()
        np.save(buffer, animation.astype(np.float32 if kind == OUTPUT_VERTICES else np.float64))
        files = {out: buffer.getvalue()}
    else:
        files = {path: format_coeffs_csv(track, COEFFICIENT_NAMES).encode("utf-8")
                 for path, track in zip(output_paths(out, animation.shape[0]), animation)}
    for path, payload in files.items():
        with atomic_write(path, "wb") as handle:
            handle.write(payload)
    return list(files)


def _write_images(image, animation: np.ndarray, *, method: str, audio: Path) -> list[Path]:
    """The coefficient samples of ``animation`` (S, T, 32) as labelled images
    (:func:`blendvoca.builder.report.coefficient_strip_figure`): ``image`` for one sample,
    ``<stem>-<k>.png`` for several."""
    paths = output_paths(image, animation.shape[0])
    for k, (path, track) in enumerate(zip(paths, animation)):
        path.parent.mkdir(parents=True, exist_ok=True)
        sample = f", sample {k} of {len(paths)}" if len(paths) > 1 else ""
        coefficient_strip_figure(path, track, COEFFICIENT_NAMES, title=f"{method}: {audio.name}{sample}", fps=FPS)
    return paths


def generate_file(method: str, audio, out, *, checkpoint=None, style: str | None = None, samples: int = 1,
                  seed: int = 0, config=None, data=None, device=None, image=None) -> list[Path]:
    """Animate the WAV ``audio`` with the registered ``method`` and write ``out`` (format by suffix),
    and with ``image`` (a ``.png`` path; coefficient methods) the coefficients as a labelled image.

    Paths are ``str`` or ``os.PathLike``. Everything is checked, the method loaded and the
    animation generated and checked before the first byte is written.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    UserError
        A mistake in what was asked (module docstring); nothing written.
    DataError
        An audio file that is empty or does not decode; nothing written.
    MethodError
        The method failed or broke the contract; nothing written.
    """
    cls = _checked_request(method, out, samples)
    kind = getattr(cls, "output", "coefficients")
    if image is not None:
        if kind == OUTPUT_VERTICES:
            raise UserError(f"--image {os.fspath(image)}: method {method!r} outputs vertices; the image draws "
                            "coefficients (python -m benchmark.render draws vertices); leave --image out")
        if Path(os.fspath(image)).suffix.lower() != ".png":
            raise UserError(f"--image {os.fspath(image)}: expected a .png file, got the suffix "
                            f"{Path(os.fspath(image)).suffix or '(none)'!r}")
    audio_path = Path(os.fspath(audio)).expanduser()
    if not audio_path.is_file():
        raise UserError(f"--audio {audio_path}: no such file; expected a WAV recording")
    samples_16k = load_audio(audio_path, rate=AUDIO_RATE)  # any rate and channels; empty or undecodable: DataError
    trained = ready_method(method, checkpoint=checkpoint, config=config, data=data, device=device)
    animation = generated_animation(trained, samples_16k, name=method, style=style, samples=samples, seed=seed,
                                    sentence=audio_path.stem)
    written = _write(Path(os.fspath(out)), animation, kind)
    if image is not None:
        written += _write_images(Path(os.fspath(image)), animation, method=method, audio=audio_path)
    return written


@cli.command
def main(argv=None) -> int:
    """Command line entry point (see the module docstring)."""
    p = cli.parser("benchmark.generate", __doc__)
    p.add_argument("--method", required=True, help="registered or installed method (python -m benchmark.run --list)")
    p.add_argument("--checkpoint", default=None, metavar="DIR",
                   help="the folder `benchmark.run --method NAME --checkpoint DIR` saved (or a released weights "
                        "file); needed by methods that train")
    p.add_argument("--audio", required=True, metavar="WAV", help="speech to animate (any rate, mono or stereo)")
    p.add_argument("--style", default=None, metavar="S",
                   help="speaker to animate, for methods whose output depends on it (default: the method's first)")
    p.add_argument("--samples", type=int, default=1, metavar="N", help="samples of a stochastic method (default 1)")
    p.add_argument("--seed", type=int, default=0, metavar="K", help="sampling seed (default 0)")
    p.add_argument("--out", required=True, metavar="FILE",
                   help="coefficients: .csv (N > 1: FILE-0.csv ...) or .npy (S, T, 32); vertices: .npy (S, T, V, 3)")
    p.add_argument("--image", default=None, metavar="PNG",
                   help="also draw the coefficients as a labelled image (a row per blendshape, time in seconds, "
                        "the method and audio in its title; N > 1: PNG-0.png ...); coefficient methods")
    cli.add_data_option(p)
    cli.add_config_options(p)
    cli.add_device_option(p, default="cpu")
    cli.add_quiet_option(p)
    args = p.parse_args(argv)
    cli.require_address_space("benchmark.generate")
    schema = method_schema(args.method)  # an unknown method: exit 2 before any file is read
    config = cli.parse_config(args.config, preset=args.preset, schema=schema, method=args.method)
    device = cli.checked_device(args.device)
    paths = generate_file(args.method, args.audio, args.out, checkpoint=args.checkpoint, style=args.style,
                          samples=args.samples, seed=args.seed, config=config, data=args.data, device=device,
                          image=args.image)
    for path in paths:
        print(path)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
