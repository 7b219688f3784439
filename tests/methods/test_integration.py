"""The runner and baselines on a real (tiny) BlendVOCA build with its own corpus meshes.

Scored with the vertex metrics only (the latent metrics are the metrics module's
business and dominate the time); slow because the shared fixture builds the dataset.
"""

import json

import pytest

from baselines.mesh_adapter.export import exported_corpus_meshes
from benchmark.protocol import RunSpec, run

pytestmark = pytest.mark.slow


#: The vertex metrics in both reference spaces.
VERTEX = tuple(f"{name}_{space}" for name in ("lve", "mve", "fdd", "energy") for space in ("mesh", "rig"))


def _vertex_only(generated, dataset, split="test", vertices=None):
    from benchmark.evaluation import EvaluationSettings, evaluate_split
    from benchmark.protocol import Generated

    return evaluate_split(Generated(generated, vertices=vertices), dataset, split,
                          EvaluationSettings(mesh=True, workers=1), metrics=VERTEX)


def _run(name, built_dataset, tmp_path, **kw):
    evaluate = kw.pop("evaluate", _vertex_only)
    path = run(RunSpec(name, data_root=built_dataset, results_dir=tmp_path / "results", **kw),
               evaluate=evaluate)
    return json.loads(path.read_text())


def test_reference_rows_and_mesh_adapter_on_real_build(built_dataset, synthetic_corpus, tmp_path):
    gt = _run("ground-truth", built_dataset, tmp_path)
    static = _run("static", built_dataset, tmp_path)
    assert gt["metrics"]["lve_rig"]["mean"] == 0.0 and gt["metrics"]["mve_rig"]["mean"] == 0.0
    # against the source meshes the ground truth has the rig's floor: what the fit leaves
    floor = gt["metrics"]["lve_mesh"]["mean"]
    assert 0 < floor and 0 < gt["metrics"]["mve_mesh"]["mean"] < 0.5
    assert static["metrics"]["lve_rig"]["mean"] > 0.1  # mm: the corpus really moves the lips
    assert static["metrics"]["lve_mesh"]["mean"] > floor
    assert gt["dataset"]["manifest_hash"] == static["dataset"]["manifest_hash"]

    for fps in (60, 30):
        config = exported_corpus_meshes(synthetic_corpus, tmp_path / f"meshes{fps}", fps=fps)
        adapted = _run("mesh-adapter", built_dataset, tmp_path, config={"config": str(config)})
        assert adapted["method"]["label"] == f"corpus meshes ({fps} fps)"
        # the corpus meshes are what the build fitted: the adapter's fit lands near the ground
        # truth in rig space and, a coefficient row, at the rig's floor in mesh space (the 30 fps
        # export is interpolated back to 60 fps)
        metrics = adapted["metrics"]
        for name in ("lve", "mve"):
            assert metrics[f"{name}_rig"]["mean"] < 0.25 * static["metrics"][f"{name}_rig"]["mean"], (fps, name)
            assert metrics[f"{name}_mesh"]["mean"] == pytest.approx(gt["metrics"][f"{name}_mesh"]["mean"],
                                                                    rel=0.1 if fps == 60 else 0.5), (fps, name)


def _replay_class():
    """A vertex-output method that replays the source meshes (plus ``offset`` metres on every coordinate)."""
    import numpy as np

    from benchmark.methods import Method

    class CorpusReplay(Method):
        name = "corpus-replay"
        output = "vertices"

        def __init__(self, offset=0.0):
            super().__init__(offset=offset)

        contract = 3

        def train(self, dataset, request):
            self._dataset = dataset

        def generate(self, utterance, *, samples=1, seed=0):
            frames = self._dataset.vertices(utterance.subject, utterance.sentence)
            return (frames + self._config["offset"])[None].astype(np.float32)

    return CorpusReplay


def test_dataset_vertices_and_template_from_the_recorded_corpus(built_dataset, synthetic_corpus, tmp_path,
                                                                monkeypatch):
    import numpy as np

    from benchmark.data import open_blendvoca
    from blendvoca.vocaset import open_vocaset

    ds = open_blendvoca(built_dataset)
    corpus = open_vocaset(synthetic_corpus)
    subject = ds.split("test")[0]
    sentence = ds.sentences(subject)[0]
    frames = ds.vertices(subject, sentence)
    assert frames.shape == (ds.coeffs(subject, sentence).shape[0], 5023, 3) and frames.dtype == np.float64
    np.testing.assert_array_equal(frames, corpus.frames(subject, sentence))
    np.testing.assert_array_equal(ds.template(subject), corpus.template(subject))
    np.testing.assert_allclose(ds.template(subject), ds.rig(subject).neutral)
    assert ds.faces().shape[1] == 3 and ds.faces().max() == 5022
    # an explicit corpus wins over the recorded one
    assert open_blendvoca(built_dataset, vocaset=synthetic_corpus).corpus_root() == synthetic_corpus
    # an unreachable corpus is a clear error naming the remedy
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("blendshape_coeffs", "splits.json"):
        (copy / name).symlink_to(built_dataset / name)
    manifest = json.loads((built_dataset / "manifest.json").read_text())
    manifest.setdefault("inputs", {}).setdefault("vocaset", {})["path"] = str(tmp_path / "gone")
    (copy / "manifest.json").write_text(json.dumps(manifest))
    monkeypatch.delenv("BLENDVOCA_VOCASET", raising=False)
    with pytest.raises(FileNotFoundError, match="--vocaset"):
        open_blendvoca(copy, vocaset=tmp_path / "nowhere").vertices(subject, sentence)


def test_vertex_output_method_is_fitted_and_scored_on_its_own_vertices(built_dataset, tmp_path):
    import numpy as np

    from benchmark.methods import register, unregister
    from benchmark.runs import read_run

    register("corpus-replay")(_replay_class())
    try:
        replay = _run("corpus-replay", built_dataset, tmp_path, evaluate=_vertex_and_own)
        shifted = _run("corpus-replay", built_dataset, tmp_path / "b", evaluate=_vertex_and_own,
                       config={"offset": 0.001})
    finally:
        unregister("corpus-replay")
    assert replay["method"]["output"] == "vertices"
    # the source meshes against themselves: only the float16 rounding of the stored offsets remains
    assert replay["metrics"]["lve_mesh"]["mean"] < 0.02 and replay["metrics"]["mve_mesh"]["mean"] < 0.02  # mm
    # its fit is the ground truth's: about 0 in rig space too
    assert replay["metrics"]["lve_rig"]["mean"] < 0.02 and replay["metrics"]["mve_rig"]["mean"] < 0.02
    # a 1 mm shift of every vertex is a 1 mm mean vertex error
    assert abs(shifted["metrics"]["mve_mesh"]["mean"] - np.sqrt(3.0)) < 0.05
    # the fitted tracks are the build's ground truth (the build fitted the same meshes the same way;
    # the replay's float32 vertices move the head-pose estimate and the fit by ~1e-5)
    from benchmark.data import open_blendvoca

    ds = open_blendvoca(built_dataset)
    run = read_run(tmp_path / "results" / f"{replay['tracks']}.json")
    for subject, sentence in run.keys:
        np.testing.assert_allclose(run.tracks(subject, sentence)[0], ds.coeffs(subject, sentence), atol=1e-4)
        assert run.vertices(subject, sentence).shape == (1, *ds.vertices(subject, sentence).shape)
    assert len(run.keys) == replay["dataset"]["num_sentences"]


def _vertex_and_own(generated, dataset, split="test", vertices=None):
    from benchmark.evaluation import own_vertex_metrics

    if vertices is None:
        return _vertex_only(generated, dataset, split)
    rigs = {s: dataset.rig(s) for s, _ in generated}
    own = own_vertex_metrics({k: vertices[k] for k in generated}, dataset.vertices, rigs, dataset.names)
    both = _vertex_only(generated, dataset, split, vertices)
    assert all(own[name] == both[name] for name in both if name in own)  # the same computation
    return both


def test_the_two_floors_ground_truth_and_corpus_meshes(built_dataset, tmp_path):
    """``ground-truth`` is 0 in rig space, ``corpus-meshes`` (a vertex row) 0 in mesh space
    and about 0 in rig space (its fit is the build's own)."""
    meshes = _run("corpus-meshes", built_dataset, tmp_path)
    gt = _run("ground-truth", built_dataset, tmp_path)
    assert meshes["method"]["output"] == "vertices" and meshes["method"]["reference"] is True
    for name in ("lve", "mve"):
        assert meshes["metrics"][f"{name}_mesh"]["mean"] < 0.02  # mm: the float16 stored offsets
        assert meshes["metrics"][f"{name}_rig"]["mean"] < 0.02
        assert gt["metrics"][f"{name}_rig"]["mean"] == 0
        assert gt["metrics"][f"{name}_mesh"]["mean"] > 10 * meshes["metrics"][f"{name}_mesh"]["mean"]
