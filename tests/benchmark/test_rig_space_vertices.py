"""Vertex methods on a coefficient build (FACEGOOD, Live Link, BEAT, UniTalker): no source meshes,
so ``BlendVOCADataset.vertices``/``template`` are the ARKit reference rig's (``vertex_space == "rig"``)
and the methods train, generate and are scored in rig space (docs/vertex_baselines.md)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from benchmark.data import open_blendvoca
from blendvoca.datasets import adapter
from blendvoca.fit.vertex_tracks import adapted_coefficients, fitted_sample_tracks
from tests.datasets.corpora import write_facegood

#: The ARKit reference rig's vertex count (``rigs/<subject>.npz`` of a coefficient build).
ARKIT_RIG_VERTICES = 1220


@pytest.fixture(scope="module")
def facegood_build(tmp_path_factory):
    """A small FACEGOOD build: seven 4 s takes in FACEGOOD's layout, one utterance each, split by take."""
    root = tmp_path_factory.mktemp("rigverts")
    write_facegood(root / "fg", seconds=4.0)
    adapter("facegood")(root / "fg", root / "out")  # mouthClose, which FACEGOOD's rig lacks, is 0
    return root / "out"


def test_a_coefficient_build_gives_vertex_methods_the_rig_at_the_ground_truth(facegood_build):
    data = open_blendvoca(facegood_build)
    assert not data.has_meshes and data.vertex_space == "rig"
    subject = data.split("test")[0]
    sentence = data.sentences(subject)[0]
    rig = data.rig(subject)
    coeffs = data.coeffs(subject, sentence)
    template = data.template(subject)
    vertices = data.vertices(subject, sentence)
    assert template.shape == (ARKIT_RIG_VERTICES, 3) and np.array_equal(template, rig.neutral)
    assert vertices.shape == (len(coeffs), ARKIT_RIG_VERTICES, 3) and vertices.dtype == np.float64
    # neutral + sum_k u_k delta_k over the build's 32 names, in the coefficient columns' order
    order = [rig.names.index(n) for n in data.names]
    expected = rig.neutral + np.einsum("tk,kvd->tvd", coeffs, rig.deltas[order])
    assert np.allclose(vertices, expected, atol=1e-12)
    assert np.abs(vertices - template).max() > 1e-3  # the mouth moves (millimetres)
    faces = data.faces()
    assert faces.shape[1] == 3 and faces.max() == ARKIT_RIG_VERTICES - 1


def test_the_benchmark_fit_of_rig_vertices_recovers_real_facegood_coefficients(realdata_dir, tmp_path):
    """Ground truth on a real take (FACEGOOD 1114_3_16, cut into utterances): the rig-space vertices of each
    utterance, fitted back to coefficients the way a vertex method's output is scored
    (:mod:`blendvoca.fit.vertex_tracks`), give the utterance's coefficients again."""
    take = tmp_path / "take"
    take.mkdir()
    for name in ("bs_names_1015.npy", "bs_value_1114_3_16.npy", "1114_3_16.wav"):
        (take / name).symlink_to(realdata_dir / "facegood" / name)
    adapter("facegood")(take, tmp_path / "out")  # one take: all in the test split
    data = open_blendvoca(tmp_path / "out")
    (subject,) = data.split("test")
    sentences = data.sentences(subject)
    assert len(sentences) >= 5
    rig = data.rig(subject).select(data.names)
    for sentence in sentences[:4]:
        truth = data.coeffs(subject, sentence)
        vertices = data.vertices(subject, sentence)
        # bounds only (the real capture moves faster than the protocol's rate bound): exact recovery
        loose = adapted_coefficients(vertices, rig.neutral, rig.deltas, delta=None)
        assert np.abs(loose - truth).max() < 1e-6, sentence
        # the benchmark's fit (rate bound 0.1 per frame): exact on a track that obeys the bound,
        # here the real track with its changes limited to the bound frame by frame
        limited = truth.copy()
        for t in range(1, len(limited)):
            limited[t] = limited[t - 1] + np.clip(truth[t] - limited[t - 1], -0.1, 0.1)
        fitted = fitted_sample_tracks(rig.evaluate(limited)[None], data.rig(subject), data.names)[0]
        assert np.abs(fitted - limited).max() < 1e-5, sentence


@pytest.mark.parametrize("name", ["faceformer", "codetalker", "cdface"])
def test_vertex_methods_train_and_generate_on_the_rig_of_a_coefficient_build(name, facegood_build):
    """The method contract (train twice with one seed, generate, save, load) on rig-space vertices:
    the methods size themselves from the data (1220 vertices, the rig's lips for CDFace)."""
    from benchmark.methods import get_method
    from benchmark.testing import check_method

    if name == "faceformer":
        from tests.faceformer.test_plugin import TINY
    elif name == "codetalker":
        from tests.codetalker.test_plugin import TINY
    else:
        from tests.cdface.test_plugin import PLUGIN_TINY as TINY
    data = open_blendvoca(facegood_build)
    report = check_method(get_method(name), max_steps=3, samples=2, dataset=data, **TINY)
    assert report.output == "vertices" and report.shapes
    for key, shape in report.shapes.items():
        subject, sentence = key.split("/")
        assert shape == [2, len(data.coeffs(subject, sentence)), ARKIT_RIG_VERTICES, 3], key


@pytest.mark.slow  # trains FaceFormer 5 steps and scores every metric with the VAE: ~35 s
def test_benchmark_run_scores_faceformer_on_a_coefficient_build_in_rig_space(facegood_build, tmp_path, capsys,
                                                                             monkeypatch):
    from benchmark.run import main as run_main

    monkeypatch.delenv("BLENDVOCA_VOCASET", raising=False)
    with pytest.warns(UserWarning, match="source meshes cannot be read.*vertex_space 'rig'"):
        rc = run_main(["--method", "faceformer", "--preset", "cpu-demo", "--data", str(facegood_build),
                       "--max-steps", "5", "--results", str(tmp_path / "results"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    (path,) = (tmp_path / "results").glob("*.json")
    metrics = json.loads(path.read_text())["metrics"]
    vertex = {"lve_rig", "lve_squared_rig", "mve_rig", "fdd_rig", "energy_rig", "apd_rig", "lpd_rig", "upd_rig"}
    assert vertex <= set(metrics)
    assert all(math.isfinite(metrics[m]["mean"]) for m in vertex)
    assert metrics["lve_rig"]["mean"] > 0 and metrics["mve_rig"]["mean"] > 0  # 5 steps: not the ground truth
    assert not any(m.endswith("_mesh") for m in metrics)
