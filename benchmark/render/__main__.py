"""``python -m benchmark.render``: render a coefficient track (through a rig) or a
mesh sequence to MP4, with audio."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmark.render", description=__doc__)
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--coeffs", help="coefficient CSV (60 fps); needs --rig")
    src.add_argument("--meshes", help="mesh sequence: .npy (T, V, 3) or a folder of .ply/.obj frames; needs --faces or a mesh folder")
    parser.add_argument("--rig", help="rig .npz (blendvoca.rig.Rig) or SAiD folder (Neutral.obj + <name>.obj)")
    parser.add_argument("--faces", help="mesh file whose faces to use with a .npy sequence")
    parser.add_argument("--audio", help="WAV to mux")
    parser.add_argument("--out", required=True, help="output .mp4")
    parser.add_argument("--fps", type=float, default=60.0, help="input frame rate")
    parser.add_argument("--out-fps", type=float, default=None, help="video frame rate (default: input rate)")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--backend", default="auto", choices=("auto", "pyrender", "software"))
    args = parser.parse_args(argv)

    from benchmark.render import render_sequence, resample_frames, write_video

    if args.coeffs:
        if not args.rig:
            parser.error("--coeffs needs --rig")
        from blendvoca.io.coeffs import read_coeffs_csv
        from blendvoca.rig import Rig

        rig = Rig.load(args.rig) if Path(args.rig).suffix == ".npz" else Rig.load_said_folder(args.rig)
        coeffs, _ = read_coeffs_csv(args.coeffs, names=rig.names)
        vertices = rig.evaluate(np.asarray(coeffs, dtype=np.float64))
        faces = rig.faces
    else:
        from blendvoca.io.mesh import read_mesh

        path = Path(args.meshes)
        if path.is_dir():
            files = sorted(p for p in path.iterdir() if p.suffix in (".ply", ".obj"))
            if not files:
                parser.error(f"{path} holds no .ply/.obj frames")
            meshes = [read_mesh(p) for p in files]
            vertices = np.stack([m[0] for m in meshes])
            faces = meshes[0][1]
        else:
            vertices = np.load(path)
            if not args.faces:
                parser.error("a .npy sequence needs --faces MESH")
            faces = read_mesh(args.faces)[1]
    out_fps = args.out_fps or args.fps
    if out_fps != args.fps:
        vertices = resample_frames(vertices, args.fps, out_fps)
    frames = render_sequence(vertices, faces, size=args.size, backend=args.backend, progress=True)
    audio = None
    if args.audio:
        from blendvoca.io.audio import load_audio

        audio = load_audio(args.audio, rate=16000)
    write_video(args.out, frames, out_fps, audio=audio, rate=16000)
    print(f"wrote {args.out} ({len(frames)} frames at {out_fps:g} fps)")


if __name__ == "__main__":
    main()
