"""A contact sheet: every blendshape of a rig drawn from the front, in one image.

A small numpy z-buffer rasteriser draws Gouraud-shaded triangles (back faces culled);
matplotlib's Agg backend only writes the titles. Nothing needs OpenGL, so it runs
on any CI machine.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from blendvoca.runtime.progress import bar

from ._checks import as_faces, as_vertices
from .registration import vertex_normals

_GREY = np.array([0.80, 0.80, 0.82])
_WARM = np.array([0.95, 0.35, 0.15])


def rasterise_front(
    vertices: np.ndarray,
    faces: np.ndarray,
    face_colours: np.ndarray,
    window: tuple[float, float, float, float],
    size: tuple[int, int],
    *,
    background: float = 1.0,
) -> np.ndarray:
    """Orthographic front view (looking down -z, +y up) of coloured triangles.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) int ndarray
    face_colours : (F, 3) or (F, 3, 3) float ndarray
        RGB in [0, 1] per face, or per face corner (interpolated across the face:
        Gouraud shading).
    window : (x_min, x_max, y_min, y_max)
        Region of the x-y plane mapped onto the image.
    size : (height, width)
        Image size in pixels.
    background : float
        Grey level of empty pixels.

    Returns
    -------
    image : (H, W, 3) float64 ndarray
        The nearest (largest z) front-facing triangle covering each pixel centre.
    """
    H, W = size
    x0, x1, y0, y1 = window
    P = np.empty((len(vertices), 3))
    P[:, 0] = (vertices[:, 0] - x0) / (x1 - x0) * W - 0.5
    P[:, 1] = (y1 - vertices[:, 1]) / (y1 - y0) * H - 0.5
    P[:, 2] = vertices[:, 2]
    tri = P[faces]  # (F, 3, 3) pixel coordinates + depth
    # in image coordinates (y down) a front-facing triangle is clockwise
    area = (tri[:, 1, 0] - tri[:, 0, 0]) * (tri[:, 2, 1] - tri[:, 0, 1]) - (tri[:, 2, 0] - tri[:, 0, 0]) * (
        tri[:, 1, 1] - tri[:, 0, 1]
    )
    keep = area < 0
    colours = np.asarray(face_colours, dtype=np.float64)
    if colours.ndim == 2:
        colours = np.repeat(colours[:, None, :], 3, axis=1)
    tri, colours, area = tri[keep], colours[keep], area[keep]
    lo = np.floor(tri[:, :, :2].min(axis=1)).astype(np.int64)
    hi = np.ceil(tri[:, :, :2].max(axis=1)).astype(np.int64)
    span = np.maximum(hi - lo + 1, 1)  # (T, 2): the bounding box's width and height
    best_depth = np.full(H * W, -np.inf)
    image = np.full((H * W, 3), background, dtype=np.float64)
    # group triangles by the width and height of their bounding box (rounded up to
    # powers of two) so each group tests a small fixed grid of candidate pixels
    bits = np.ceil(np.log2(span)).astype(np.int64)
    group = bits[:, 0] * 64 + bits[:, 1]
    for g in np.unique(group):
        sel = np.flatnonzero(group == g)
        nx, ny = 1 << int(g // 64), 1 << int(g % 64)
        oy, ox = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
        for chunk in np.array_split(sel, max(1, len(sel) * nx * ny // 2_000_000 + 1)):
            t = tri[chunk]
            px = lo[chunk, 0][:, None] + ox.ravel()[None]  # (T, n*n)
            py = lo[chunk, 1][:, None] + oy.ravel()[None]
            # barycentric coordinates of the pixel centres
            ax, ay = t[:, 0, 0][:, None], t[:, 0, 1][:, None]
            bx, by = t[:, 1, 0][:, None], t[:, 1, 1][:, None]
            cx, cy = t[:, 2, 0][:, None], t[:, 2, 1][:, None]
            a = area[chunk][:, None]
            w1 = ((px - ax) * (cy - ay) - (cx - ax) * (py - ay)) / a
            w2 = ((bx - ax) * (py - ay) - (px - ax) * (by - ay)) / a
            w0 = 1.0 - w1 - w2
            inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0) & (px >= 0) & (px < W) & (py >= 0) & (py < H)
            if not inside.any():
                continue
            depth = w0 * t[:, 0, 2][:, None] + w1 * t[:, 1, 2][:, None] + w2 * t[:, 2, 2][:, None]
            which, _ = np.nonzero(inside)
            pix = (py * W + px)[inside]
            dep = depth[inside]
            bary = np.stack([w0[inside], w1[inside], w2[inside]], axis=1)
            order = np.lexsort((-dep, pix))  # per pixel, nearest first
            pix, dep, which, bary = pix[order], dep[order], which[order], bary[order]
            first = np.ones(len(pix), dtype=bool)
            first[1:] = pix[1:] != pix[:-1]
            pix, dep, which, bary = pix[first], dep[first], which[first], bary[first]
            nearer = dep > best_depth[pix]
            best_depth[pix[nearer]] = dep[nearer]
            corner = colours[chunk][which[nearer]]  # (N, 3 corners, RGB)
            image[pix[nearer]] = np.einsum("nc,ncr->nr", bary[nearer], corner)
    return image.reshape(H, W, 3)


def shaded_face_colours(
    vertices: np.ndarray,
    faces: np.ndarray,
    displacement: np.ndarray | None = None,
    *,
    light: Sequence[float] = (0.3, 0.4, 1.0),
) -> np.ndarray:
    """Lambert-shaded grey per face corner (vertex normals), tinted by relative displacement.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) int ndarray
    displacement : (V,) float ndarray, optional
        Displacement magnitude per vertex; tinted relative to its maximum.
    light : (3,) float
        Direction towards the light.

    Returns
    -------
    colours : (F, 3, 3) float64 ndarray in [0, 1]
        RGB of each corner of each face.
    """
    n = vertex_normals(vertices, faces)
    lvec = np.asarray(light, dtype=np.float64)
    shade = 0.25 + 0.75 * np.clip(n @ (lvec / np.linalg.norm(lvec)), 0.0, 1.0)  # (V,)
    colour = np.broadcast_to(_GREY, (len(vertices), 3)).copy()
    if displacement is not None and np.max(displacement) > 0:
        t = (displacement / np.max(displacement))[:, None]
        colour = (1 - t) * _GREY + t * _WARM
    return np.clip(colour * shade[:, None], 0.0, 1.0)[faces]


def face_window(neutral: np.ndarray, deltas: np.ndarray) -> tuple[float, float, float, float]:
    """A square around the moving vertices (or the whole mesh), 15 % margin."""
    mag = np.linalg.norm(deltas, axis=2).max(axis=0) if len(deltas) else np.zeros(len(neutral))
    moving = mag > 0.05 * mag.max() if mag.max() > 0 else np.ones(len(neutral), dtype=bool)
    if moving.sum() < 3:
        moving[:] = True
    lo, hi = neutral[moving, :2].min(axis=0), neutral[moving, :2].max(axis=0)
    extent = (hi - lo).max() * 1.3
    centre = (hi + lo) / 2
    return (centre[0] - extent / 2, centre[0] + extent / 2, centre[1] - extent / 2, centre[1] + extent / 2)


#: Lengths a scale bar may take, in millimetres (times powers of ten).
_BAR_STEPS = (1.0, 2.0, 5.0)


def scale_bar_mm(window_mm: float, *, fraction: float = 0.3) -> float:
    """The longest round length (1, 2 or 5 times a power of ten, millimetres) at most
    ``fraction`` of a tile's width of ``window_mm`` millimetres."""
    if not window_mm > 0:
        raise ValueError(f"scale_bar_mm: expected a positive window width, got {window_mm}")
    target = fraction * window_mm
    exponent = np.floor(np.log10(target))
    return float(max(step * 10.0**exponent for step in _BAR_STEPS if step * 10.0**exponent <= target * (1 + 1e-9)))


def scale_bar_pixels(window, tile: int, mm_per_unit: float) -> tuple[float, int]:
    """The scale bar of a ``tile``-pixel tile of ``window`` (mesh units): ``(length in mm, length in pixels)``."""
    width_mm = (window[1] - window[0]) * mm_per_unit
    bar_mm = scale_bar_mm(width_mm)
    return bar_mm, int(round(bar_mm / width_mm * tile))


def contact_sheet(
    neutral: np.ndarray,
    deltas: np.ndarray,
    faces: np.ndarray,
    names: Sequence[str],
    *,
    columns: int = 8,
    tile: int = 200,
    highlight: bool = True,
    window: tuple[float, float, float, float] | None = None,
    mm_per_unit: float | None = 1000.0,
) -> np.ndarray:
    """Render the neutral and every blendshape from the front (+z towards the viewer, +y up),
    with a millimetre scale bar under the neutral.

    Parameters
    ----------
    neutral : (V, 3) float ndarray
    deltas : (K, V, 3) float ndarray
    faces : (F, 3) int ndarray
    names : sequence of str, length K
        Tile titles.
    columns : int
        Tiles per row.
    tile : int
        Tile height in pixels (the drawing; a title strip is added above).
    highlight : bool
        Tint faces by displacement (relative to the shape's largest) so the region
        a shape moves stands out.
    window : (x_min, x_max, y_min, y_max), optional
        Region of the x-y plane drawn; default: a square around the vertices that
        move by more than 5 % of the rig's largest displacement (the face), or the
        whole mesh when nothing moves.
    mm_per_unit : float or None
        Millimetres per mesh unit: 1000 for metres (BlendVOCA's rigs, FLAME, the ARKit
        reference; DESIGN.md), 1 for a mesh in millimetres; None draws no scale bar.
        The bar (black, 3 px high, bottom left of the neutral's tile) is
        :func:`scale_bar_mm` long, labelled in mm; every tile has the same scale.

    Returns
    -------
    image : (H, W, 3) uint8 ndarray
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    N = as_vertices(neutral, "contact_sheet", name="neutral")
    F = as_faces(faces, len(N), "contact_sheet")
    D = np.asarray(deltas, dtype=np.float64)
    if D.ndim != 3 or D.shape[1:] != N.shape:
        raise ValueError(f"contact_sheet: expected deltas of shape (K, {len(N)}, 3), got {D.shape}")
    if len(names) != len(D):
        raise ValueError(f"contact_sheet: {len(D)} shapes but {len(names)} names")
    if columns < 1 or tile < 16:
        raise ValueError(f"contact_sheet: expected columns >= 1 and tile >= 16, got {columns} and {tile}")
    titles = ["Neutral", *names]
    if window is None:
        window = face_window(N, D)
    strip = 16
    rows = int(np.ceil(len(titles) / columns))
    sheet = np.ones((rows * (tile + strip), columns * tile, 3))
    for k, title in enumerate(bar(titles, desc="contact sheet", unit="shape")):
        delta = np.zeros_like(N) if k == 0 else D[k - 1]
        X = N + delta
        colours = shaded_face_colours(X, F, np.linalg.norm(delta, axis=1) if highlight and k else None)
        r, c = divmod(k, columns)
        y = r * (tile + strip) + strip
        sheet[y : y + tile, c * tile : (c + 1) * tile] = rasterise_front(X, F, colours, window, (tile, tile))
    bar_label = None
    if mm_per_unit is not None:
        bar_mm, pixels = scale_bar_pixels(window, tile, mm_per_unit)
        row, col = strip + tile - 8, 6  # the neutral's tile, bottom left
        sheet[row - 3 : row, col : col + pixels] = 0.0
        bar_label = (col, row - 6, f"{bar_mm:g} mm")
    H, W = sheet.shape[:2]
    fig = Figure(figsize=(W / 100, H / 100), dpi=100)
    canvas = FigureCanvasAgg(fig)
    fig.figimage(sheet, 0, 0)
    if bar_label is not None:
        x, y, text = bar_label
        fig.text(x / W, 1 - y / H, text, ha="left", va="bottom", fontsize=7)
    for k, title in enumerate(titles):
        r, c = divmod(k, columns)
        fig.text((c + 0.5) * tile / W, 1 - (r * (tile + strip) + 2) / H, title, ha="center", va="top", fontsize=8)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:H, :W, :3].copy()
