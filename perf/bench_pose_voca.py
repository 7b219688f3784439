"""The joint pose fit on a real VOCA output stream (docs/pose.md, "On a real VOCA output stream").

    python perf/bench_pose_voca.py --meshes DIR --template PLY

DIR holds the 25 frames ``00000.obj`` ... ``00024.obj`` of
``generated_animations/stream/meshes`` and PLY is ``template/FLAME_sample.ply``, both
from the user's copy of TimoBolkart/voca. The frames are not on its master: they are in
commit bcf4ddfe4fcfa215acb1ba29979cf84190ab5eef (pull request 123, head a3f53e75),
e.g. ``git show bcf4ddfe:generated_animations/stream/meshes/00000.obj``. VOCA's terms:
never committed here.

The ARKit reference rig is transferred onto a FLAME head as the build does
(``blendvoca.builder.speaker_rig``: 68-landmark correspondence, 4580-vertex head crop),
and the frames are unposed and fitted four ways, each measured on that head crop:

(a) pose removal on FLAME's stable region, then the fit (``fit_sequence(...,
    pose_fit="remove")``, the default for FLAME meshes before (c) became it);
(b) plain Kabsch on the upper head (the head crop above the nose base, FLAME landmark
    33, unweighted: ``remove_head_pose(..., iterations=0)``), then the same fit;
(c) the joint fit (``fit_pose_and_coefficients``, defaults);
(d) ``fit_sequence``'s default on FLAME meshes, which is (c): its residual is printed
    beside (c)'s, and must be the same.

Two rigs: one on PLY and one on the stream's own frame with the smallest lip aperture
(the stream's upper head is not PLY's: the first line of each section says by how
much). Printed per rig: RMS residual (mm), largest rotation, correlation of jawOpen
with the lip aperture (inner-lip landmarks 62 and 66), then per frame the rotation each
path removes (degrees, relative to the rig's neutral). The stream is at 24 fps (that
branch's commit "downgrade frame rate to 24"): the rate bound is scaled to it (0.1
per 60 fps frame is 0.25 per frame) instead of resampling, so a row is a frame.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blendvoca.assets import load_index_list  # noqa: E402
from blendvoca.builder import lip_aperture, speaker_rig  # noqa: E402
from blendvoca.builder.fit_stage import LIP_LANDMARKS  # noqa: E402
from blendvoca.fit import fit_sequence, remove_head_pose  # noqa: E402
from blendvoca.fit.joint_pose import fit_pose_and_coefficients  # noqa: E402
from blendvoca.io.mesh import read_mesh  # noqa: E402
from blendvoca.rig import load_arkit_reference  # noqa: E402


def compare(neutral, faces, frames, fps):
    """The four paths on one rig: {label: (FitResult, HeadPose)}, the rig, the upper-head mismatch (mm)."""
    landmarks, head = load_index_list("flame-landmarks"), load_index_list("flame-head-idx")
    rig = speaker_rig(load_arkit_reference("speech"), neutral, faces, load_index_list("arkit-landmarks"),
                      landmarks, head)
    delta = 0.1 * 60.0 / fps
    upper = head[neutral[head, 1] > neutral[landmarks[33], 1]]
    a = fit_sequence(rig.neutral, rig.deltas, frames, vertex_subset=head, rate_bound=delta, pose_fit="remove")
    kabsch = remove_head_pose(frames, rig.neutral, stable=upper, iterations=0)
    b = fit_sequence(rig.neutral, rig.deltas, kabsch.frames, vertex_subset=head, rate_bound=delta, unposed=True)
    c = fit_pose_and_coefficients(rig.neutral, rig.deltas, frames, vertex_subset=head, rate_bound=delta)
    mismatch = 1000 * np.sqrt(np.mean(np.sum((kabsch.frames[:, upper] - neutral[upper]) ** 2, axis=2)))
    paths = {"(a) pose removal, then fit": (a, a.pose), "(b) plain Kabsch, upper head": (b, kabsch),
             "(c) joint fit": (c.fit, c.pose)}
    d = fit_sequence(rig.neutral, rig.deltas, frames, vertex_subset=head, rate_bound=delta)
    paths["(d) fit_sequence's default"] = (d, d.pose)
    return paths, rig, mismatch, c


def report(title, paths, rig, mismatch, joint, aperture):
    jaw = rig.names.index("jawOpen")
    print(f"\n## rig on {title}\nupper head vs the neutral after plain Kabsch, before any fit: {mismatch:.2f} mm rms")
    print(f"joint fit: {joint.iterations} alternations, converged {joint.converged}\n")
    print("| path | rms residual, mm | largest rotation, deg | jawOpen vs lip aperture, r |\n|---|---:|---:|---:|")
    for label, (fit, pose) in paths.items():
        r = np.corrcoef(fit.coeffs[:, jaw], aperture)[0, 1]
        print(f"| {label} | {1000 * np.sqrt(np.mean(fit.rmse ** 2)):.3f} | {pose.angles_deg.max():.2f} | {r:.3f} |")
    print("\n| frame | lip aperture, mm | rotation (a) | (b) | (c) | jawOpen (c) |\n|---:|---:|---:|---:|---:|---:|")
    angles = [pose.angles_deg for _, pose in list(paths.values())[:3]]
    for t in range(len(aperture)):
        print(f"| {t} | {1000 * aperture[t]:.2f} | " + " | ".join(f"{a[t]:.2f}" for a in angles)
              + f" | {joint.coeffs[t, jaw]:.3f} |")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", type=Path, required=True, help="folder of the stream's OBJ frames")
    parser.add_argument("--template", type=Path, required=True, help="FLAME_sample.ply")
    parser.add_argument("--fps", type=float, default=24.0, help="frame rate of the stream (default 24)")
    args = parser.parse_args(argv)
    paths = sorted(args.meshes.glob("*.obj"))
    if not paths:
        parser.error(f"no .obj frames in {args.meshes}")
    frames = np.stack([read_mesh(p)[0] for p in paths])
    template, faces = read_mesh(args.template)
    if frames.shape[1:] != template.shape:
        parser.error(f"frames {frames.shape[1:]} and template {template.shape} differ in topology")
    landmarks = load_index_list("flame-landmarks")
    aperture = lip_aperture(frames, *landmarks[list(LIP_LANDMARKS)])
    closed = int(np.argmin(aperture))
    print(f"{len(frames)} frames from {args.meshes}, {args.fps:g} fps; head crop: flame-head-idx (4580 vertices)")
    for title, neutral in ((args.template.name, template),
                           (f"frame {closed} of the stream (smallest lip aperture)", frames[closed])):
        report(title, *compare(neutral, faces, frames, args.fps), aperture)
    return 0


if __name__ == "__main__":
    sys.exit(main())
