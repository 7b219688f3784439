"""Headless rendering of coefficient tracks and mesh sequences to video.

``render_sequence`` picks pyrender over EGL when it works and the numpy
rasteriser otherwise; either way one renderer serves one sequence.
"""

from __future__ import annotations

import functools

import numpy as np

from benchmark.render.camera import face_box, face_camera, front_camera, project
from benchmark.render.software import rasterize
from benchmark.render.timing import resample_frames
from benchmark.render.video import read_video, write_video
from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array

BACKENDS = ("auto", "pyrender", "software")


@functools.lru_cache(maxsize=1)
def _egl_ok() -> bool:
    from benchmark.render.pyrender_backend import egl_available

    return egl_available()


def render_sequence(vertices, faces, *, size: int = 256, backend: str = "auto", yfov: float = np.pi / 8,
                    pose=None, progress: bool = False) -> np.ndarray:
    """Render a mesh sequence from the front.

    Parameters
    ----------
    vertices : (T, V, 3) array_like, metres
    faces : (F, 3) int array_like
    size : int
        Square image side (pixels).
    backend : {"auto", "pyrender", "software"}
    yfov : float
    pose : (4, 4), optional
        Camera-to-world pose; default :func:`front_camera` over the whole sequence.
    progress : bool
        tqdm bar over frames (either backend).

    Returns
    -------
    (T, size, size, 3) uint8 ndarray
    """
    vertices = float_array(vertices, where="render_sequence", name="vertices", shape="(T, V, 3)")
    faces = np.asarray(faces, dtype=np.int64)
    if vertices.ndim != 3 or vertices.shape[2] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise UserError(f"render_sequence: expected vertices (T, V, 3) and faces (F, 3), got {vertices.shape}, {faces.shape}")
    if faces.size and (faces.min() < 0 or faces.max() >= vertices.shape[1]):
        raise UserError(f"render_sequence: face indices out of range for {vertices.shape[1]} vertices")
    if backend not in BACKENDS:
        raise UserError(f"render_sequence: backend must be one of {BACKENDS}, got {backend!r}")
    if pose is None:
        pose = front_camera(vertices, yfov=yfov)
    if backend == "auto":
        backend = "pyrender" if _egl_ok() else "software"
    elif backend == "pyrender" and not _egl_ok():
        raise UserError("render_sequence: backend 'pyrender' cannot open a headless EGL context here (pyrender, "
                        "PyOpenGL and an EGL driver are needed: pip install 'blendvoca[render]'); use backend "
                        "'software' or 'auto'")
    if backend == "pyrender":
        from benchmark.render.pyrender_backend import render_pyrender

        return render_pyrender(vertices, faces, pose, yfov, size, size, progress=progress)
    from tqdm import tqdm

    return np.stack([rasterize(v, faces, pose, yfov, size, size)
                     for v in tqdm(vertices, desc="render (software)", unit="frame", disable=not progress)])


def render_coeffs(coeffs, rig, *, fps: float = 60.0, out_fps: float | None = None, **kwargs) -> np.ndarray:
    """Render a coefficient track through a rig.

    Parameters
    ----------
    coeffs : (T, K) array_like at ``fps``, columns in ``rig.names`` order
    rig : blendvoca.rig.Rig (``neutral``, ``deltas``, ``faces``) or any object with them
    fps : float
    out_fps : float, optional
        Resample the track (linear in time) to this rate first (25 for SyncNet).
    **kwargs : passed to :func:`render_sequence`

    Returns
    -------
    (T', size, size, 3) uint8 ndarray
    """
    from benchmark.metrics.vertex import rig_vertices

    coeffs = float_array(coeffs, where="render_coeffs", name="coeffs", shape="(T, K)")
    if out_fps is not None and out_fps != fps:
        coeffs = resample_frames(coeffs, fps, out_fps)
    return render_sequence(rig_vertices(rig.neutral, rig.deltas, coeffs), rig.faces, **kwargs)


class RenderError(DataError, RuntimeError):
    """A render that shows nothing (no face in the picture): the mesh's faces or the camera
    do not fit the data (a :class:`~blendvoca.errors.DataError`, exit 2; still a ``RuntimeError``)."""


def visible_fraction(frames, background: int = 250) -> np.ndarray:
    """Fraction of pixels of each frame that are not the white background, ``(T,)``."""
    frames = np.asarray(frames)
    return (frames < background).any(axis=-1).reshape(len(frames), -1).mean(axis=1)


def check_visible(frames, *, where: str, minimum: float = 0.01) -> None:
    """Raise :class:`RenderError` when some frame shows (almost) nothing.

    Parameters
    ----------
    frames : (T, H, W, 3) uint8
    where : what was rendered, for the message
    minimum : least fraction of non-background pixels a frame must have
    """
    shown = visible_fraction(frames)
    if len(shown) == 0:
        raise RenderError(f"{where}: the render has no frames")
    bad = np.flatnonzero(shown < minimum)
    if len(bad):
        raise RenderError(f"{where}: {len(bad)} of {len(shown)} frames show no face (first: frame {bad[0]}, "
                          f"{100 * shown[bad[0]]:.2f}% of pixels drawn, expected at least {100 * minimum:g}%); "
                          "check the faces (a vertex-only mesh draws nothing) and the camera")


__all__ = ["RenderError", "check_visible", "face_box", "face_camera", "front_camera", "project", "rasterize", "read_video", "render_coeffs", "render_sequence",
           "resample_frames", "visible_fraction", "write_video"]
