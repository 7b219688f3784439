"""The report warns, with the numbers, when a transfer does not suit the head: a dragged
neck, triangles that flip (and not in the source), left and right shapes that are not
mirror images; a FLAME-like rig raises none (issue 39)."""

import json

import numpy as np

from blendvoca.retarget.report import (
    FLIP_SHAPE_LIMIT,
    MIRROR_LIMIT,
    NECK_LIMIT,
    boundary_vertices,
    neck_vertices,
    report_markdown,
    retarget_report,
    retarget_warnings,
    suggested_crop,
)
from blendvoca.rig import Rig

S = 0.1  # metres per grid unit: a head 20 cm wide


def _head():
    """A symmetric open sheet shaped like the front of a head and neck (x left-right, y up,
    z towards the viewer), 25 x 31 vertices, with 68 landmarks: chin at y = -0.5, nose
    bridge at y = 0.5, the neck below y = -1 (half the chin-to-bridge height below the chin)."""
    u = np.linspace(-1.0, 1.0, 25)
    v = np.linspace(-2.0, 1.0, 31)
    U, Vg = np.meshgrid(u, v)  # rows bottom (neck) to top
    Z = 0.5 * np.sqrt(1.0 - 0.8 * U**2)
    vertices = S * np.stack([U, Vg, Z], axis=-1).reshape(-1, 3)
    faces = []
    cols = len(u)
    for r in range(len(v) - 1):
        for c in range(cols - 1):
            a, b, d, e = r * cols + c, r * cols + c + 1, (r + 1) * cols + c, (r + 1) * cols + c + 1
            # diagonals mirrored across the midline so the triangulation is symmetric too
            if c < cols // 2:
                faces += [[a, b, e], [a, e, d]]
            else:
                faces += [[a, b, d], [b, e, d]]
    faces = np.array(faces, dtype=np.int64)

    def at(x, y):
        return int(np.argmin(np.linalg.norm(vertices[:, :2] - S * np.array([x, y]), axis=1)))

    landmarks = np.array([at(0.9 * np.cos(t), -0.1 - 0.4 * np.sin(t)) for t in np.linspace(0, np.pi, 17)]  # jaw 0-16
                         + [at(-0.5 + 0.1 * k, 0.6) for k in range(5)] + [at(0.1 + 0.1 * k, 0.6) for k in range(5)]
                         + [at(0.0, 0.5 - 0.1 * k) for k in range(4)] + [at(-0.2 + 0.1 * k, 0.1) for k in range(5)]
                         + [at(-0.4 + 0.05 * k, 0.35) for k in range(6)] + [at(0.2 + 0.05 * k, 0.35) for k in range(6)]
                         + [at(-0.3 + 0.05 * k, -0.2) for k in range(12)] + [at(-0.2 + 0.05 * k, -0.25) for k in range(8)])
    landmarks[8] = at(0.0, -0.5)  # chin
    for k in (27, 28, 29, 30, 33, 51, 57, 62, 66):  # the midline
        landmarks[k] = at(0.0, vertices[landmarks[k], 1] / S)
    assert len(landmarks) == 68
    return vertices, faces, landmarks


def _bump(vertices, centre, sigma=0.12):
    return np.exp(-np.sum((vertices[:, :2] / S - centre) ** 2, axis=1) / (2 * sigma**2))


def _jaw_weight(y, neck):
    """1 on the jaw (y from -0.5 to -0.1), 0 above the mouth; below the chin it fades to 0 by
    y = -0.8, or with ``neck`` it stays 1 all the way down (a dragged neck)."""
    up = np.clip((0.0 - y) / 0.1, 0.0, 1.0)
    down = np.ones_like(y) if neck else np.clip((y + 0.8) / 0.3, 0.0, 1.0)
    return up * down


def _rig(*, neck=False, mirror=False, flip=False):
    vertices, faces, landmarks = _head()
    y = vertices[:, 1] / S
    names = ("jawOpen", "mouthSmileLeft", "mouthSmileRight", "mouthFunnel")
    deltas = np.zeros((len(names), *vertices.shape))
    deltas[0] = 0.01 * _jaw_weight(y, neck)[:, None] * np.array([0.0, -1.0, 0.2])
    deltas[1] = 0.004 * _bump(vertices, (0.3, -0.2))[:, None] * np.array([1.0, 1.0, 0.0])
    right_centre = (-0.3, -0.2) if not mirror else (-0.15, 0.05)
    right_direction = np.array([-1.0, 1.0, 0.0]) if not mirror else np.array([0.0, -1.0, 1.0])
    deltas[2] = 0.004 * _bump(vertices, right_centre)[:, None] * right_direction
    deltas[3] = 0.003 * _bump(vertices, (0.0, -0.25))[:, None] * np.array([0.0, 0.0, 1.0])
    if flip:  # turn a patch around the mouth inside out: x mirrored in place
        patch = (np.abs(vertices[:, 0] / S) < 0.45) & (y > -0.45) & (y < -0.05)
        deltas[3, patch, 0] = -2.0 * vertices[patch, 0]
    return Rig(vertices, deltas, names, faces), landmarks


def _kinds(report):
    return sorted(w["kind"] for w in report["warnings"])


def test_a_flame_like_rig_raises_no_warning():
    rig, landmarks = _rig()
    report = retarget_report(rig, landmarks)
    assert report["warnings"] == [] and retarget_warnings(report) == []
    s = report["summary"]
    assert s["flipped_faces_total"] == 0 and s["worst_mirror_rms_relative"] < 1e-6
    assert report["neck"]["vertices"] > 0 and s["worst_neck_mm"] < 1e-3
    assert "## Warnings" not in report_markdown(report)


def test_a_dragged_neck_is_named_with_its_displacement():
    rig, landmarks = _rig(neck=True)
    report = retarget_report(rig, landmarks)
    assert _kinds(report) == ["neck"]
    (warning,) = report["warnings"]
    assert warning["shape"] == "jawOpen" and warning["value"] > NECK_LIMIT
    neck = neck_vertices(rig.neutral, landmarks)
    assert np.all(rig.neutral[neck, 1] < -1.0 * S + 1e-9) and len(neck) == report["neck"]["vertices"]
    assert "jawOpen" in warning["message"] and "10.2 mm" in warning["message"] and "--crop" in warning["message"]
    assert "open border" in warning["message"]  # the sheet's bottom edge is the neck's cut
    assert set(boundary_vertices(rig.faces, rig.num_vertices)) >= set(range(25))
    markdown = report_markdown(report)
    assert "## Warnings" in markdown and "the neck is dragged" in markdown
    # the suggested crop leaves the neck out and keeps the face
    keep = suggested_crop(rig.neutral, landmarks)
    assert set(landmarks) <= set(keep) and not set(neck) & set(keep)


def test_left_and_right_shapes_that_are_not_mirror_images():
    rig, landmarks = _rig(mirror=True)
    report = retarget_report(rig, landmarks)
    assert _kinds(report) == ["mirror"]
    (warning,) = report["warnings"]
    assert warning["pair"] == "mouthSmileLeft/mouthSmileRight" and warning["value"] > MIRROR_LIMIT
    assert f"{100 * warning['value']:.0f} % of their RMS displacement" in warning["message"]


def test_flipped_faces_are_counted_and_those_the_source_folds_too_are_not_the_transfers():
    rig, landmarks = _rig(flip=True)
    report = retarget_report(rig, landmarks)
    assert _kinds(report) == ["flipped_faces"]
    (warning,) = report["warnings"]
    flipped = report["shapes"]["mouthFunnel"]["flipped_faces"]
    assert flipped / len(rig.faces) > FLIP_SHAPE_LIMIT
    assert f"{flipped} triangles flip" in warning["message"] and "mouthFunnel" in warning["message"]
    # the same folds in the source (a source of the same topology, faces paired one to one):
    # inherited, not the transfer's, and no warning
    pairs = np.stack([np.arange(len(rig.faces))] * 2, axis=1)
    report = retarget_report(rig, landmarks, source=rig, face_pairs=pairs)
    assert report["shapes"]["mouthFunnel"]["flipped_faces"] == flipped
    assert report["shapes"]["mouthFunnel"]["flipped_faces_new"] == 0
    assert report["summary"]["source_flipped_faces_total"] == flipped and report["warnings"] == []


def test_the_command_warns_on_a_head_that_is_not_flames_and_its_suggested_crop_helps(assets_dir, tmp_path, capsys):
    """FLAME's head with its vertices renumbered is not FLAME's topology: no default crop,
    the whole head takes part and the jaw drags the neck; the suggested crop stops it."""
    from blendvoca.io.mesh import read_ply, write_obj
    from blendvoca.retarget.cli import main

    V, F = read_ply(assets_dir / "voca" / "FLAME_sample.ply")
    landmarks = np.loadtxt(assets_dir / "said" / "FLAME_landmarks.txt", dtype=np.int64)
    order = np.random.default_rng(0).permutation(len(V))  # new vertex k is old vertex order[k]
    new_index = np.empty_like(order)
    new_index[order] = np.arange(len(order))
    write_obj(tmp_path / "head.obj", V[order], new_index[F])
    np.savetxt(tmp_path / "landmarks.txt", new_index[landmarks], fmt="%d")
    args = ["--target", str(tmp_path / "head.obj"), "--target-landmarks", str(tmp_path / "landmarks.txt"), "--no-sheet"]
    assert main(args + ["--out", str(tmp_path / "whole")]) == 0
    captured = capsys.readouterr()
    warnings = [line for line in captured.err.splitlines() if line.startswith("warning: ")]
    assert any("the neck is dragged" in w and "jawOpen" in w for w in warnings), captured.err
    suggestion = tmp_path / "whole" / "suggested_crop.txt"
    assert suggestion.is_file() and f"--crop {suggestion}" in captured.err
    summary = captured.out.strip().splitlines()[-1]
    assert "flipped faces" in summary and "worst mirror-pair error" in summary and "warning" in summary
    report = json.loads((tmp_path / "whole" / "report.json").read_text())
    assert "neck" in [w["kind"] for w in report["warnings"]] and report["summary"]["worst_neck_mm"] > 10
    assert "## Warnings" in (tmp_path / "whole" / "report.md").read_text()

    assert main(args + ["--out", str(tmp_path / "cropped"), "--crop", str(suggestion)]) == 0
    captured = capsys.readouterr()
    report = json.loads((tmp_path / "cropped" / "report.json").read_text())
    assert "neck" not in [w["kind"] for w in report["warnings"]] and report["summary"]["worst_neck_mm"] < 0.5
    assert "the neck is dragged" not in captured.err

