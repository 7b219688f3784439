"""Offscreen OpenGL rendering with pyrender (EGL, headless)."""

from __future__ import annotations

import os

import numpy as np


def egl_environment() -> None:
    """Select headless EGL for PyOpenGL unless the caller chose a platform."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    os.environ.setdefault("EGL_PLATFORM", "surfaceless")


def render_pyrender(vertices, faces, pose, yfov: float, width: int = 256, height: int = 256,
                    progress: bool = False) -> np.ndarray:
    """Render a mesh sequence with one pyrender renderer, deleted afterwards
    (a renderer reused across sequences leaks memory).

    Parameters
    ----------
    vertices : (T, V, 3), faces : (F, 3), pose : (4, 4), yfov : float
    progress : bool, a tqdm bar over frames

    Returns
    -------
    (T, height, width, 3) uint8 ndarray
    """
    egl_environment()
    try:
        import pyrender
        import trimesh
        from tqdm import tqdm
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise ImportError("render_pyrender needs pyrender and trimesh: pip install pyrender trimesh") from err
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    material = pyrender.MetallicRoughnessMaterial(baseColorFactor=(0.78, 0.74, 0.70, 1.0), metallicFactor=0.0,
                                                  roughnessFactor=0.8, doubleSided=True)
    renderer = pyrender.OffscreenRenderer(width, height)
    try:
        frames = np.empty((len(vertices), height, width, 3), dtype=np.uint8)
        scene = pyrender.Scene(bg_color=(1.0, 1.0, 1.0, 1.0), ambient_light=(0.3, 0.3, 0.3))
        scene.add(pyrender.PerspectiveCamera(yfov=yfov, aspectRatio=width / height), pose=pose)
        scene.add(pyrender.DirectionalLight(intensity=2.0), pose=pose)
        node = None
        for t, v in enumerate(tqdm(vertices, desc="render (pyrender)", unit="frame", disable=not progress)):
            mesh = pyrender.Mesh.from_trimesh(trimesh.Trimesh(v, faces, process=False), material=material, smooth=True)
            if node is not None:
                scene.remove_node(node)
            node = scene.add(mesh)
            colour, _ = renderer.render(scene)
            frames[t] = colour[..., :3]
        return frames
    finally:
        renderer.delete()


def egl_available() -> bool:
    """Whether pyrender can open a headless EGL context here."""
    egl_environment()
    try:
        import pyrender

        r = pyrender.OffscreenRenderer(8, 8)
        r.delete()
        return True
    except Exception:  # noqa: BLE001 - any failure means: not available
        return False
