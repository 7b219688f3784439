"""Render a coefficient track (through a rig), a mesh sequence, or a stored run's ground
truth next to the method's track, to MP4 with the audio and a waveform strip.

``python -m benchmark.render (--coeffs CSV --rig RIG | --meshes SEQ | --run JSON ...) --out MP4``.
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


def _track_vertices(csv_path, rig, where: str):
    """Vertices of a coefficient CSV through ``rig``; rig shapes the CSV lacks are 0 (noted)."""
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
    return rig.evaluate(coeffs)


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
    from blendvoca.io.mesh import read_mesh, read_ply_sequence

    path = Path(path)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in (".ply", ".obj"))
        if not files:
            raise UserError(f"{path} holds no .ply/.obj frames")
        first_v, first_f = read_mesh(files[0])
        if all(p.suffix.lower() == ".ply" for p in files):
            vertices = read_ply_sequence(files, num_vertices=len(first_v))
        else:
            frames = [read_mesh(p)[0] for p in files]
            for p, v in zip(files, frames):
                if v.shape != first_v.shape:
                    raise DataError(f"{p}: {len(v)} vertices, the first frame {files[0].name} has {len(first_v)}; "
                                    "the frames of a sequence share one topology")
            vertices = np.stack(frames)
        return vertices, _mesh_faces(first_f, vertices.shape[1], faces_path, str(path))
    if not path.is_file():
        raise UserError(f"mesh sequence not found: {path}")
    if path.suffix != ".npy":
        raise UserError(f"{path}: expected a .npy (T, V, 3) array or a folder of .ply/.obj frames")
    try:
        vertices = np.load(path, allow_pickle=False)
    except (ValueError, EOFError) as error:  # not a .npy file, truncated, pickled objects
        raise DataError(f"{path}: not a readable .npy array ({error})") from None
    if vertices.ndim != 3 or vertices.shape[2] != 3 or not np.issubdtype(vertices.dtype, np.number):
        raise DataError(f"{path}: expected a numeric array (T, V, 3), got {vertices.dtype} of shape {vertices.shape}")
    if not np.all(np.isfinite(vertices)):
        raise DataError(f"{path}: NaN or infinite coordinates (first in frame "
                        f"{int(np.argwhere(~np.isfinite(vertices))[0][0])})")
    if not faces_path:
        raise UserError("a .npy sequence needs --faces MESH")
    return vertices, _mesh_faces(None, vertices.shape[1], faces_path, str(path))


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
    parser.add_argument("--backend", default="auto", choices=("auto", "pyrender", "software"))
    args = parser.parse_args(argv)
    return _render(args)


#: What ``--out`` may be: the containers the H.264 + AAC encoding is written to.
VIDEO_SUFFIXES = (".mp4",)


def _render(args) -> int:
    from benchmark.render import check_visible, face_camera, front_camera, render_sequence, resample_frames, write_video
    from benchmark.render.compose import label, side_by_side, waveform_strip
    from benchmark.render.video import match_audio_length

    if Path(args.out).suffix.lower() not in VIDEO_SUFFIXES:
        raise UserError(f"--out {args.out}: unsupported file type {Path(args.out).suffix or '(none)'!r}; "
                        f"supported: {', '.join(VIDEO_SUFFIXES)} (H.264 video with AAC audio)")
    if args.size < 16:
        raise UserError(f"--size must be at least 16 pixels, got {args.size}")
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
        panels = [("ground truth", _track_vertices(files.ground_truth, rig, f"{where} ground truth")),
                  (f"{files.method} (sample {args.sample})", _track_vertices(files.generated, rig, f"{where} {files.method}"))]
        faces = rig.faces
        audio_path = audio_path or files.audio
    elif args.coeffs:
        if not args.rig:
            raise UserError("--coeffs needs --rig")
        rig = _load_rig(args.rig)
        panels = [("", _track_vertices(args.coeffs, rig, args.coeffs))]
        faces = rig.faces
    else:
        vertices, faces = _mesh_sequence(args.meshes, args.faces)
        panels = [("", vertices)]
    out_fps = args.out_fps or args.fps
    if out_fps != args.fps:
        panels = [(name, resample_frames(v, args.fps, out_fps)) for name, v in panels]
    reference = panels[0][1][0]
    yfov = np.pi / 8
    views = [face_camera(reference, yfov) if args.framing == "face" else front_camera(reference, yfov)]
    if args.side:
        views.append(face_camera(reference, yfov, side=True))
    rendered = []
    for name, vertices in panels:
        images = []
        for pose in views:
            frames = render_sequence(vertices, faces, size=args.size, backend=args.backend, yfov=yfov, pose=pose,
                                     progress=True)
            check_visible(frames, where=f"render of {name or args.coeffs or args.meshes}")
            images.append(frames)
        joined = np.concatenate(images, axis=2)
        rendered.append(label(joined, name, scale=max(1, args.size // 256)) if name else joined)
    audio = None
    strip = None
    if audio_path:
        from blendvoca.io.audio import load_audio

        if not Path(audio_path).is_file():
            raise UserError(f"audio file not found: {audio_path}")
        audio = load_audio(audio_path, rate=16000)
        rendered = [match_audio_length(r, out_fps, len(audio), 16000) for r in rendered]
        if not args.no_waveform:
            strip = waveform_strip(audio, 16000, len(rendered[0]), out_fps, sum(r.shape[2] for r in rendered),
                                   max(args.size // 5, 16))
    video = side_by_side(rendered, strip)
    write_video(args.out, video, out_fps, audio=audio, rate=16000)
    print(f"wrote {args.out} ({len(video)} frames at {out_fps:g} fps, {video.shape[2]}x{video.shape[1]} px)")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
