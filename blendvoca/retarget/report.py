"""Quality report of a retargeted rig: displacement, region, mirror consistency, coverage,
and the warnings a transfer onto a head it does not suit raises (flipped triangles, left
and right shapes that are not mirror images, a dragged neck), each with its figure and
the crop to try."""

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
# chin, top of the nose bridge, and the two ends of the jaw line (iBUG 68)
CHIN, NOSE_BRIDGE, JAW_RIGHT_END, JAW_LEFT_END = 8, 27, 0, 16

# When a report warns (see `retarget_warnings`; measured in docs/retarget.md: the FLAME
# template with its head crop stays below each by a factor of 1.4 or more, the same head
# transferred whole drags the neck by half of jawOpen's travel).
#: The neck: vertices lower than the chin by this fraction of the chin-to-nose-bridge height.
NECK_DEPTH = 0.5
#: A shape drags the neck when it moves it by more than this fraction of its largest displacement.
NECK_LIMIT = 0.10
#: Triangles that flip in one shape (and not in the source), as a fraction of the target's faces.
FLIP_SHAPE_LIMIT = 0.015
#: ... and in all shapes together.
FLIP_TOTAL_LIMIT = 0.04
#: Mirror-pair RMS error relative to the pair's RMS displacement.
MIRROR_LIMIT = 0.30
#: The suggested crop keeps what lies above this fraction of the chin-to-bridge height below the chin.
CROP_DEPTH = 0.25


def face_axes(vertices: np.ndarray, landmarks: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The chin, the face's up direction and its height, from the iBUG 68 landmarks.

    Up runs from the chin to the top of the nose bridge, made perpendicular to the
    left-right axis (jaw end to jaw end), so that a plane across it cuts both sides alike.

    Returns
    -------
    chin : (3,) float64, up : (3,) unit float64, height : float (chin to bridge along up)
    """
    V = np.asarray(vertices, dtype=np.float64)
    chin = V[landmarks[CHIN]]
    side = V[landmarks[JAW_LEFT_END]] - V[landmarks[JAW_RIGHT_END]]
    side = side / max(np.linalg.norm(side), 1e-300)
    up = V[landmarks[NOSE_BRIDGE]] - chin
    up = up - (up @ side) * side
    height = float(np.linalg.norm(up))
    return chin, up / max(height, 1e-300), height


def neck_vertices(vertices: np.ndarray, landmarks: np.ndarray, depth: float = NECK_DEPTH) -> np.ndarray:
    """Vertices lower than the chin by more than ``depth`` times the chin-to-bridge height
    (the neck of a head mesh; none on a face mask such as the ARKit reference), ``(N,) int64``."""
    chin, up, height = face_axes(vertices, landmarks)
    return np.flatnonzero((np.asarray(vertices, dtype=np.float64) - chin) @ up < -depth * height).astype(np.int64)


def boundary_vertices(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Vertices on an open border of the mesh (an edge used by one face), ``(N,) int64``."""
    F = np.asarray(faces, dtype=np.int64)
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    key = edges[:, 0] * n_vertices + edges[:, 1]
    unique, counts = np.unique(key, return_counts=True)
    once = unique[counts == 1]
    return np.unique(np.concatenate([once // n_vertices, once % n_vertices])).astype(np.int64)


def suggested_crop(vertices: np.ndarray, landmarks: np.ndarray, depth: float = CROP_DEPTH) -> np.ndarray:
    """A crop for a head whose neck the transfer drags: the vertices above a plane across
    the neck ``depth`` times the chin-to-bridge height below the chin (face, scalp, ears),
    ``(N,) int64``; what lies below is re-attached with the falloff."""
    chin, up, height = face_axes(vertices, landmarks)
    return np.flatnonzero((np.asarray(vertices, dtype=np.float64) - chin) @ up >= -depth * height).astype(np.int64)


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
    face_pairs: np.ndarray | None = None,
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
    face_pairs : (P, 2) int ndarray, optional
        ``(source face, rig face)`` correspondence (the plan's pairs, target faces in the
        full mesh): a triangle that flips where a source partner flips too is the
        source's fold, not the transfer's (``flipped_faces_new`` leaves it out).

    Returns
    -------
    report : dict
        ``{"shapes": {name: {...}}, "mirror": {...}, "neck": {...}, "coverage": {...},
        "summary": {...}, "warnings": [...]}``; the warnings are `retarget_warnings`'.
    """
    lm = as_indices(landmarks, rig.num_vertices, "retarget_report", name="landmarks")
    if len(lm) != 68:
        raise UserError(f"retarget_report: expected the 68 iBUG landmarks, got {len(lm)}")
    pairs = None
    if face_pairs is not None and source is not None:
        pairs = np.asarray(face_pairs, dtype=np.int64).reshape(-1, 2)
        if len(pairs) and (pairs[:, 0].max() >= len(source.faces) or pairs[:, 1].max() >= len(rig.faces)):
            raise UserError(f"retarget_report: face_pairs index {pairs[:, 0].max() + 1} source and "
                            f"{pairs[:, 1].max() + 1} rig faces, the rigs have {len(source.faces)} and {len(rig.faces)}")
    mm = 1000.0
    neck = neck_vertices(rig.neutral, lm)
    neck_border = np.intersect1d(neck, boundary_vertices(rig.faces, rig.num_vertices))
    shapes = {}
    for name, delta in zip(rig.names, rig.deltas):
        mag = np.linalg.norm(delta, axis=1)
        groups = {g: float(mag[lm[a:b]].mean() * mm) for g, (a, b) in LANDMARK_REGIONS.items()}
        top = max(groups.values())
        flips = flipped_faces(rig.neutral, delta, rig.faces)
        entry = {
            "max_mm": float(mag.max() * mm),
            "mean_mm": float(mag.mean() * mm),
            "finite": bool(np.all(np.isfinite(delta))),
            "flipped_faces": len(flips),
            "flipped_faces_new": len(flips),
            "landmark_groups_mm": groups,
            "region": [g for g, v in groups.items() if top > 0 and v >= region_fraction * top],
            "moved_vertices": int(np.sum(mag > 0.1 * max(mag.max(), 1e-300))),
        }
        if seam is not None and len(seam):
            entry["seam_max_mm"] = float(mag[np.asarray(seam)].max() * mm)
        if len(neck):
            entry["neck_max_mm"] = float(mag[neck].max() * mm)
            entry["neck_relative"] = float(mag[neck].max() / max(mag.max(), 1e-300)) if mag.max() > 0 else 0.0
            if len(neck_border):
                entry["neck_border_max_mm"] = float(mag[neck_border].max() * mm)
        if source is not None and name in source.names:
            src_delta = source.deltas[source.names.index(name)]
            entry["source_max_mm"] = float(np.linalg.norm(src_delta, axis=1).max() * mm)
            src_flips = flipped_faces(source.neutral, src_delta, source.faces)
            entry["source_flipped_faces"] = len(src_flips)
            if pairs is not None and len(flips):
                # a rig triangle whose source partner folds too inherits the fold
                folded = np.zeros(len(source.faces), dtype=bool)
                folded[src_flips] = True
                inherited = np.zeros(len(rig.faces), dtype=bool)
                inherited[pairs[folded[pairs[:, 0]], 1]] = True
                entry["flipped_faces_new"] = int(np.count_nonzero(~inherited[flips]))
        shapes[name] = entry
    report = {"shapes": shapes}
    below = NECK_DEPTH * face_axes(rig.neutral, lm)[2] * mm
    report["neck"] = {"vertices": len(neck), "border_vertices": len(neck_border), "below_chin_mm": below}
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
    summary = {
        "shapes": len(rig.names),
        "faces": len(rig.faces),
        "all_finite": all(s["finite"] for s in shapes.values()),
        "largest_displacement_mm": max((s["max_mm"] for s in shapes.values()), default=0.0),
        "flipped_faces_total": int(sum(s["flipped_faces"] for s in shapes.values())),
        "flipped_faces_new_total": int(sum(s["flipped_faces_new"] for s in shapes.values())),
    }
    if source is not None:
        summary["source_flipped_faces_total"] = int(sum(s.get("source_flipped_faces", 0) for s in shapes.values()))
    if shapes:
        worst = max(shapes, key=lambda n: shapes[n]["flipped_faces_new"])
        summary["worst_flipped_shape"] = worst
        summary["worst_flipped_fraction"] = shapes[worst]["flipped_faces_new"] / max(len(rig.faces), 1)
    if symmetric and report["mirror"]["pairs"]:
        pairs_ = report["mirror"]["pairs"]
        summary["worst_mirror_relative"] = max(p["max_relative"] for p in pairs_.values())
        summary["worst_mirror_rms_relative"] = max(p["rms_relative"] for p in pairs_.values())
        summary["worst_mirror_pair"] = max(pairs_, key=lambda k: pairs_[k]["rms_relative"])
    if len(neck) and shapes:
        worst = max(shapes, key=lambda n: shapes[n]["neck_relative"])
        summary["worst_neck_shape"] = worst
        summary["worst_neck_relative"] = shapes[worst]["neck_relative"]
        farthest = max(shapes, key=lambda n: shapes[n]["neck_max_mm"])
        summary["worst_neck_mm"] = shapes[farthest]["neck_max_mm"]
        summary["worst_neck_mm_shape"] = farthest
    report["summary"] = summary
    report["warnings"] = retarget_warnings(report)
    return report


def retarget_warnings(report: dict) -> list[dict]:
    """What in a `retarget_report` says the transfer does not suit the head, with the figures.

    Three checks, each against its module constant:

    * ``neck``: a shape moves the neck (`neck_vertices`) by more than ``NECK_LIMIT`` of its
      largest displacement: the whole head took part and the jaw drags it;
    * ``flipped_faces``: triangles flip in the transfer that do not flip in the source, more
      than ``FLIP_SHAPE_LIMIT`` of the faces in one shape or ``FLIP_TOTAL_LIMIT`` in all;
    * ``mirror``: a left shape and its right partner are not mirror images, the RMS error
      above ``MIRROR_LIMIT`` of their RMS displacement.

    Returns
    -------
    list of ``{"kind", "message", "value", "limit"}`` (empty when the rig looks sound);
    each message names the shape and the numbers and suggests the crop.
    """
    s = report["summary"]
    out = []
    neck = report.get("neck", {})
    if s.get("worst_neck_relative", 0.0) > NECK_LIMIT:
        name = s["worst_neck_shape"]
        entry = report["shapes"][name]
        border = (f", the mesh's open border there by {entry['neck_border_max_mm']:.1f} mm"
                  if "neck_border_max_mm" in entry else "")
        farthest = s["worst_neck_mm_shape"]
        also = (f"; {farthest} moves it most, by {s['worst_neck_mm']:.1f} mm" if farthest != name else "")
        out.append({"kind": "neck", "value": s["worst_neck_relative"], "limit": NECK_LIMIT, "shape": name,
                    "message": f"the neck is dragged: {name} moves the {neck['vertices']} vertices more than "
                               f"{neck['below_chin_mm']:.0f} mm below the chin by up to {entry['neck_max_mm']:.1f} mm "
                               f"({100 * s['worst_neck_relative']:.0f} % of its largest displacement, limit "
                               f"{100 * NECK_LIMIT:.0f} %){border}{also}. The neck took part in the transfer: crop it "
                               "out (--crop: the face, scalp and ears without the neck)"})
    faces = max(s.get("faces", 1), 1)
    total = s.get("flipped_faces_new_total", 0)
    if s.get("worst_flipped_fraction", 0.0) > FLIP_SHAPE_LIMIT or total / faces > FLIP_TOTAL_LIMIT:
        name = s["worst_flipped_shape"]
        source = (f"; the source folds {s['source_flipped_faces_total']} in the same shapes"
                  if "source_flipped_faces_total" in s else "")
        out.append({"kind": "flipped_faces", "value": total / faces, "limit": FLIP_TOTAL_LIMIT, "shape": name,
                    "message": f"{total} triangles flip in the transfer that do not flip in the source "
                               f"({100 * total / faces:.1f} % of the {faces} faces over {s['shapes']} shapes, limit "
                               f"{100 * FLIP_TOTAL_LIMIT:.0f} %; {name} alone {report['shapes'][name]['flipped_faces_new']}, "
                               f"{100 * s['worst_flipped_fraction']:.1f} %, limit {100 * FLIP_SHAPE_LIMIT:.1f} %{source}). "
                               "Folds come from parts the source face does not have (neck, the inside of the "
                               "mouth, eyeballs): crop them out (--crop)"})
    if s.get("worst_mirror_rms_relative", 0.0) > MIRROR_LIMIT:
        pair = s["worst_mirror_pair"]
        asym = report["mirror"]["mesh_asymmetry_mm"]
        out.append({"kind": "mirror", "value": s["worst_mirror_rms_relative"], "limit": MIRROR_LIMIT, "pair": pair,
                    "message": f"left and right shapes are not mirror images: {pair} differ by "
                               f"{100 * s['worst_mirror_rms_relative']:.0f} % of their RMS displacement (limit "
                               f"{100 * MIRROR_LIMIT:.0f} %; the head itself is asymmetric by a median {asym:.2f} mm). "
                               "A neck or an inner mouth that takes part pulls one side: crop them out (--crop)"})
    return out


def report_markdown(report: dict, *, title: str = "Retargeting report") -> str:
    """The report of `retarget_report` as a Markdown page."""
    lines = [f"# {title}", ""]
    s = report["summary"]
    warnings = report.get("warnings", [])
    if warnings:
        lines += ["## Warnings", ""] + [f"- **{w['kind'].replace('_', ' ')}**: {w['message']}" for w in warnings] + [""]
    flips = f"- flipped faces (all shapes): {s['flipped_faces_total']}"
    if "flipped_faces_new_total" in s and s["flipped_faces_new_total"] != s["flipped_faces_total"]:
        flips += f", {s['flipped_faces_new_total']} of them not folded in the source"
    if "source_flipped_faces_total" in s:
        flips += f" (the source folds {s['source_flipped_faces_total']})"
    lines += [f"- shapes: {s['shapes']}", f"- all finite: {s['all_finite']}",
              f"- largest displacement: {s['largest_displacement_mm']:.2f} mm", flips]
    if "worst_mirror_relative" in s:
        lines.append(f"- worst mirror-pair error: {100 * s['worst_mirror_relative']:.1f} % of the shape's largest displacement "
                     f"(RMS: {100 * s['worst_mirror_rms_relative']:.1f} % of the shapes' RMS displacement, "
                     f"{s['worst_mirror_pair']})")
    if "worst_neck_relative" in s:
        neck = report["neck"]
        lines.append(f"- neck ({neck['vertices']} vertices more than {neck['below_chin_mm']:.0f} mm below the chin): "
                     f"moved by at most {s['worst_neck_mm']:.2f} mm ({s['worst_neck_mm_shape']}), at most "
                     f"{100 * s['worst_neck_relative']:.1f} % of a shape's largest displacement ({s['worst_neck_shape']})")
    if "coverage" in report:
        lines += [f"- {k.replace('_', ' ')}: {100 * v:.1f} %" for k, v in report["coverage"].items()]
    lines += ["", "| shape | max mm | mean mm | source max mm | region | flipped | not in source | seam max mm | neck max mm |",
              "|---|---|---|---|---|---|---|---|---|"]
    for name, e in report["shapes"].items():
        src = f"{e['source_max_mm']:.2f}" if "source_max_mm" in e else ""
        seam = f"{e['seam_max_mm']:.2f}" if "seam_max_mm" in e else ""
        neck = f"{e['neck_max_mm']:.2f}" if "neck_max_mm" in e else ""
        lines.append(f"| {name} | {e['max_mm']:.2f} | {e['mean_mm']:.3f} | {src} | {', '.join(e['region'])} | "
                     f"{e['flipped_faces']} | {e.get('flipped_faces_new', e['flipped_faces'])} | {seam} | {neck} |")
    if "mirror" in report:
        m = report["mirror"]
        lines += ["", f"Mirror pairs (plane x = {m['plane']:.4f}, median mesh asymmetry {m['mesh_asymmetry_mm']:.3f} mm):", "",
                  "| pair | max mm | p99 mm | mean mm | max / shape max | RMS / shape RMS |", "|---|---|---|---|---|---|"]
        for pair, e in m["pairs"].items():
            lines.append(f"| {pair} | {e['max_mm']:.3f} | {e['p99_mm']:.3f} | {e['mean_mm']:.4f} | "
                         f"{100 * e['max_relative']:.1f} % | {100 * e['rms_relative']:.1f} % |")
    return "\n".join(lines) + "\n"
