"""Transfer the ARKit blendshapes (or another rig's) onto a head mesh by deformation transfer.

``python -m blendvoca.retarget --target MESH --target-landmarks TXT --out DIR``: the
command line over :func:`retarget_files`.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np

from blendvoca import cli
from blendvoca.assets import load_index_list
from blendvoca.io.atomic import atomic_write
from blendvoca.io.mesh import read_index_list, read_mesh
from blendvoca.rig import Rig, load_arkit_reference, shape_names

from .contact_sheet import contact_sheet
from .crop import default_crop
from .pipeline import plan_retarget, retargeted_deltas
from .report import CROP_DEPTH, face_axes, report_markdown, retarget_report, suggested_crop


def retarget_files(
    target: str | os.PathLike,
    target_landmarks: str | os.PathLike,
    out: str | os.PathLike,
    *,
    source_rig: str | os.PathLike | None = None,
    source_landmarks: str | os.PathLike | None = None,
    crop: str | os.PathLike | None = None,
    shapes: str = "speech",
    falloff: float = 0.02,
    sheet: bool = True,
) -> dict:
    """Retarget the source rig onto the mesh ``target`` and write the results under ``out``.

    Writes ``Neutral.obj`` and ``<name>.obj`` per shape (full target topology and
    vertex order), ``rig.npz``, ``contact_sheet.png`` and ``report.json`` /
    ``report.md``. The source defaults to the ARKit reference rig and its landmarks.

    The report's warnings (`retarget_warnings`: a dragged neck, triangles that flip,
    left and right shapes that are not mirror images) are printed as ``warning:`` lines
    on stderr; when the neck is dragged, ``suggested_crop.txt`` (the vertices above a
    plane across the neck, `suggested_crop`) is written too and a ``note:`` says how to
    use it.

    Returns
    -------
    report : dict
        As written to ``report.json``.
    """
    names = shape_names(shapes)
    source = load_arkit_reference(names) if source_rig is None else Rig.load_said_folder(source_rig, names)
    lm_s = load_index_list("arkit-landmarks") if source_landmarks is None else read_index_list(source_landmarks)
    V, F = read_mesh(target)
    lm_t = read_index_list(target_landmarks)
    if crop is None:
        keep, note = default_crop(F, len(V))
        if note:
            print(note)
    else:
        keep = read_index_list(crop)
    plan = plan_retarget(source.neutral, source.faces, V, F, lm_s, lm_t, crop=keep, falloff=falloff)
    rig = Rig(V, retargeted_deltas(plan, source.deltas), names, F)
    out = Path(os.fspath(out))
    rig.save_said_folder(out)
    rig.save(out / "rig.npz")
    seam = plan.crop.vertex_index[plan.crop.seam]
    pairs = plan.correspondence.pairs
    face_pairs = np.stack([pairs[:, 0], plan.crop.face_index[pairs[:, 1]]], axis=1)
    report = retarget_report(rig, lm_t, source=source, coverage=plan.correspondence.coverage(), seam=seam,
                             face_pairs=face_pairs)
    for warning in report["warnings"]:
        print(f"warning: {warning['message']}", file=sys.stderr)
    if any(w["kind"] == "neck" for w in report["warnings"]):
        suggestion = suggested_crop(V, lm_t)
        if len(suggestion) < len(V):
            path = out / "suggested_crop.txt"
            with atomic_write(path, "w") as f:
                f.write("".join(f"{int(i)}\n" for i in suggestion))
            below = CROP_DEPTH * face_axes(V, lm_t)[2] * 1000
            report["suggested_crop"] = {"path": str(path), "vertices": len(suggestion), "of": len(V),
                                        "below_chin_mm": below}
            print(f"note: {path} keeps the {len(suggestion)} of {len(V)} vertices above a plane {below:.0f} mm below the "
                  f"chin; retarget with --crop {path} (or a list of the face, scalp and ears of your own)",
                  file=sys.stderr)
    report["alignment"] = {
        "scale": plan.similarity.scale,
        "rotation": plan.similarity.rotation.tolist(),
        "translation": plan.similarity.translation.tolist(),
        "landmark_rms_mm": plan.similarity.rms_residual * 1000,
        "landmark_max_mm": plan.similarity.max_residual * 1000,
    }
    with atomic_write(out / "report.json", "w") as f:
        json.dump(report, f, indent=2)
    with atomic_write(out / "report.md", "w") as f:
        f.write(report_markdown(report, title=f"Retargeting report: {Path(os.fspath(target)).name}"))
    if sheet:
        import matplotlib.image

        image = contact_sheet(rig.neutral, rig.deltas, rig.faces, rig.names)
        with atomic_write(out / "contact_sheet.png", "wb") as f:
            matplotlib.image.imsave(f, image, format="png")
    return report


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("blendvoca.retarget", __doc__)
    parser.add_argument("--target", type=Path, required=True, help="target neutral mesh (.obj or .ply)")
    parser.add_argument("--target-landmarks", type=Path, required=True,
                        help="68 iBUG landmark vertex indices on the full target mesh (one per line)")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument("--source-rig", type=Path, help="source rig folder (Neutral.obj + <name>.obj); default ARKit reference")
    parser.add_argument("--source-landmarks", type=Path, help="68 landmark indices on the source neutral")
    parser.add_argument("--crop", type=Path, help="vertex indices of the target kept during the transfer "
                        "(default: FLAME's head crop on a FLAME-topology target, else the whole mesh)")
    parser.add_argument("--shapes", choices=("speech", "all"), default="speech")
    parser.add_argument("--falloff", type=float, default=0.02,
                        help="distance (target units) over which re-attached vertices blend back to rest")
    parser.add_argument("--no-sheet", action="store_true", help="skip the contact sheet image")
    args = parser.parse_args(argv)
    report = retarget_files(args.target, args.target_landmarks, args.out, source_rig=args.source_rig,
                            source_landmarks=args.source_landmarks, crop=args.crop, shapes=args.shapes,
                            falloff=args.falloff, sheet=not args.no_sheet)
    print(summary_line(report, args.out))
    return cli.EXIT_OK


def summary_line(report: dict, out) -> str:
    """The command's last line: what was written and the quality figures, warnings counted."""
    s = report["summary"]
    parts = [f"{s['shapes']} shapes written to {out}", f"largest displacement {s['largest_displacement_mm']:.1f} mm",
             f"landmark RMS {report['alignment']['landmark_rms_mm']:.2f} mm"]
    flips = f"flipped faces {s['flipped_faces_total']}"
    if s.get("flipped_faces_new_total", s["flipped_faces_total"]) != s["flipped_faces_total"]:
        flips += f" ({s['flipped_faces_new_total']} not folded in the source)"
    parts.append(flips)
    if "worst_mirror_rms_relative" in s:
        parts.append(f"worst mirror-pair error {100 * s['worst_mirror_rms_relative']:.0f} % ({s['worst_mirror_pair']})")
    if "worst_neck_mm" in s:
        parts.append(f"neck moved by at most {s['worst_neck_mm']:.1f} mm ({s['worst_neck_mm_shape']})")
    count = len(report.get("warnings", []))
    parts.append(f"{count} warning{'s' if count != 1 else ''}" + (" (see report.md)" if count else ""))
    return "; ".join(parts)
