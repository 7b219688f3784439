"""Offscreen OpenGL rendering with pyrender (EGL, headless)."""

from __future__ import annotations

import os

import numpy as np

#: OpenGL renderers that rasterise on the CPU (Mesa): slower than the numpy rasteriser
#: for these meshes (about 200 ms against about 40 ms a 512 px face view on 2 cores).
SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "software rasterizer")


def egl_environment() -> None:
    """Select headless EGL for PyOpenGL unless the caller chose a platform."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    os.environ.setdefault("EGL_PLATFORM", "surfaceless")


def _import():
    egl_environment()
    try:
        import pyrender
        import trimesh
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise ImportError("the pyrender backend needs pyrender and trimesh: pip install pyrender trimesh") from err
    return pyrender, trimesh


class PyrenderRenderer:
    """Frames of one mesh topology from one camera with one pyrender renderer; call
    :meth:`close` (or use it as a context manager) to delete it (a renderer kept across
    sequences leaks memory).

    Parameters
    ----------
    faces : (F, 3), pose : (4, 4), yfov : float, width, height : int
    """

    def __init__(self, faces, pose, yfov: float, width: int = 256, height: int = 256):
        pyrender, trimesh = _import()
        self._pyrender, self._trimesh = pyrender, trimesh
        self.faces = np.asarray(faces, dtype=np.int64)
        self.width, self.height = int(width), int(height)
        self._material = pyrender.MetallicRoughnessMaterial(baseColorFactor=(0.78, 0.74, 0.70, 1.0), metallicFactor=0.0,
                                                            roughnessFactor=0.8, doubleSided=True)
        self._renderer = pyrender.OffscreenRenderer(self.width, self.height)
        self._scene = pyrender.Scene(bg_color=(1.0, 1.0, 1.0, 1.0), ambient_light=(0.3, 0.3, 0.3))
        self._scene.add(pyrender.PerspectiveCamera(yfov=yfov, aspectRatio=self.width / self.height), pose=pose)
        self._scene.add(pyrender.DirectionalLight(intensity=2.0), pose=pose)
        self._node = None

    def render(self, vertices, out: np.ndarray | None = None) -> np.ndarray:
        """One frame, ``(height, width, 3)`` uint8 (into ``out`` when given)."""
        v = np.asarray(vertices, dtype=np.float64)
        mesh = self._pyrender.Mesh.from_trimesh(self._trimesh.Trimesh(v, self.faces, process=False),
                                                material=self._material, smooth=True)
        if self._node is not None:
            self._scene.remove_node(self._node)
        self._node = self._scene.add(mesh)
        colour, _ = self._renderer.render(self._scene)
        if out is None:
            return np.ascontiguousarray(colour[..., :3])
        out[...] = colour[..., :3]
        return out

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.delete()
            self._renderer = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def egl_renderer_name() -> str | None:
    """The OpenGL renderer string of a headless EGL context (e.g. ``"llvmpipe (LLVM 15.0.6,
    256 bits)"`` or an NVIDIA GPU's name), ``None`` when none opens here."""
    egl_environment()
    try:
        import pyrender

        r = pyrender.OffscreenRenderer(8, 8)
        try:
            from OpenGL.GL import GL_RENDERER, glGetString

            name = glGetString(GL_RENDERER)
            return name.decode(errors="replace") if isinstance(name, bytes) else str(name or "unknown")
        finally:
            r.delete()
    except Exception:  # noqa: BLE001 - any failure means: not available
        return None


def is_software_gl(name: str | None) -> bool:
    """Whether an OpenGL renderer string names a CPU rasteriser (Mesa llvmpipe, softpipe)."""
    return bool(name) and any(word in name.lower() for word in SOFTWARE_GL)
