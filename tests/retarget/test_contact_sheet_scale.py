"""The contact sheet's millimetre scale bar: its pixel length is the stated millimetres
through the sheet's projection."""

import numpy as np
import pytest

from blendvoca.retarget.contact_sheet import contact_sheet, scale_bar_mm, scale_bar_pixels


def test_scale_bar_lengths_are_round_and_at_most_a_third():
    assert scale_bar_mm(100.0) == 20.0  # 30 % of 100 mm -> 20
    assert scale_bar_mm(180.0) == 50.0
    assert scale_bar_mm(30.0) == 5.0
    assert scale_bar_mm(3.0) == pytest.approx(0.5)
    for width in (1.7, 12.0, 95.0, 240.0, 3100.0):
        bar = scale_bar_mm(width)
        assert 0.3 * width / 2.5 - 1e-9 <= bar <= 0.3 * width + 1e-9


def _longest_black_run(image):
    dark = (image.astype(np.float64).mean(axis=2) < 10)
    best = (0, 0, 0)
    for r, row in enumerate(dark):
        padded = np.concatenate([[0], row.astype(np.int8), [0]])
        edges = np.flatnonzero(np.diff(padded))
        for start, stop in zip(edges[::2], edges[1::2]):
            if stop - start > best[0]:
                best = (stop - start, r, start)
    return best


@pytest.mark.parametrize("mm_per_unit, scale", [(1000.0, 1.0), (1.0, 1000.0)])
def test_the_bar_measures_the_stated_millimetres(mm_per_unit, scale):
    """A 0.1 x 0.1 m square (or 100 x 100 mm in a millimetre mesh) in a 0.16 m window on a
    200 px tile: 1250 px per metre; the bar (the round length under 30 % of 160 mm: 20 mm) is 25 px."""
    grid = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 6), np.linspace(-0.05, 0.05, 6)), -1).reshape(-1, 2)
    neutral = np.column_stack([grid, np.zeros(len(grid))]) * scale
    faces = []
    for i in range(5):
        for j in range(5):
            a = i * 6 + j
            faces += [[a, a + 1, a + 7], [a, a + 7, a + 6]]
    faces = np.array(faces)
    delta = np.zeros((1, len(neutral), 3))
    delta[0, :, 2] = 0.01 * scale
    window = tuple(np.array([-0.08, 0.08, -0.08, 0.08]) * scale)
    image = contact_sheet(neutral, delta, faces, ["shape"], columns=2, tile=200, window=window,
                          mm_per_unit=mm_per_unit)
    bar_mm, pixels = scale_bar_pixels(window, 200, mm_per_unit)
    assert bar_mm == 20.0
    expected = bar_mm / 1000.0 / 0.16 * 200  # metres over the window's width, in pixels
    length, row, col = _longest_black_run(image)
    assert length == pytest.approx(expected, abs=1.0) and pixels == round(expected)
    assert col < 200 and row > 100  # under the neutral, at the bottom of its tile
    # and without a unit no bar
    plain = contact_sheet(neutral, delta, faces, ["shape"], columns=2, tile=200, window=window, mm_per_unit=None)
    assert _longest_black_run(plain)[0] < 0.5 * expected
