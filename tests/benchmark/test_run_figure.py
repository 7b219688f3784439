"""The per-run figure beside a result: the stored tracks of the first test sentences against
the ground truth, and the training loss curve StepLoop recorded (the lines drawn are the data)."""

import matplotlib.image
import numpy as np
import pytest

import blendvoca.builder.report as report
from benchmark.methods import Method, register, unregister
from benchmark.methods.training_loop import StepLoop, loops_finished, loss_histories
from benchmark.protocol import RunSpec, run
from benchmark.run_figure import FIGURE_SENTENCES, FIGURE_SHAPES, figure_path, write_run_figure
from benchmark.runs import read_run
from tests.methods.fakes import fake_evaluate, speech_dataset

STEPS = 12


class LoopStepper(Method):
    """Trains with the one training loop: the level halves its distance to 0.05 each step, the
    loss being that distance (known in closed form); generates the level."""

    contract = 3

    def train(self, dataset, request):
        self.level = 0.5

        def step(loop):
            self.level += 0.5 * (0.05 - self.level)
            return abs(self.level - 0.05)

        StepLoop(max_steps=STEPS, desc="loop-stepper").run(step)

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((samples, utterance.num_frames, 32), self.level)


@pytest.fixture(scope="module", autouse=True)
def registered():
    register("test-loop-stepper")(LoopStepper)
    yield
    unregister("test-loop-stepper")


def _captured_figure(monkeypatch):
    """The figure ``tracks_against_figure`` saves, kept open for the test to read its lines."""
    kept = {}
    save = report._save_figure

    def keep(fig, path):
        kept["fig"] = fig
        fig.canvas.draw()
        kept["texts"] = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]
        save(fig, path)

    monkeypatch.setattr(report, "_save_figure", keep)
    return kept


def test_the_figure_draws_the_stored_tracks_the_truth_and_the_losses(tmp_path, monkeypatch):
    dataset = speech_dataset(seed=2, sentences=2, seconds=1.0)
    mark = loops_finished()
    path = run(RunSpec("test-loop-stepper", data_root="unused", samples=1, budget=None, results_dir=tmp_path),
               evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    histories = loss_histories(mark)
    (desc, offset, loop), = histories  # the one place the losses are kept: the run's one loop
    expected = [0.45 * 0.5 ** k for k in range(1, STEPS + 1)]
    assert desc == "loop-stepper" and offset == 0 and loop.train_loss == pytest.approx(expected)
    kept = _captured_figure(monkeypatch)
    names = dataset.names

    def truth(subject, sentence, shapes):
        return dataset.coeffs(subject, sentence)[:, [list(names).index(s) for s in shapes]]

    figure = write_run_figure(path, ground_truth=truth, histories=histories)
    assert figure == figure_path(path) == path.with_suffix(".png") and figure.parent == path.parent
    image = matplotlib.image.imread(figure)
    assert image.shape[:2] == (round(2.6 * (FIGURE_SENTENCES + 1) * 90), 900)  # 2 sentences + the loss panel
    axes = kept["fig"].axes
    stored = read_run(path)
    for ax, (subject, sentence) in zip(axes, stored.keys[:FIGURE_SENTENCES]):
        lines = ax.get_lines()
        assert [ln.get_label() for ln in lines] == [*FIGURE_SHAPES, *(f"{s} (ground truth)" for s in FIGURE_SHAPES)]
        generated = stored.tracks(subject, sentence)[0]
        for j, shape in enumerate(FIGURE_SHAPES):
            np.testing.assert_allclose(lines[j].get_ydata(), generated[:, names.index(shape)], atol=1e-6)
            np.testing.assert_allclose(lines[3 + j].get_ydata(), truth(subject, sentence, [shape])[:, 0])
            assert lines[j].get_color() == lines[3 + j].get_color() and lines[3 + j].get_linestyle() == "--"
        assert subject in ax.get_title() and sentence in ax.get_title()
    loss_ax = axes[FIGURE_SENTENCES]
    np.testing.assert_allclose(loss_ax.get_lines()[0].get_ydata(), expected)
    np.testing.assert_allclose(loss_ax.get_lines()[0].get_xdata(), np.arange(1, STEPS + 1))
    assert loss_ax.get_yscale() == "log" and loss_ax.get_xlabel() == "training step"


def test_without_training_there_is_no_loss_panel(tmp_path, monkeypatch):
    dataset = speech_dataset(seed=2, sentences=1, seconds=1.0)
    path = run(RunSpec("mean", data_root="unused", samples=1, budget=None, results_dir=tmp_path),
               evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    kept = _captured_figure(monkeypatch)
    figure = write_run_figure(path, ground_truth=lambda s, q, shapes: dataset.coeffs(s, q)[
        :, [list(dataset.names).index(x) for x in shapes]])
    assert len(kept["fig"].axes) == FIGURE_SENTENCES and figure.is_file()
    assert not any("training loss" in t for t in kept["texts"])


def test_the_command_writes_the_figure_beside_the_result_and_names_it(tmp_path, monkeypatch, capsys):
    from benchmark.protocol import scoring, spec
    from benchmark.run import main
    from tests.methods.fakes import fake_evaluate_split

    dataset = speech_dataset(seed=2, sentences=1, seconds=1.0)
    monkeypatch.setattr(spec, "_open_default", lambda root, vocaset=None: dataset)
    monkeypatch.setattr(scoring, "evaluate_split", fake_evaluate_split)
    rc = main(["--method", "test-loop-stepper", "--data", str(tmp_path), "--results", str(tmp_path / "r"),
               "--samples", "1", "--quiet"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    (path,) = (tmp_path / "r").glob("*.json")
    assert captured.out.strip().splitlines()[-1] == str(path)  # the last line stays the result, for scripts
    figure = path.with_suffix(".png")
    assert figure.is_file() and matplotlib.image.imread(figure).shape[1] == 900
    last = captured.err.strip().splitlines()[-1]
    assert last.startswith(f"figure: {figure}") and "ground truth" in last and "training loss" in last


class RigReplay(Method):
    """A vertex method: the speaker's rig driven by the ground truth (its rig-space fit recovers it)."""

    output = "vertices"
    contract = 3

    def train(self, dataset, request):
        self._dataset = dataset

    def generate(self, utterance, *, samples=1, seed=0):
        rig = self._dataset.rig(utterance.subject)
        coeffs = self._dataset.coeffs(utterance.subject, utterance.sentence)
        return (rig.neutral[None] + np.einsum("tk,kvc->tvc", coeffs, rig.deltas))[None]


def test_a_vertex_method_is_drawn_through_its_rig_space_coefficients(tmp_path, monkeypatch):
    dataset = speech_dataset(seed=2, sentences=1, seconds=1.0)
    register("test-rig-replay")(RigReplay)
    try:
        path = run(RunSpec("test-rig-replay", data_root="unused", samples=1, budget=None, results_dir=tmp_path),
                   evaluate=lambda tracks, ds, split, vertices=None: fake_evaluate(tracks, ds, split),
                   open_dataset=lambda root: dataset)
    finally:
        unregister("test-rig-replay")
    kept = _captured_figure(monkeypatch)
    names = list(dataset.names)
    write_run_figure(path, ground_truth=lambda s, q, shapes: dataset.coeffs(s, q)[:, [names.index(x) for x in shapes]])
    ax = kept["fig"].axes[0]
    assert "rig-space fit of its vertices" in ax.get_title()
    lines = ax.get_lines()
    stored = read_run(path)
    fitted = stored.tracks(*stored.keys[0])[0]
    for j, shape in enumerate(FIGURE_SHAPES):  # the stored rig-space fit its rig metrics score
        np.testing.assert_allclose(lines[j].get_ydata(), fitted[:, names.index(shape)], atol=1e-6)
        assert lines[3 + j].get_label() == f"{shape} (ground truth)"


def test_the_loop_keeps_the_latest_losses_only():
    from benchmark.methods.training_loop import HISTORY_LIMIT

    mark = loops_finished()
    for k in range(HISTORY_LIMIT + 3):
        StepLoop(max_steps=2, desc=f"loop{k}").run(lambda loop, k=k: float(k + loop.step))
    assert loops_finished() == mark + HISTORY_LIMIT + 3
    kept = loss_histories(mark)
    assert [desc for desc, _, _ in kept] == [f"loop{k}" for k in range(3, HISTORY_LIMIT + 3)]
    assert kept[-1][2].train_loss == [HISTORY_LIMIT + 2.0, HISTORY_LIMIT + 3.0]
    assert loss_histories(loops_finished()) == []
