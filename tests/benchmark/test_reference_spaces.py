"""Every vertex metric in both reference spaces, for coefficient and vertex rows alike;
the AV lag bias read against the data's own offsets; metric subsets."""

import numpy as np
import pytest

import types

from benchmark.evaluation import EvaluationSettings, evaluate_split
from benchmark.testing import FakeBlendVOCA


def _mean_features(windows):
    return windows.mean(axis=1)


class MeshesBeyondTheRig(FakeBlendVOCA):
    """Source meshes = the rig driven by the track plus motion no rig shape expresses
    (a slow per-vertex wobble), as real captures have."""

    def vertices(self, subject, sentence):
        base = super().vertices(subject, sentence)
        t = np.arange(len(base))[:, None, None]
        phase = np.random.default_rng(len(sentence)).uniform(0, 6, size=base.shape[1:])
        return base + 0.0005 * np.sin(2 * np.pi * t / 40 + phase)


def _truth(ds, samples=1):
    return {(s, q): np.repeat(ds.coeffs(s, q)[None], samples, axis=0) for s in ds.split("test")
            for q in ds.sentences(s)}


def _score(tracks, ds, split="test", metrics=None, vertices=None, **options):
    settings = EvaluationSettings(extractor=_mean_features, wind_repeats=1, wind_resamples=2, fd_resamples=2,
                                  resamples=50, workers=1, wind_cache=None, **options)
    generated = tracks if vertices is None else types.SimpleNamespace(tracks=tracks, vertices=vertices)
    return evaluate_split(generated, ds, split, settings, metrics)


def test_coefficient_rows_are_scored_in_both_spaces():
    ds = MeshesBeyondTheRig(seed=3, test=2)
    res = _score(_truth(ds), ds, lipsync=False)
    for name in ("lve", "lve_squared", "mve", "fdd", "energy"):
        assert res[f"{name}_rig"]["mean"] == 0, name  # the ground truth is the rig-space floor
        assert res[f"{name}_mesh"]["mean"] > 0, name  # and carries the rig's floor in mesh space
    # the rig's floor in mesh space is the motion it cannot express: 0.5 mm wobble amplitude
    assert 0.2 < res["mve_mesh"]["mean"] < 0.6
    # where the meshes are exactly the rig's, the two spaces agree
    plain = FakeBlendVOCA(seed=3, test=2)
    noisy = {k: np.clip(v + np.random.default_rng(0).normal(0, 0.05, v.shape), 0, 1) for k, v in _truth(plain, 3).items()}
    both = _score(noisy, plain, lipsync=False)
    for name in ("lve", "mve", "fdd", "energy", "apd", "upd", "lpd", "mpd"):
        assert both[f"{name}_mesh"]["mean"] == pytest.approx(both[f"{name}_rig"]["mean"], rel=1e-9), name


def test_vertex_rows_are_scored_in_both_spaces():
    """A vertex row that outputs the source meshes: 0 in mesh space; its coefficient fit
    (here: exactly the ground truth) 0 in rig space."""
    ds = MeshesBeyondTheRig(seed=4, test=2)
    truth = _truth(ds)
    meshes = {k: ds.vertices(*k)[None] for k in truth}
    res = _score(truth, ds, vertices=meshes, lipsync=False)
    for name in ("lve", "mve", "fdd", "energy"):
        assert res[f"{name}_mesh"]["mean"] == pytest.approx(0, abs=1e-12), name
        assert res[f"{name}_rig"]["mean"] == 0, name
    # a vertex row's diversity is measured on its own vertices in mesh space
    two = {k: np.concatenate([v, v + 0.001]) for k, v in meshes.items()}
    res = _score({k: np.repeat(v, 2, axis=0) for k, v in truth.items()}, ds, vertices=two, lipsync=False)
    assert res["apd_mesh"]["mean"] == pytest.approx(1000 * 0.001 * np.sqrt(3)) and res["apd_rig"]["mean"] == 0


def test_a_subset_of_metrics():
    ds = FakeBlendVOCA(seed=5)
    res = _score(_truth(ds), ds, metrics=("lve_rig", "fd"))
    assert list(res) == ["fd", "lve_rig"] and set(res.per_sentence[0]) == {"subject", "sentence", "lve_rig"}
    with pytest.raises(ValueError, match="unknown metric.*lve"):
        _score(_truth(ds), ds, metrics=("lve",))


def test_the_mesh_space_needs_the_source_meshes():
    class NoMeshes(FakeBlendVOCA):
        def vertices(self, subject, sentence):
            raise FileNotFoundError("the source corpus is not reachable")

    ds = NoMeshes(seed=6)
    with pytest.warns(UserWarning, match="mesh-space metrics"):
        res = _score(_truth(ds), ds, lipsync=False)
    assert "lve_rig" in res and "lve_mesh" not in res
    with pytest.raises(FileNotFoundError):
        _score(_truth(ds), ds, lipsync=False, mesh=True)


def _delayed(track, k):
    """The track k frames later (motion after audio); the first frame repeated before it."""
    return np.concatenate([np.repeat(track[:1], k, axis=0), track[:len(track) - k]])


def test_the_lag_bias_of_a_delayed_ground_truth_is_the_delay(built_dataset):
    """On a build of the synthetic corpus (whose ground truth has its own random
    per-sentence lag): the ground truth's lag bias is 0, the ground truth delayed by
    k frames has a lag bias of k, although its mean |offset| is not k."""
    from benchmark.data import open_blendvoca

    ds = open_blendvoca(built_dataset)
    keys = [(s, q) for s in ds.split("test") + ds.split("val") for q in ds.sentences(s)]
    truth = {k: ds.coeffs(*k) for k in keys}

    def scored(k, split):
        tracks = {key: _delayed(v, k)[None] for key, v in truth.items()}
        return _score(tracks, ds, split=split, metrics=("av_lag_bias_geometric", "av_offset_signed_geometric",
                                                       "av_offset_geometric"))

    for split in ("test", "val"):
        assert scored(0, split)["av_lag_bias_geometric"]["mean"] == 0
        for k in (2, 4):
            res = scored(k, split)
            assert res["av_lag_bias_geometric"]["mean"] == pytest.approx(k, abs=0.5), (split, k)
            rows = res.per_sentence
            assert all(r["av_offset_geometric"] == abs(r["av_offset_signed_geometric"]) for r in rows)
