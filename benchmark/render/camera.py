"""Front-view camera framing a face mesh (up +y, facing +z)."""

from __future__ import annotations

import numpy as np


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
        raise ValueError("front_camera: expected finite vertices (V, 3)")
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
