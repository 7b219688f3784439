"""The former numpy rasteriser of ``benchmark.render.software``, kept as the reference
:class:`~benchmark.render.software.SoftwareRenderer` is tested (and timed,
``benchmarks/bench_render.py``) against."""

from __future__ import annotations

import numpy as np

from benchmark.render.camera import project
from benchmark.render.software import BACKGROUND, BASE_COLOUR
from blendvoca.retarget.registration import vertex_normals


def reference_rasterize(vertices, faces, pose, yfov: float, width: int = 256, height: int = 256) -> np.ndarray:
    """The former rasteriser, the reference the fast one is tested against: every
    (triangle, bounding-box pixel) candidate enumerated, the nearest found by sorting."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    xy, depth = project(v, pose, yfov, width, height)
    view_dir = pose[:3, 3] - v
    view_dir /= np.linalg.norm(view_dir, axis=1, keepdims=True)
    shade = 0.25 + 0.75 * np.abs((vertex_normals(v, f) * view_dir).sum(axis=1))

    visible = np.all(depth[f] > 1e-6, axis=1)
    f = f[visible]
    p = xy[f]  # (F, 3, 2)
    area = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1])
    keep = np.abs(area) > 1e-12
    f, p, area = f[keep], p[keep], area[keep]
    x0 = np.clip(np.ceil(p[..., 0].min(axis=1) - 0.5), 0, width).astype(np.int64)
    x1 = np.clip(np.floor(p[..., 0].max(axis=1) - 0.5), -1, width - 1).astype(np.int64)
    y0 = np.clip(np.ceil(p[..., 1].min(axis=1) - 0.5), 0, height).astype(np.int64)
    y1 = np.clip(np.floor(p[..., 1].max(axis=1) - 0.5), -1, height - 1).astype(np.int64)
    nx = np.maximum(x1 - x0 + 1, 0)
    ny = np.maximum(y1 - y0 + 1, 0)
    counts = nx * ny
    image = np.full((height, width, 3), BACKGROUND, dtype=np.uint8)
    total = int(counts.sum())
    if total == 0:
        return image
    tri = np.repeat(np.arange(len(f)), counts)
    local = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    px = x0[tri] + local % nx[tri]
    py = y0[tri] + local // nx[tri]
    cx, cy = px + 0.5, py + 0.5
    q = p[tri]
    w0 = (q[:, 1, 0] - cx) * (q[:, 2, 1] - cy) - (q[:, 2, 0] - cx) * (q[:, 1, 1] - cy)
    w1 = (q[:, 2, 0] - cx) * (q[:, 0, 1] - cy) - (q[:, 0, 0] - cx) * (q[:, 2, 1] - cy)
    a = area[tri]
    b0, b1 = w0 / a, w1 / a
    b2 = 1.0 - b0 - b1
    inside = (b0 >= -1e-9) & (b1 >= -1e-9) & (b2 >= -1e-9)
    tri, px, py, b0, b1, b2 = tri[inside], px[inside], py[inside], b0[inside], b1[inside], b2[inside]
    fv = f[tri]
    z = b0 * depth[fv[:, 0]] + b1 * depth[fv[:, 1]] + b2 * depth[fv[:, 2]]
    pixel = py * width + px
    order = np.lexsort((z, pixel))
    first = order[np.r_[True, pixel[order][1:] != pixel[order][:-1]]]
    s = b0[first] * shade[fv[first, 0]] + b1[first] * shade[fv[first, 1]] + b2[first] * shade[fv[first, 2]]
    colour = np.clip(s[:, None] * BASE_COLOUR[None] * 255.0, 0, 255).astype(np.uint8)
    image.reshape(-1, 3)[pixel[first]] = colour
    return image
