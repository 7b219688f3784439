"""The build report's pictures: the rig contact sheet of every speaker and the fit-error heat
map of the worst sentence (the one the report's numbers name), with its error in closed form."""

import re

import matplotlib.image
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blendvoca.builder.report import (RIG_SHEET_COUNT, RIG_TILE, fit_errors, rig_sheet_figure, worst_fit_figure,
                                      worst_sentence)
from blendvoca.builder.state import read_record, record_path
from blendvoca.rig import Rig
from blendvoca.vocaset import open_vocaset


def _per_sentence_rows(report: str) -> dict:
    """``{(speaker, sentence): max error mm}`` from the report's per-sentence table."""
    section = report.split("## Per sentence", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 9 and re.fullmatch(r"[0-9.]+", cells[4]):
            rows[(cells[0], cells[1])] = float(cells[4])
    return rows


def test_the_report_links_a_rig_sheet_of_every_speaker(built_dataset, synthetic_corpus):
    corpus = open_vocaset(synthetic_corpus)
    report = (built_dataset / "report" / "README.md").read_text()
    assert "(rigs.png)" in report and "(worst_fit.png)" in report
    image = matplotlib.image.imread(built_dataset / "report" / "rigs.png")
    speakers = len(corpus.subjects)
    # a row per speaker, the neutral and the key shapes in columns, tiles of RIG_TILE pixels
    assert image.shape[:2] == (16 + speakers * RIG_TILE, 90 + (1 + RIG_SHEET_COUNT) * RIG_TILE)
    for r in range(speakers):
        neutral = image[16 + r * RIG_TILE: 16 + (r + 1) * RIG_TILE, 90: 90 + RIG_TILE, :3]
        jaw = image[16 + r * RIG_TILE: 16 + (r + 1) * RIG_TILE, 90 + RIG_TILE: 90 + 2 * RIG_TILE, :3]
        assert (neutral.mean(axis=2) < 0.9).mean() > 0.3  # a face fills the tile
        tint = jaw[..., 0] - jaw[..., 2]  # jawOpen's moving region is tinted warm; the neutral is grey
        assert (tint > 0.2).sum() > 50 and (neutral[..., 0] - neutral[..., 2] > 0.2).sum() == 0
    assert "jawOpen" in report and "mouthFunnel" in report.split("(rigs.png)")[0].rsplit("## ", 1)[1]


def test_the_heat_map_shows_the_sentence_with_the_largest_error(built_dataset, synthetic_corpus):
    report = (built_dataset / "report" / "README.md").read_text()
    rows = _per_sentence_rows(report)
    assert len(rows) == 12
    worst = max(rows, key=rows.get)
    assert f"Fit error of the worst sentence ({worst[0]} {worst[1]}," in report
    records = {key: read_record(record_path(built_dataset, "sentences", *key)) for key in rows}
    assert worst_sentence(records) == worst
    image = matplotlib.image.imread(built_dataset / "report" / "worst_fit.png")
    assert image.shape[0] > 250 and 1.0 < image.shape[1] / image.shape[0] < 1.6
    # its worst frame's largest vertex error is the one the table reports
    corpus = open_vocaset(synthetic_corpus)
    subject, sentence = worst
    from blendvoca import format as fmt

    rig = fmt.read_rig(built_dataset, subject)
    coeffs, _ = fmt.read_coeffs(built_dataset, subject, sentence, names=rig.names)
    shown = worst_fit_figure(built_dataset.parent / "w.png", rig, coeffs, corpus.frames(subject, sentence),
                             np.asarray(corpus.head_index()), title="t")
    assert shown["max_error_mm"] == pytest.approx(rows[worst], abs=2e-3)  # the table's 3 decimals (+ CSV rounding)


def _toy_rig():
    rng = np.random.default_rng(0)
    grid = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 8), np.linspace(-0.05, 0.05, 8)), -1).reshape(-1, 2)
    neutral = np.column_stack([grid, 0.01 * rng.standard_normal(len(grid))])
    faces = np.array([[i * 8 + j, i * 8 + j + 1, i * 8 + j + 9] for i in range(7) for j in range(7)]
                     + [[i * 8 + j, i * 8 + j + 9, i * 8 + j + 8] for i in range(7) for j in range(7)])
    deltas = 0.005 * rng.standard_normal((3, len(neutral), 3))
    return Rig(neutral=neutral, deltas=deltas, names=("jawOpen", "mouthFunnel", "mouthClose"), faces=faces)


def test_fit_errors_closed_form_and_posed_frames():
    rig = _toy_rig()
    coeffs = np.random.default_rng(1).uniform(0, 1, (5, 3))
    frames = rig.neutral[None] + np.einsum("tk,kvc->tvc", coeffs, rig.deltas)
    frames[3, 10] += [0.0, 0.0, 0.004]  # a planted 4 mm error at frame 3, vertex 10
    head = np.arange(len(rig.neutral))
    errors = fit_errors(rig, coeffs, frames, head)
    expected = np.zeros_like(errors)
    expected[3, 10] = 0.004
    np.testing.assert_allclose(errors, expected, atol=1e-12)
    # outside the fitted vertices: 0
    assert fit_errors(rig, coeffs, frames, head[head != 10])[3, 10] == 0.0
    # a head pose (rotation + translation per frame) is taken out before measuring
    posed = frames.copy()
    posed[3, 10] -= [0.0, 0.0, 0.004]
    for t in range(len(posed)):
        R = Rotation.from_euler("xyz", [0.1 * t, -0.05, 0.2]).as_matrix()
        posed[t] = posed[t] @ R.T + [0.01 * t, 0.02, -0.03]
    np.testing.assert_allclose(fit_errors(rig, coeffs, posed, head, posed=True), 0.0, atol=1e-9)


def test_worst_fit_figure_picks_the_frame_with_the_largest_error(tmp_path):
    rig = _toy_rig()
    coeffs = np.full((6, 3), 0.5)
    frames = rig.neutral[None] + np.einsum("tk,kvc->tvc", coeffs, rig.deltas)
    frames[4, 20, 1] += 0.003
    frames[2, 5, 1] += 0.001
    shown = worst_fit_figure(tmp_path / "w.png", rig, coeffs, frames, np.arange(len(rig.neutral)), title="toy")
    assert shown["frame"] == 4 and shown["max_error_mm"] == pytest.approx(3.0)
    assert shown["rmse_mm"] == pytest.approx(3.0 / np.sqrt(len(rig.neutral)))
    assert (tmp_path / "w.png").stat().st_size > 5_000


def test_rig_sheet_keeps_the_shapes_every_rig_has(tmp_path):
    rig = _toy_rig()
    drawn = rig_sheet_figure(tmp_path / "r.png", {"A": rig, "B": rig})
    assert drawn == ["jawOpen", "mouthFunnel", "mouthClose"]  # in RIG_SHEET_SHAPES' order
    image = matplotlib.image.imread(tmp_path / "r.png")
    assert image.shape[:2] == (16 + 2 * RIG_TILE, 90 + 4 * RIG_TILE)
