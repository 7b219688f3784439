"""Render a coefficient track (through a rig), a mesh sequence, or a stored run's ground
truth next to the method's track, to MP4 with the audio and a waveform strip.

``python -m benchmark.render (--coeffs CSV --rig RIG | --meshes SEQ | --run JSON ...) --out MP4``.
Frames are streamed to the encoder as they are drawn: memory does not grow with the clip.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca import cli
from blendvoca.errors import DataError, UserError

# At 512 px with the face framing, a FLAME mouth is about 135 px wide.
DEFAULT_SIZE = 512


def _load_rig(path):
    from blendvoca.rig import Rig

    path = Path(path)
    if not path.exists():
        raise UserError(f"rig not found: {path}")
    return Rig.load(path) if path.suffix == ".npz" else Rig.load_said_folder(path)


def _track_source(csv_path, rig, where: str):
    """A frame source of a coefficient CSV through ``rig`` (evaluated a window of frames at a
    time); rig shapes the CSV lacks are 0 (noted)."""
    from benchmark.render.sources import RigSource

    from blendvoca.io.coeffs import missing_columns, read_coeffs_csv

    coeffs, _ = read_coeffs_csv(csv_path, names=rig.names, missing="zero")
    bad = np.argwhere(~np.isfinite(coeffs))
    if len(bad):  # a NaN vertex draws nothing: say so here, not "frames show no face" after rendering
        frame, column = (int(i) for i in bad[0])
        raise DataError(f"{csv_path}: {len(bad)} NaN or infinite coefficient(s), the first at frame {frame} "
                        f"(line {frame + 2}), column {rig.names[column]!r}: {coeffs[frame, column]}")
    absent = missing_columns(csv_path, rig.names)
    if absent:
        print(f"note: {where}: the rig has {len(rig.names)} shapes, the track lacks {len(absent)}; "
              f"they are 0: {', '.join(absent)}", file=sys.stderr)
    return RigSource(coeffs, rig)


def _mesh_faces(faces, num_vertices: int, faces_path, where: str):
    """The faces to draw a sequence with: ``--faces``, the frames' own, or FLAME's."""
    from blendvoca.io.mesh import read_mesh

    if faces_path:
        F = read_mesh(faces_path)[1]
        if len(F) == 0:
            raise UserError(f"--faces {faces_path}: the mesh has no faces")
        if F.max() >= num_vertices:
            raise UserError(f"--faces {faces_path}: faces index {F.max() + 1} vertices, the frames have {num_vertices}")
        return F
    if faces is not None and len(faces):
        return faces
    from blendvoca.retarget.crop import FLAME_VERTEX_COUNT

    if num_vertices == FLAME_VERTEX_COUNT:
        from blendvoca.assets import AssetError, resolve

        try:
            F = read_mesh(resolve("flame-sample", download_missing=False))[1]
        except (AssetError, FileNotFoundError) as error:
            raise UserError(f"{where}: the frames have no faces and the FLAME template is unavailable ({error}); "
                             "pass --faces MESH") from None
        print(f"note: {where}: vertex-only frames with FLAME's 5023 vertices: drawn with the FLAME template's faces",
              file=sys.stderr)
        return F
    raise UserError(f"{where}: the frames have no faces (vertex-only); pass --faces MESH, a mesh with the same "
                     f"{num_vertices} vertices such as the subject's template")


def _mesh_sequence(path, faces_path):
    """A frame source of a mesh sequence (a folder read a window of files at a time, a .npy
    memory-mapped) and the faces to draw it with."""
    from benchmark.render.sources import ArraySource, FileSource, check_finite_chunks
    from blendvoca.io.mesh import read_mesh

    path = Path(path)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in (".ply", ".obj"))
        if not files:
            raise UserError(f"{path} holds no .ply/.obj frames")
        first_v, first_f = read_mesh(files[0])
        source = FileSource(files, len(first_v))
        return source, _mesh_faces(first_f, len(first_v), faces_path, str(path))
    if not path.is_file():
        raise UserError(f"mesh sequence not found: {path}")
    if path.suffix != ".npy":
        raise UserError(f"{path}: expected a .npy (T, V, 3) array or a folder of .ply/.obj frames")
    try:
        vertices = np.load(path, allow_pickle=False, mmap_mode="r")
    except (ValueError, EOFError, OSError) as error:  # not a .npy file, truncated, pickled objects
        raise DataError(f"{path}: not a readable .npy array ({error})") from None
    if vertices.ndim != 3 or vertices.shape[2] != 3 or not np.issubdtype(vertices.dtype, np.number):
        raise DataError(f"{path}: expected a numeric array (T, V, 3), got {vertices.dtype} of shape {vertices.shape}")
    if len(vertices) == 0:
        raise DataError(f"{path}: the sequence has no frames")
    check_finite_chunks(vertices, str(path))
    if not faces_path:
        raise UserError("a .npy sequence needs --faces MESH")
    return ArraySource(vertices, path), _mesh_faces(None, vertices.shape[1], faces_path, str(path))


@cli.command
def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.parser("benchmark.render", __doc__)
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--coeffs", help="coefficient CSV (60 fps; BlendVOCA or Live Link Face columns); needs --rig")
    src.add_argument("--meshes", help="mesh sequence: .npy (T, V, 3) or a folder of .ply/.obj frames")
    src.add_argument("--run", help="stored result JSON with tracks (protocol v2): ground truth next to the method")
    parser.add_argument("--subject", help="with --run: the subject")
    parser.add_argument("--sentence", help="with --run: the sentence, e.g. sentence01")
    parser.add_argument("--sample", type=int, default=0, help="with --run: which generated sample (default 0)")
    parser.add_argument("--rig", help="rig .npz (blendvoca.rig.Rig) or SAiD folder (Neutral.obj + <name>.obj)")
    parser.add_argument("--faces", help="mesh whose faces to draw a .npy or vertex-only sequence with")
    parser.add_argument("--audio", help="WAV to mux (with --run: the sentence's audio by default)")
    parser.add_argument("--out", required=True, help="output .mp4")
    parser.add_argument("--fps", type=float, default=60.0, help="input frame rate")
    parser.add_argument("--out-fps", type=float, default=None, help="video frame rate (default: input rate)")
    parser.add_argument("--size", type=int, default=DEFAULT_SIZE,
                        help=f"side of each square view in pixels (default {DEFAULT_SIZE})")
    parser.add_argument("--framing", choices=("face", "head"), default="face",
                        help="face: brows to chin (default); head: the whole mesh")
    parser.add_argument("--side", action="store_true", help="add a profile view next to the front view")
    parser.add_argument("--no-waveform", action="store_true", help="no waveform strip under the views")
    parser.add_argument("--backend", default="auto", choices=("auto", "pyrender", "software"),
                        help="auto: pyrender on a GPU's EGL, else the numpy rasteriser (default)")
    parser.add_argument("--jobs", type=int, default=None,
                        help="processes drawing frames with the numpy rasteriser (default: the CPUs but one, at "
                             "most 8, for a render of more than a few frames; 1 draws in this process)")
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    return _render(args)


#: What ``--out`` may be: the containers the H.264 + AAC encoding is written to.
VIDEO_SUFFIXES = (".mp4",)


def _render(args) -> int:
    from benchmark.render import face_camera, front_camera
    from benchmark.render.sources import resampled
    from benchmark.render.stream import Panel, render_video

    if Path(args.out).suffix.lower() not in VIDEO_SUFFIXES:
        raise UserError(f"--out {args.out}: unsupported file type {Path(args.out).suffix or '(none)'!r}; "
                        f"supported: {', '.join(VIDEO_SUFFIXES)} (H.264 video with AAC audio)")
    if args.size < 16:
        raise UserError(f"--size must be at least 16 pixels, got {args.size}")
    if args.jobs is not None and args.jobs < 1:
        raise UserError(f"--jobs must be at least 1, got {args.jobs}")
    for flag, rate in (("--fps", args.fps), ("--out-fps", args.out_fps)):
        if rate is not None and not (np.isfinite(rate) and rate > 0):
            raise UserError(f"{flag} must be a positive number of frames per second, got {rate}")
    audio_path = args.audio
    if args.run:
        from benchmark.render.stored_run import locate_sentence

        if not (args.subject and args.sentence):
            raise UserError("--run needs --subject and --sentence")
        files = locate_sentence(args.run, args.subject, args.sentence, args.sample)
        rig = _load_rig(files.rig)
        where = f"{args.subject}/{args.sentence}"
        method = f"{files.method} (sample {args.sample})"
        panels = [Panel("ground truth", _track_source(files.ground_truth, rig, f"{where} ground truth"), "ground truth"),
                  Panel(method, _track_source(files.generated, rig, f"{where} {files.method}"), method)]
        faces = rig.faces
        audio_path = audio_path or files.audio
    elif args.coeffs:
        if not args.rig:
            raise UserError("--coeffs needs --rig")
        rig = _load_rig(args.rig)
        panels = [Panel("", _track_source(args.coeffs, rig, args.coeffs), args.coeffs)]
        faces = rig.faces
    else:
        source, faces = _mesh_sequence(args.meshes, args.faces)
        panels = [Panel("", source, args.meshes)]
    out_fps = args.out_fps or args.fps
    for panel in panels:
        panel.source = resampled(panel.source, args.fps, out_fps)
    reference = panels[0].source.frame(0)
    yfov = np.pi / 8
    views = [face_camera(reference, yfov) if args.framing == "face" else front_camera(reference, yfov)]
    if args.side:
        views.append(face_camera(reference, yfov, side=True))
    audio, rate = None, None
    if audio_path:
        from blendvoca.io.audio import read_audio

        if not Path(audio_path).is_file():
            raise UserError(f"audio file not found: {audio_path}")
        audio, rate = read_audio(audio_path)  # muxed at the recording's own rate and channels
    count, width, height = render_video(args.out, panels, faces, views, fps=out_fps, size=args.size,
                                        backend=args.backend, yfov=yfov, audio=audio, rate=rate,
                                        waveform=not args.no_waveform, jobs=args.jobs)
    print(f"wrote {args.out} ({count} frames at {out_fps:g} fps, {width}x{height} px)")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
