"""Headless rendering of coefficient tracks and mesh sequences to video.

``open_renderer`` gives one view's renderer (set up once, then frame after frame):
pyrender over EGL or the numpy rasteriser (``choose_backend``). ``render_sequence``
renders a whole sequence into an array; ``python -m benchmark.render`` streams frames to
the encoder instead (``benchmark.render.stream``) and, with ``--backend auto``, leaves an
EGL context that rasterises on the CPU (Mesa's llvmpipe) for the numpy rasteriser, which
is several times faster.
"""

from __future__ import annotations

import functools

import numpy as np

from benchmark.render.camera import face_box, face_camera, front_camera, project
from benchmark.render.software import SoftwareRenderer, rasterize
from benchmark.render.timing import resample_frames
from benchmark.render.video import read_video, write_video
from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.runtime.progress import bar

BACKENDS = ("auto", "pyrender", "software")


@functools.lru_cache(maxsize=1)
def _egl_name() -> str | None:
    from benchmark.render.pyrender_backend import egl_renderer_name

    return egl_renderer_name()


def _egl_ok() -> bool:
    return _egl_name() is not None


def choose_backend(backend: str = "auto", *, cpu_gl: bool = True) -> str:
    """The backend a render uses: ``"pyrender"`` or ``"software"``.

    ``"auto"`` is pyrender when a headless EGL context opens, else the numpy rasteriser;
    with ``cpu_gl=False`` (``python -m benchmark.render``) an EGL context that rasterises
    on the CPU (Mesa's llvmpipe, softpipe: several times slower than the numpy
    rasteriser) counts as none. ``render_sequence`` keeps ``cpu_gl=True``, so the frames
    scored by SyncNet do not change with this choice. ``"pyrender"`` without EGL is a
    :class:`~blendvoca.errors.UserError`.
    """
    from benchmark.render.pyrender_backend import is_software_gl

    if backend not in BACKENDS:
        raise UserError(f"render: backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "auto":
        usable = _egl_ok() and (cpu_gl or not is_software_gl(_egl_name()))
        return "pyrender" if usable else "software"
    if backend == "pyrender" and not _egl_ok():
        raise UserError("render_sequence: backend 'pyrender' cannot open a headless EGL context here (pyrender, "
                        "PyOpenGL and an EGL driver are needed: pip install 'blendvoca[render]'); use backend "
                        "'software' or 'auto'")
    return backend


def open_renderer(faces, pose, *, size: int = 256, backend: str = "auto", yfov: float = np.pi / 8,
                  num_vertices: int | None = None):
    """A renderer of one view: ``renderer.render(vertices (V, 3), out=None) -> (size, size, 3)
    uint8`` frame after frame, ``renderer.close()`` at the end (a context manager too).

    Parameters
    ----------
    faces : (F, 3) int array_like
    pose : (4, 4) camera-to-world
    size : int, backend : {"auto", "pyrender", "software"}, yfov : float
    num_vertices : int, optional, the frames' vertex count
    """
    backend = choose_backend(backend)
    if backend == "pyrender":
        from benchmark.render.pyrender_backend import PyrenderRenderer

        return PyrenderRenderer(faces, pose, yfov, size, size)
    return SoftwareRenderer(faces, pose, yfov, size, size, num_vertices=num_vertices)


def render_sequence(vertices, faces, *, size: int = 256, backend: str = "auto", yfov: float = np.pi / 8,
                    pose=None) -> np.ndarray:
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
    backend = choose_backend(backend)
    frames = np.empty((len(vertices), size, size, 3), dtype=np.uint8)
    renderer = open_renderer(faces, pose, size=size, backend=backend, yfov=yfov, num_vertices=vertices.shape[1])
    try:
        for t, v in enumerate(bar(vertices, desc=f"render ({backend})", unit="frame")):
            renderer.render(v, out=frames[t])
    finally:
        close = getattr(renderer, "close", None)
        if close is not None:
            close()
    return frames


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


class VisibilityCheck:
    """:func:`check_visible` frame by frame, for a render that is streamed: ``add(frame)``
    for each frame, ``finish()`` at the end raises the same :class:`RenderError`."""

    def __init__(self, where: str, minimum: float = 0.01, background: int = 250):
        self.where, self.minimum, self.background = where, minimum, background
        self.count = 0
        self.bad = 0
        self.first = None  # (frame, fraction shown) of the first bad frame

    def add(self, frame, shown: float | None = None) -> float:
        """Record one ``(H, W, 3)`` frame (or the fraction ``shown`` of its pixels that its
        renderer drew, when it knows); return that fraction."""
        if shown is None:
            shown = float((np.asarray(frame) < self.background).any(axis=-1).mean())
        if shown < self.minimum:
            self.bad += 1
            if self.first is None:
                self.first = (self.count, shown)
        self.count += 1
        return shown

    def finish(self, first_only: bool = False) -> None:
        """Raise :class:`RenderError` when a frame showed (almost) nothing; ``first_only``:
        called after the first frame, before the others are drawn."""
        if self.count == 0:
            raise RenderError(f"{self.where}: the render has no frames")
        if self.bad:
            frame, shown = self.first
            drawn = f"{100 * shown:.2f}% of pixels drawn, expected at least {100 * self.minimum:g}%"
            which = (f"the first frame shows no face ({drawn})" if first_only else
                     f"{self.bad} of {self.count} frames show no face (first: frame {frame}, {drawn})")
            raise RenderError(f"{self.where}: {which}; check the faces (a vertex-only mesh draws nothing) "
                              "and the camera")


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


__all__ = ["RenderError", "SoftwareRenderer", "VisibilityCheck", "check_visible", "choose_backend", "face_box", "face_camera", "front_camera", "open_renderer", "project", "rasterize", "read_video", "render_coeffs", "render_sequence",
           "resample_frames", "visible_fraction", "write_video"]
