"""``sanity.png`` is sized to its content and names the build without its absolute path."""

from types import SimpleNamespace

import matplotlib.image
import numpy as np

from benchmark.sanity.report import build_label, plot_table, table_figure


def _table():
    entry = {"status": "held", "values": [0.1, 0.2, 0.4, 0.8, 1.6], "levels": [0, 1, 2, 4, 8], "rho": 1.0,
             "expected": "rises", "ok": True}
    failed = {**entry, "status": "failed", "rho": -1.0, "ok": False, "values": entry["values"][::-1]}
    return {"lve_rig": {"damping": entry, "time_shift": failed}, "fd_rig": {"damping": entry}}


def _texts(fig):
    return [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]


def test_the_title_names_the_build_not_its_absolute_path():
    root = "/home/someone/very/long/private/folder/blendvoca-default"
    dataset = SimpleNamespace(root=root, manifest_hash="0123456789abcdef" * 4)
    label = build_label(dataset)
    assert label == "blendvoca-default (01234567)"
    fig = table_figure(_table(), title=f"metric sanity: {label} (test split, levels small)")
    texts = " ".join(_texts(fig))
    assert "blendvoca-default (01234567)" in texts and "/home/someone" not in texts and root not in texts
    assert build_label(SimpleNamespace(root=None, manifest_hash=None)) == "build"


def test_title_and_legend_lie_inside_the_saved_image(tmp_path):
    # a title far wider than the grid: before, it ran off both sides of the image
    title = "metric sanity: " + "a-long-build-name-" * 8 + " (test split, levels small) - 2 held, 1 failed"
    fig = table_figure(_table(), title=title)
    renderer = fig.canvas.get_renderer()
    fig.canvas.draw()
    title_box = fig._suptitle.get_window_extent(renderer)
    legend_box = fig.texts[0].get_window_extent(renderer)  # the legend is the figure's first text
    assert title_box.width > fig.bbox.width  # it does not fit the grid's own size
    path = plot_table(_table(), tmp_path / "sanity.png", title=title)
    image = matplotlib.image.imread(path)
    height, width = image.shape[:2]
    # the saved image holds both texts whole (tight box + padding), and no more than a margin around them
    assert width >= title_box.width and width >= legend_box.width
    assert height >= title_box.y1 - legend_box.y0
    assert width <= max(title_box.width, legend_box.width, fig.bbox.width) + 40
    # dark (text) pixels near the left and right edges of the title's row: the title reaches both sides
    top = image[: int(title_box.height) + 12, :, :3].mean(axis=2)
    cols = np.flatnonzero((top < 0.5).any(axis=0))
    assert cols.min() < 0.05 * width and cols.max() > 0.95 * width
