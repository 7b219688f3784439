"""Quality report of a retargeted rig: displacement, region, mirror consistency, coverage."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from blendvoca.errors import UserError
from blendvoca.names import mirror_pairs
from blendvoca.rig import Rig

from ._checks import as_indices
from .registration import face_normals, vertex_normals

# iBUG 300-W 68-point groups
LANDMARK_REGIONS: dict[str, tuple[int, int]] = {
    "jaw": (0, 17),
    "brows": (17, 27),
    "nose": (27, 36),
    "eyes": (36, 48),
    "outer lips": (48, 60),
    "inner lips": (60, 68),
}
# landmarks on the facial midline (nose bridge and tip, philtrum, lips, chin)
MIDLINE_LANDMARKS: tuple[int, ...] = (8, 27, 28, 29, 30, 33, 51, 57, 62, 66)


def mirror_vertex_map(
    vertices: np.ndarray, faces: np.ndarray, plane_x: float, *, axis: int = 0, neighbours: int = 8
) -> tuple[np.ndarray, np.ndarray]:
    """Mirror partner of every vertex across the plane ``x[axis] = plane_x``.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) int ndarray
        For vertex normals: a partner must face the mirrored way, which keeps the
        touching upper and lower lips (or eyelids) apart.
    plane_x : float
    axis : int
        Left-right axis (0: x, as in FLAME and ARKit).
    neighbours : int
        Candidates examined per vertex.

    Returns
    -------
    partner : (V,) int64 ndarray
        Nearest compatible vertex to each vertex's reflection (the nearest vertex
        when none is compatible).
    distance : (V,) float64 ndarray
        How far the partner is from the exact reflection (0 on a symmetric mesh).
    """
    V = np.asarray(vertices, dtype=np.float64)
    reflected = V.copy()
    reflected[:, axis] = 2 * plane_x - reflected[:, axis]
    normals = vertex_normals(V, np.asarray(faces, dtype=np.int64))
    mirrored_normals = normals.copy()
    mirrored_normals[:, axis] *= -1
    k = min(neighbours, len(V))
    distance, candidate = cKDTree(V).query(reflected, k=k)
    distance, candidate = distance.reshape(len(V), k), candidate.reshape(len(V), k)
    ok = np.einsum("vkc,vc->vk", normals[candidate], mirrored_normals) > 0.5
    ok[~ok.any(axis=1), 0] = True
    first = np.argmax(ok, axis=1)
    rows = np.arange(len(V))
    return candidate[rows, first].astype(np.int64), distance[rows, first]


def mirror_errors(
    deltas_left: np.ndarray, deltas_right: np.ndarray, partner: np.ndarray, *, axis: int = 0
) -> np.ndarray:
    """How far a right shape is from the mirror image of its left partner.

    Parameters
    ----------
    deltas_left, deltas_right : (V, 3) float ndarray
    partner : (V,) int ndarray
        From `mirror_vertex_map`.
    axis : int

    Returns
    -------
    error : (V,) float64 ndarray
        ``|| reflect(deltas_left[partner[v]]) - deltas_right[v] ||``.
    """
    mirrored = np.array(deltas_left, dtype=np.float64)[partner]
    mirrored[:, axis] *= -1
    return np.linalg.norm(mirrored - deltas_right, axis=1)


def flipped_faces(neutral: np.ndarray, delta: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces whose normal turns by more than 90 degrees in a shape, ``(N,) int64``."""
    before = face_normals(neutral, faces)
    after = face_normals(neutral + delta, faces)
    return np.flatnonzero(np.einsum("ij,ij->i", before, after) < 0)


def retarget_report(
    rig: Rig,
    landmarks: np.ndarray,
    *,
    source: Rig | None = None,
    coverage: dict[str, float] | None = None,
    symmetric: bool = True,
    axis: int = 0,
    region_fraction: float = 0.25,
    seam: np.ndarray | None = None,
) -> dict:
    """Per-shape quality figures of a retargeted rig (millimetres for lengths).

    Parameters
    ----------
    rig : Rig
        Retargeted rig, positions in metres.
    landmarks : (68,) int ndarray
        iBUG 68 landmarks on the rig's mesh (names the region a shape moves).
    source : Rig, optional
        The source rig, for the source's largest displacement of each shape.
    coverage : dict, optional
        `Correspondence.coverage` figures, copied into the report.
    symmetric : bool
        The target is left/right symmetric: report mirror consistency of the pairs.
    axis : int
        Left-right axis.
    region_fraction : float
        A landmark group is in a shape's region when its mean landmark displacement
        exceeds this fraction of the largest group mean.
    seam : (S,) int ndarray, optional
        Vertices on the crop seam (their largest displacement is reported).

    Returns
    -------
    report : dict
        ``{"shapes": {name: {...}}, "mirror": {...}, "coverage": {...}, "summary": {...}}``.
    """
    lm = as_indices(landmarks, rig.num_vertices, "retarget_report", name="landmarks")
    if len(lm) != 68:
        raise UserError(f"retarget_report: expected the 68 iBUG landmarks, got {len(lm)}")
    mm = 1000.0
    shapes = {}
    for name, delta in zip(rig.names, rig.deltas):
        mag = np.linalg.norm(delta, axis=1)
        groups = {g: float(mag[lm[a:b]].mean() * mm) for g, (a, b) in LANDMARK_REGIONS.items()}
        top = max(groups.values())
        entry = {
            "max_mm": float(mag.max() * mm),
            "mean_mm": float(mag.mean() * mm),
            "finite": bool(np.all(np.isfinite(delta))),
            "flipped_faces": len(flipped_faces(rig.neutral, delta, rig.faces)),
            "landmark_groups_mm": groups,
            "region": [g for g, v in groups.items() if top > 0 and v >= region_fraction * top],
            "moved_vertices": int(np.sum(mag > 0.1 * max(mag.max(), 1e-300))),
        }
        if seam is not None and len(seam):
            entry["seam_max_mm"] = float(mag[np.asarray(seam)].max() * mm)
        if source is not None and name in source.names:
            s = np.linalg.norm(source.deltas[source.names.index(name)], axis=1).max()
            entry["source_max_mm"] = float(s * mm)
        shapes[name] = entry
    report = {"shapes": shapes}
    if symmetric:
        plane = float(rig.neutral[lm[list(MIDLINE_LANDMARKS)], axis].mean())
        partner, gap = mirror_vertex_map(rig.neutral, rig.faces, plane, axis=axis)
        mirror = {"plane": plane, "mesh_asymmetry_mm": float(np.median(gap) * mm), "pairs": {}}
        for left, right in mirror_pairs(rig.names):
            dl, dr = rig.deltas[rig.names.index(left)], rig.deltas[rig.names.index(right)]
            err = mirror_errors(dl, dr, partner, axis=axis)
            scale = max(np.linalg.norm(dl, axis=1).max(), np.linalg.norm(dr, axis=1).max(), 1e-300)
            rms = np.sqrt(0.5 * (np.sum(dl**2) + np.sum(dr**2)) / len(dl))
            mirror["pairs"][f"{left}/{right}"] = {
                "max_mm": float(err.max() * mm),
                "p99_mm": float(np.percentile(err, 99) * mm),
                "mean_mm": float(err.mean() * mm),
                "max_relative": float(err.max() / scale),
                # error energy relative to the shapes' own displacement energy
                "rms_relative": float(np.sqrt(np.mean(err**2)) / max(rms, 1e-300)),
            }
        report["mirror"] = mirror
    if coverage is not None:
        report["coverage"] = {k: float(v) for k, v in coverage.items()}
    report["summary"] = {
        "shapes": len(rig.names),
        "all_finite": all(s["finite"] for s in shapes.values()),
        "largest_displacement_mm": max((s["max_mm"] for s in shapes.values()), default=0.0),
        "flipped_faces_total": int(sum(s["flipped_faces"] for s in shapes.values())),
    }
    if symmetric and report["mirror"]["pairs"]:
        report["summary"]["worst_mirror_relative"] = max(p["max_relative"] for p in report["mirror"]["pairs"].values())
        report["summary"]["worst_mirror_rms_relative"] = max(p["rms_relative"] for p in report["mirror"]["pairs"].values())
    return report


def report_markdown(report: dict, *, title: str = "Retargeting report") -> str:
    """The report of `retarget_report` as a Markdown page."""
    lines = [f"# {title}", ""]
    s = report["summary"]
    lines += [f"- shapes: {s['shapes']}", f"- all finite: {s['all_finite']}",
              f"- largest displacement: {s['largest_displacement_mm']:.2f} mm",
              f"- flipped faces (all shapes): {s['flipped_faces_total']}"]
    if "worst_mirror_relative" in s:
        lines.append(f"- worst mirror-pair error: {100 * s['worst_mirror_relative']:.1f} % of the shape's largest displacement "
                     f"(RMS: {100 * s['worst_mirror_rms_relative']:.1f} % of the shapes' RMS displacement)")
    if "coverage" in report:
        lines += [f"- {k.replace('_', ' ')}: {100 * v:.1f} %" for k, v in report["coverage"].items()]
    lines += ["", "| shape | max mm | mean mm | source max mm | region | flipped | seam max mm |", "|---|---|---|---|---|---|---|"]
    for name, e in report["shapes"].items():
        src = f"{e['source_max_mm']:.2f}" if "source_max_mm" in e else ""
        seam = f"{e['seam_max_mm']:.2f}" if "seam_max_mm" in e else ""
        lines.append(f"| {name} | {e['max_mm']:.2f} | {e['mean_mm']:.3f} | {src} | {', '.join(e['region'])} | {e['flipped_faces']} | {seam} |")
    if "mirror" in report:
        m = report["mirror"]
        lines += ["", f"Mirror pairs (plane x = {m['plane']:.4f}, median mesh asymmetry {m['mesh_asymmetry_mm']:.3f} mm):", "",
                  "| pair | max mm | p99 mm | mean mm | max / shape max | RMS / shape RMS |", "|---|---|---|---|---|---|"]
        for pair, e in m["pairs"].items():
            lines.append(f"| {pair} | {e['max_mm']:.3f} | {e['p99_mm']:.3f} | {e['mean_mm']:.4f} | "
                         f"{100 * e['max_relative']:.1f} % | {100 * e['rms_relative']:.1f} % |")
    return "\n".join(lines) + "\n"
