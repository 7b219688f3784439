"""Front-view camera framing a face mesh (up +y, facing +z)."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError


def front_camera(vertices, yfov: float = np.pi / 8, margin: float = 1.15, aspect: float = 1.0) -> np.ndarray:
    """Camera-to-world pose (4, 4) of a perspective camera on the +z axis of the
    mesh's bounding box, looking down -z, far enough that the box's front face,
    enlarged by ``margin``, fits the field of view.

    Parameters
    ----------
    vertices : (V, 3) or (T, V, 3) array_like
        The box is taken over all frames given.
    yfov : float
        Vertical field of view (radians).
    margin : float
    aspect : float
        Width / height of the image.

    Returns
    -------
    (4, 4) float64 ndarray
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise UserError("front_camera: expected finite vertices (V, 3)")
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre = 0.5 * (lo + hi)
    half_h = 0.5 * (hi[1] - lo[1]) * margin
    half_w = 0.5 * (hi[0] - lo[0]) * margin / aspect
    distance = max(half_h, half_w, 1e-6) / np.tan(yfov / 2) + hi[2] - centre[2]
    pose = np.eye(4)
    pose[:3, 3] = [centre[0], centre[1], centre[2] + distance]
    return pose


def project(vertices, pose, yfov: float, width: int, height: int):
    """Pixel coordinates and depth of vertices seen by a camera.

    Parameters
    ----------
    vertices : (V, 3) array_like
    pose : (4, 4) camera-to-world (OpenGL convention: looks down -z, up +y)
    yfov : float
    width, height : int

    Returns
    -------
    xy : (V, 2) ndarray, pixels (x right, y down, pixel centres at +0.5)
    depth : (V,) ndarray, distance along the viewing axis
    """
    v = np.asarray(vertices, dtype=np.float64)
    pose = np.asarray(pose, dtype=np.float64)
    cam = (v - pose[:3, 3]) @ pose[:3, :3]
    depth = -cam[:, 2]
    f = 1.0 / np.tan(yfov / 2)
    safe = np.where(depth > 1e-9, depth, 1e-9)
    x_ndc = f * (height / width) * cam[:, 0] / safe
    y_ndc = f * cam[:, 1] / safe
    xy = np.stack([(x_ndc + 1) * 0.5 * width, (1 - y_ndc) * 0.5 * height], axis=1)
    return xy, depth


def face_box(vertices, depth_fraction: float = 0.3, up: float = 0.45, down: float = 0.75) -> tuple[np.ndarray, np.ndarray]:
    """The box of the face (brows to chin, cheek to cheek) of a head facing +z.

    The nose tip is the vertex nearest the viewer (largest z); the face is what lies
    within ``depth_fraction`` of the head's largest extent behind it, which leaves out
    the ears, the back of the head and the sides of the neck. Its width W (x range)
    sets the height: from ``down * W`` below the tip to ``up * W`` above it, which
    keeps the scalp and most of the neck out of the picture and an open jaw in it on
    FLAME and ARKit heads.

    Parameters
    ----------
    vertices : (V, 3) or (T, V, 3) array_like (the first frame decides)

    Returns
    -------
    lo, hi : (3,) float64 ndarrays, opposite corners
    """
    v = np.asarray(vertices, dtype=np.float64)
    v = v[0] if v.ndim == 3 else v
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0 or not np.all(np.isfinite(v)):
        raise UserError(f"face_box: expected finite vertices (V, 3), got shape {v.shape}")
    extent = float(np.ptp(v, axis=0).max())
    tip = v[np.argmax(v[:, 2])]
    front = v[v[:, 2] >= tip[2] - depth_fraction * extent]
    width = float(np.ptp(front[:, 0]))
    lo = np.array([front[:, 0].min(), tip[1] - down * width, front[:, 2].min()])
    hi = np.array([front[:, 0].max(), tip[1] + up * width, tip[2]])
    return lo, hi


def face_camera(vertices, yfov: float = np.pi / 8, margin: float = 1.1, side: bool = False) -> np.ndarray:
    """Camera-to-world pose framing :func:`face_box`: from the front (on +z, looking
    down -z) or, with ``side``, in profile (on +x, looking down -x, nose to the left).

    Returns
    -------
    (4, 4) float64 ndarray
    """
    lo, hi = face_box(vertices)
    if not side:
        return front_camera(np.stack([lo, hi]), yfov=yfov, margin=margin)
    centre = 0.5 * (lo + hi)
    half = 0.5 * max(hi[1] - lo[1], hi[2] - lo[2]) * margin
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    right = float(v[:, 0].max())
    pose = np.eye(4)
    pose[:3, :3] = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    pose[:3, 3] = [right + half / np.tan(yfov / 2), centre[1], centre[2]]
    return pose
