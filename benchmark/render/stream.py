"""Render panels of mesh sequences to a video one frame at a time.

Each output frame is drawn into one reused buffer (every panel's views side by side,
the labels, the waveform strip under them) and written to the encoder's stdin at
once, so memory does not grow with the clip: the process holds the audio, the
coefficient track and a window of ``sources.CHUNK`` frames of vertices per panel,
and ffmpeg its encoder's look-ahead.

With ``jobs > 1`` (the software rasteriser only) worker processes
(:func:`blendvoca.runtime.processes.process_map`) draw blocks of ``BLOCK`` frames, a
few blocks per worker in flight, and the main process writes them in order: the
memory stays bounded by the window, not the clip.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from os import PathLike

import numpy as np

from blendvoca.runtime.processes import WorkerError, process_map
from blendvoca.runtime.progress import bar

#: Frames a worker draws per task.
BLOCK = 4


@dataclass
class Panel:
    """One sequence to draw: ``source`` (a frame source of ``benchmark.render.sources``),
    ``name`` (its label, none when empty) and ``where`` (what it is, for messages)."""

    name: str
    source: object
    where: str


#: Below this many view pixels in all (frames x views x side^2) a render is drawn in this
#: process: starting workers (about a second) would cost more than it saves.
POOL_THRESHOLD = 30 * 512 * 512


def default_jobs() -> int:
    """Worker processes for a render: the CPUs this process may use but one (the encoder's
    and the writer's), at most 8; 1 (no workers) on two CPUs or fewer."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cpus - 1, 8))


class _Drawer:
    """The views of every panel for one frame index: what a worker (or the main process) runs."""

    def __init__(self, sources, faces, poses, size, backend, yfov):
        from benchmark.render import open_renderer

        self.sources = sources
        self.size = size
        self.renderers = [[open_renderer(faces, pose, size=size, backend=backend, yfov=yfov,
                                         num_vertices=source.num_vertices) for pose in poses] for source in sources]

    def draw(self, k: int, index: int, out: np.ndarray) -> list[float | None]:
        """Panel ``k``'s frame ``index``, its views side by side into ``out`` ``(size, views * size, 3)``;
        the fraction each view drew (``None`` where its renderer does not say)."""
        vertices = self.sources[k].frame(index)
        shown = []
        size = self.size
        for v, renderer in enumerate(self.renderers[k]):
            view = out[:, v * size:(v + 1) * size]
            if view.flags.c_contiguous:
                renderer.render(vertices, out=view)
            else:
                view[...] = renderer.render(vertices)
            shown.append(getattr(renderer, "drawn_fraction", None))
        return shown

    def close(self) -> None:
        for row in self.renderers:
            for renderer in row:
                close = getattr(renderer, "close", None)
                if close is not None:
                    close()


_WORKER: _Drawer | None = None


def _worker_init(args) -> None:
    global _WORKER
    _WORKER = _Drawer(*args)


def _worker_frame(request):
    """Draw ``(t, [index or None per panel])``; return ``(t, [(pixels, shown) or None per panel])``."""
    t, indices = request
    row = []
    for k, index in enumerate(indices):
        if index is None:
            row.append(None)
            continue
        pixels = np.empty((_WORKER.size, _WORKER.size * len(_WORKER.renderers[k]), 3), dtype=np.uint8)
        row.append((pixels, _WORKER.draw(k, index, pixels)))
    return t, row


def _requests(panels, count) -> Iterator[tuple[int, list]]:
    """For each output frame, the source frame each panel shows, ``None`` where it holds its last."""
    for t in range(count):
        yield t, [t if t < len(p.source) else None for p in panels]


def _serial(panels, drawer, count, view_width, size) -> Iterator:
    pixels = [np.empty((size, view_width, 3), dtype=np.uint8) for _ in panels]
    for t, indices in _requests(panels, count):
        row = []
        for k, index in enumerate(indices):
            row.append(None if index is None else (pixels[k], drawer.draw(k, index, pixels[k])))
        yield t, row


def _pooled(panels, args, count, jobs) -> Iterator:
    import multiprocessing

    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    return process_map(_worker_frame, _requests(panels, count), workers=jobs, initializer=_worker_init,
                       initargs=(args,), chunksize=BLOCK, start_method=method)


def _first_block(frames: Iterator, jobs: int):
    """``frames`` with its first item fetched, or ``(None, 1)`` when the worker processes
    cannot start (a note says so; the render then runs in this process)."""
    import itertools
    import sys

    try:
        first = next(frames)
    except StopIteration:
        return iter(()), jobs
    except (WorkerError, OSError, EOFError) as error:
        frames.close()
        print(f"note: the {jobs} drawing processes did not start ({type(error).__name__}: {error}); drawing in this "
              "process", file=sys.stderr)
        return None, 1
    return itertools.chain([first], frames), jobs


def render_video(out: str | PathLike, panels: Sequence[Panel], faces, poses, *, fps: float, size: int,
                 backend: str = "auto", yfov: float = np.pi / 8, audio=None, rate: int = 16000,
                 waveform: bool = True, jobs: int | None = 1) -> tuple[int, int, int]:
    """Stream a render to ``out`` (MP4).

    Panel frames are drawn from each pose in ``poses`` (side by side); panels are side by
    side too. With ``audio`` the video lasts as long as it (a panel's last frame is held
    when it ends first, frames past the audio are left out) and, with ``waveform``, a
    strip under the views shows it; without, it lasts as long as the shortest panel.
    A panel view in which some frame shows no face fails with
    :class:`benchmark.render.RenderError` (after the first frame when that one shows
    nothing, else at the end) and leaves no file. ``backend="auto"`` takes the numpy
    rasteriser over a CPU OpenGL (``choose_backend(cpu_gl=False)``). ``jobs`` worker
    processes draw the frames with the numpy rasteriser (pyrender draws in this process); ``None``:
    :func:`default_jobs` for a render of at least ``POOL_THRESHOLD`` view pixels, else 1.

    Returns
    -------
    (frames, width, height) of the video written
    """
    from benchmark.render import VisibilityCheck, choose_backend
    from benchmark.render.compose import Waveform, draw_label, label_mask
    from benchmark.render.video import VideoWriter, frame_count

    backend = choose_backend(backend, cpu_gl=False)
    if audio is not None:
        audio = np.asarray(audio, dtype=np.float32)  # (N,) or (N, C): muxed as recorded
        count = frame_count(fps, len(audio), rate)
    else:
        count = min(len(p.source) for p in panels)
    view_width = size * len(poses)
    width = view_width * len(panels)
    strip_height = max(size // 5, 16) if (audio is not None and waveform) else 0
    height = size + strip_height
    frame = np.full((height, width, 3), 255, dtype=np.uint8)
    wave = Waveform(audio if audio.ndim == 1 else audio.mean(axis=1), rate, fps, width, strip_height) \
        if strip_height else None
    masks = [label_mask(p.name, scale=max(1, size // 256)) if p.name else None for p in panels]
    checks = [[VisibilityCheck(f"render of {p.where}") for _ in poses] for p in panels]
    args = ([p.source for p in panels], faces, list(poses), size, backend, yfov)
    if jobs is None:
        jobs = default_jobs() if count * len(panels) * len(poses) * size * size >= POOL_THRESHOLD else 1
    jobs = max(1, min(int(jobs), -(-count // BLOCK))) if backend == "software" else 1
    drawer = _Drawer(*args) if jobs == 1 else None
    writer = None
    pooled = None
    try:
        if drawer is None:
            pooled = _pooled(panels, args, count, jobs)
            frames, jobs = _first_block(pooled, jobs)
            if frames is None:  # the workers could not start (e.g. a main module run from stdin)
                pooled = None
                drawer = _Drawer(*args)
        if drawer is not None:
            frames = _serial(panels, drawer, count, view_width, size)
        with bar(total=count, desc=f"render ({backend}{f', {jobs} processes' if jobs > 1 else ''})",
                 unit="frame") as frames_bar:
            for t, row in frames:
                for k, drawn in enumerate(row):
                    if drawn is None:
                        continue  # the panel has ended: its last frame stays
                    pixels, shown = drawn
                    left = k * view_width
                    for v, check in enumerate(checks[k]):
                        check.add(pixels[:, v * size:(v + 1) * size], shown[v])
                    region = frame[:size, left:left + view_width]
                    region[...] = pixels
                    if masks[k] is not None:
                        draw_label(region, masks[k])
                if t == 0:  # a render that shows nothing is usually so from its first frame: stop before encoding
                    for checks_of_panel in checks:
                        for check in checks_of_panel:
                            if check.bad:
                                check.finish(first_only=True)
                    writer = VideoWriter(out, width, height, fps, audio=audio, rate=rate)
                if wave is not None:
                    wave.frame(t, out=frame[size:])
                writer.write(frame)
                frames_bar.update()
        for checks_of_panel in checks:
            for check in checks_of_panel:
                check.finish()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    finally:
        if pooled is not None:
            pooled.close()  # stops the workers
        if drawer is not None:
            drawer.close()
    writer.close()
    return count, width, height
