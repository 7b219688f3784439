"""The per-run figure ``R/<run>.png`` beside a result ``R/<run>.json``: a few key coefficient
tracks of the first test sentences against the ground truth and, for a trained method, the
training loss curve.

``benchmark.run`` writes it after storing the result and names it in its last lines. The
tracks are the stored ones (:mod:`benchmark.runs`): the method's own coefficients, or for
a vertex method the coefficients fitted to its vertices with the speaker's rig (the tracks
its rig-space metrics score), sample 0 of a stochastic method. The loss curves are those
:class:`~benchmark.methods.training_loop.StepLoop` recorded while the run trained
(:func:`~benchmark.methods.training_loop.loss_histories`). Drawn with the build report's
:func:`blendvoca.builder.report.tracks_against_figure`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmark.runs import read_run
from blendvoca.builder.report import tracks_against_figure
from blendvoca.io.coeffs import read_coeffs_csv

__all__ = ["FIGURE_SHAPES", "FIGURE_SENTENCES", "figure_path", "write_run_figure"]

#: The coefficients drawn, when the run has them.
FIGURE_SHAPES = ("jawOpen", "mouthClose", "mouthFunnel")
#: How many sentences (the first of the split, sorted) are drawn.
FIGURE_SENTENCES = 2


def figure_path(json_path) -> Path:
    """The figure of a result file: ``R/<run>.json`` -> ``R/<run>.png``."""
    json_path = Path(json_path)
    return json_path.with_suffix(".png")


def _loss_panel(histories):
    """``draw(ax)``: each loop's per-step training loss (thin) with its running mean over
    1 % of its steps, and its validations (dots), on a log axis when every loss is positive."""

    def draw(ax):
        positive = True
        for i, (desc, offset, result) in enumerate(histories):
            loss = np.asarray(result.train_loss, dtype=np.float64)
            steps = offset + np.arange(1, len(loss) + 1)
            name = desc if len(histories) == 1 else f"{desc} #{i + 1}"
            line, = ax.plot(steps, loss, lw=0.5, alpha=0.35)
            window = max(1, len(loss) // 100)
            if window > 1:
                smooth = np.convolve(loss, np.ones(window) / window, mode="valid")
                ax.plot(steps[window - 1:], smooth, lw=1.3, color=line.get_color(),
                        label=f"{name} (mean of {window} steps)")
            else:
                line.set_alpha(1.0)
                line.set_label(f"{name} (per step)")
            if result.val:
                val = np.asarray(result.val, dtype=np.float64)
                ax.plot(offset + val[:, 0], val[:, 1], "o", ms=3.5, color=line.get_color(), mfc="white",
                        label=f"{name}: validation")
                positive = positive and bool((val[:, 1] > 0).all())
            positive = positive and bool(len(loss) and (loss > 0).all())
        if positive:
            ax.set_yscale("log")
        ax.set_xlabel("training step")
        ax.set_ylabel("loss")
        ax.set_title("training loss", fontsize=9)
        ax.legend(fontsize=7, loc="upper right")

    return draw


def write_run_figure(json_path, *, ground_truth=None, histories=()) -> Path:
    """Write :func:`figure_path` of the stored run ``json_path``; return its path.

    Parameters
    ----------
    json_path : path-like
        The result file (its tracks folder beside it).
    ground_truth : callable, optional
        ``ground_truth(subject, sentence, names) -> (T, len(names))`` coefficients; default:
        the build the run was scored on (``dataset.path`` of the result), opened as the run
        opened it (:func:`benchmark.protocol.spec.open_data`).
    histories : sequence of (desc, step_offset, LoopResult)
        The training loops of the run (:func:`~benchmark.methods.training_loop.loss_histories`);
        empty: no loss panel (a reference method, or one loaded from a checkpoint).
    """
    stored = read_run(json_path)
    if ground_truth is None:
        from benchmark.protocol.spec import open_data

        dataset = open_data(stored.dataset_root)

        def ground_truth(subject, sentence, names):
            columns = [list(dataset.names).index(name) for name in names]
            return np.asarray(dataset.coeffs(subject, sentence))[:, columns]

    first = stored.keys[:FIGURE_SENTENCES]
    method = stored.result.method.display_label or stored.result.method.name
    # a vertex method's stored tracks are its vertices fitted with the speaker's rig
    kind = " (rig-space fit of its vertices)" if stored.has_vertices() else ""
    panels = []
    for subject, sentence in first:
        path = stored.track_paths(subject, sentence)[0]
        coeffs, names = read_coeffs_csv(path)
        shapes = [s for s in FIGURE_SHAPES if s in names] or list(names[:3])
        columns = [list(names).index(s) for s in shapes]
        truth = np.asarray(ground_truth(subject, sentence, shapes), dtype=np.float64)
        panels.append((f"{method}{kind}: {subject} {sentence} (solid) against the ground truth (dashed)",
                       np.asarray(coeffs, dtype=np.float64)[:, columns], shapes, truth, "ground truth", None))
    out = figure_path(json_path)
    tracks_against_figure(out, panels, below=_loss_panel(list(histories)) if histories else None)
    return out
