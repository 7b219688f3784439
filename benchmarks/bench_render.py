"""Time ``benchmark.render``'s renders to judge lip sync from.

    BLENDVOCA_ASSETS=../shared/assets python benchmarks/bench_render.py [--frames 60]

Renders a FLAME-size rig (5023 vertices, 32 shapes) through a moving track and prints
ms/frame of: the old default (whole head, 256 px), the face framing at the new default
512 px, the profile view, and the waveform strip and composition, for the numpy
rasteriser and pyrender/EGL (when an EGL context opens), each as a ratio to the first
(software, 256 px, whole head) measured in the same process. Also prints the mouth
width in pixels (FLAME landmarks 48 and 54) at each framing.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return time.perf_counter() - t0, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=60, help="frames rendered per configuration")
    parser.add_argument("--assets", default=os.environ.get("BLENDVOCA_ASSETS", "../shared/assets"))
    args = parser.parse_args()
    assets = Path(args.assets)

    from benchmark.render import face_camera, front_camera, project, render_sequence
    from benchmark.render.compose import side_by_side, waveform_strip
    from benchmark.render.pyrender_backend import egl_available
    from tests.benchmark.fakes import fake_rig, flame_head

    v, f = flame_head(assets)
    rig = fake_rig(v, f)
    t = np.arange(args.frames)[:, None] / 60.0
    coeffs = 0.5 + 0.5 * np.sin(2 * np.pi * np.linspace(1, 4, 32) * t)
    seq = rig.evaluate(coeffs)
    corners = np.loadtxt(assets / "said" / "FLAME_landmarks.txt", dtype=np.int64)[[48, 54]]
    yfov = np.pi / 8
    for name, pose, size in (("whole head", front_camera(v, yfov), 256), ("face", face_camera(v, yfov), 256),
                             ("face", face_camera(v, yfov), 512)):
        xy, _ = project(v[corners], pose, yfov, size, size)
        print(f"mouth width, {name} framing, {size} px: {xy[1, 0] - xy[0, 0]:.1f} px")

    backends = ["software"] + (["pyrender"] if egl_available() else [])
    reference = None
    print(f"== {args.frames} frames, FLAME-size rig ==")
    for backend in backends:
        render_sequence(seq[:2], f, size=64, backend=backend)  # warm-up (imports, EGL context)
        for label, pose, size in (("whole head 256", front_camera(seq, yfov), 256),
                                  ("face 256", face_camera(v, yfov), 256),
                                  ("face 512", face_camera(v, yfov), 512),
                                  ("profile 512", face_camera(v, yfov, side=True), 512)):
            seconds, frames = timed(render_sequence, seq, f, size=size, backend=backend, pose=pose)
            per_frame = seconds / args.frames * 1e3
            reference = reference or per_frame
            print(f"{backend:9s} {label:15s} {per_frame:7.1f} ms/frame  ratio {per_frame / reference:5.2f}")
    audio = np.sin(2 * np.pi * 150 * np.arange(int(args.frames / 60 * 16000)) / 16000).astype(np.float32)
    seconds, strip = timed(waveform_strip, audio, 16000, args.frames, 60.0, 1024, 102)
    print(f"waveform strip 1024 x 102: {seconds / args.frames * 1e3:.2f} ms/frame")
    panel = np.full((args.frames, 512, 512, 3), 255, np.uint8)
    seconds, _ = timed(side_by_side, [panel, panel], strip)
    print(f"composition of two 512 px panels and the strip: {seconds / args.frames * 1e3:.2f} ms/frame")


if __name__ == "__main__":
    main()
