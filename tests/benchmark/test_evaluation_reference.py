"""evaluate_split through the settings API gives the numbers the old keyword API gave.

The figures below were recorded from ``benchmark.evaluate.evaluate_split`` (21 keyword
parameters) at commit 6c360dd, before the evaluation was split into metric families,
on the same fabricated split, tracks, extractor and settings.
"""

import types

import numpy as np
import pytest

from benchmark.evaluation import EvaluationSettings, evaluate_split
from benchmark.testing import FakeBlendVOCA

#: metric -> (mean, std, ci95 low, ci95 high, sample_std, sum of the bootstrap replicates,
#: sum of the per-sentence values) of every metric, recorded at commit 6c360dd.
FULL = {
    'apd_mesh': (0.17951855528696425, 0.008886356769581867, 0.17510551300993304, 0.18516542552105805,
                 None, 3.5894594045060613, 1.0771113317217855),
    'apd_rig': (0.17951855528696425, 0.008886356769581867, 0.17534428462898485, 0.1863367203041883,
                None, 3.613513229912748, 1.0771113317217855),
    'av_confidence_expert': (2.851937196126443, 0.2077061983867599, 2.6765890258555673, 2.92807365825017,
                             0.00015644819310062653, 56.464209945388916, 17.11162317675866),
    'av_confidence_geometric': (0.47021369264743756, 0.1262200885845224, 0.4032108537590336, 0.5408542212228249,
                                0.005561486537266024, 9.63023508737219, 2.8212821558846253),
    'av_lag_bias_expert': (0.05555555555555555, 0.13608276348795434, 0.0, 0.1402777777777777,
                           0.09622504486493763, 0.9444444444444446, 0.3333333333333333),
    'av_lag_bias_geometric': (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    'av_offset_expert': (0.05555555555555555, 0.13608276348795434, 0.0, 0.19583333333333325,
                         0.09622504486493763, 1.3333333333333335, 0.3333333333333333),
    'av_offset_geometric': (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    'av_offset_signed_expert': (0.05555555555555555, 0.13608276348795434, 0.0, 0.19583333333333325,
                                0.09622504486493763, 1.3333333333333335, 0.3333333333333333),
    'av_offset_signed_geometric': (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    'energy_latent': (0.12852629711682093, 0.00215194708337403, 0.12713008126825787, 0.12989483181762754,
                      None, 2.5656776708158886, 0.7711577827009255),
    'energy_mesh': (0.034210226389532916, 0.002214667217798194, 0.032862175305844024, 0.03516506013109135,
                    None, 0.6769207264369659, 0.2052613583371975),
    'energy_rig': (0.034210226389532916, 0.002214667217798194, 0.03256971178869215, 0.03540940245228449,
                   None, 0.6846653468310502, 0.2052613583371975),
    'fd': (0.021762107134803192, None, 0.021762107134803192, 0.023042288600626463, None, 0.09059539985078666, 0),
    'fdd_mesh': (0.0006627626365236583, 0.0001965036643713658, 0.0005813643755288336, 0.0007896781735336512,
                 0.00015984345661046817, 0.013238589812112017, 0.00397657581914195),
    'fdd_rig': (0.0006627626365236583, 0.0001965036643713658, 0.0005941290456750513, 0.000799838626880007,
                0.00015984345661046817, 0.013638836162660699, 0.00397657581914195),
    'lpd_mesh': (0.9387076577066734, 0.04018816566126595, 0.9119763398311939, 0.9567329166153834,
                 None, 18.806301737045676, 5.63224594624004),
    'lpd_rig': (0.9387076577066734, 0.04018816566126595, 0.9131454628597746, 0.952514649922294,
                None, 18.68075290548648, 5.63224594624004),
    'lve_mesh': (0.8613344891636857, 0.02968865846490912, 0.8469520534458882, 0.8839582592338855,
                 0.015383509151107515, 17.27072278592778, 5.168006934982114),
    'lve_rig': (0.8613344891636857, 0.02968865846490912, 0.8457377565094666, 0.8770400881525424,
                0.015383509151107515, 17.18881736008173, 5.168006934982114),
    'lve_squared_mesh': (0.9082435157732623, 0.05780143109670002, 0.8721437316928422, 0.9700763970227028,
                         0.025776550476819652, 18.26708571454663, 5.449461094639574),
    'lve_squared_rig': (0.9082435157732623, 0.05780143109670002, 0.8866872162145057, 0.9599165968591186,
                        0.025776550476819652, 18.268517069802115, 5.449461094639574),
    'mpd_mesh': (0.17368936776598884, 0.010829664652621905, 0.16767898584695098, 0.17918487109703857,
                 None, 3.457725127659459, 1.042136206595933),
    'mpd_rig': (0.17368936776598884, 0.010829664652621905, 0.16810625697474263, 0.1803436117831669,
                None, 3.4756239178303936, 1.042136206595933),
    'multimodality': (0.03949563678893609, 0.0031917826958935253, 0.03730815966831508, 0.04169161416784395,
                      None, 39.40692117293221, 0),
    'mve_mesh': (0.03735073078742932, 0.002954261419970935, 0.03571664232568284, 0.03917880332191779,
                 0.0006273180539255617, 0.7466531094187939, 0.22410438472457592),
    'mve_rig': (0.03735073078742932, 0.002954261419970935, 0.03510198718714786, 0.0388196955182356,
                0.0006273180539255617, 0.7412569818790803, 0.22410438472457592),
    'upd_mesh': (0.039283719929950396, 0.0017963724783136006, 0.038810544850304274, 0.04063928644125104,
                 None, 0.7878893135841242, 0.23570231957970236),
    'upd_rig': (0.039283719929950396, 0.0017963724783136006, 0.038035837262007, 0.04101074045134118,
                None, 0.7881131975291491, 0.23570231957970236),
    'wind': (0.022419751289234704, 4.9065389333867974e-18, 0.022419751289234704, 0.024666197906115354,
             None, 0.07087264560408356, 0),
}
#: The mesh-space metrics of a vertex row's own vertices (2 samples), same fields, commit 6c360dd.
OWN_VERTICES = {
    'apd_mesh': (0.51961524227068, 1.790180836524724e-16, 0.51961524227068, 0.5196152422706802,
                 None, 10.3923048454136, 3.1176914536240803),
    'energy_mesh': (0.5196152422706649, 3.648565166692871e-16, 0.5196152422706647, 0.5196152422706651,
                    None, 10.3923048454133, 3.1176914536239897),
    'fdd_mesh': (0.0037278665606742868, 0.00034295203684776154, 0.00354083291799682, 0.0039153361370355315,
                 0.0021177341285978403, 0.07432340744840367, 0.02236719936404572),
    'lpd_mesh': (0.5196152422706798, 4.3568297570458958e-16, 0.5196152422706793, 0.51961524227068,
                 None, 10.392304845413594, 3.1176914536240785),
    'lve_mesh': (0.779422863405996, 2.3288234633381846e-16, 0.7794228634059959, 0.7794228634059962,
                 0.3674234614174801, 15.58845726811992, 4.676537180435976),
    'lve_squared_mesh': (0.6750000000000035, 1.8577584504832502e-16, 0.6750000000000034, 0.6750000000000036,
                         0.5727564927611103, 13.500000000000075, 4.050000000000021),
    'mpd_mesh': (0.51961524227068, 1.790180836524724e-16, 0.51961524227068, 0.5196152422706802,
                 None, 10.3923048454136, 3.1176914536240803),
    'mve_mesh': (0.779422863405996, 2.0471501066083614e-16, 0.7794228634059959, 0.7794228634059962,
                 0.36742346141747984, 15.58845726811992, 4.676537180435976),
    'upd_mesh': (0.5196152422706798, 3.614624287906422e-16, 0.5196152422706798, 0.5196152422706802,
                 None, 10.392304845413598, 3.117691453624079),
}
#: ``protocol.fd_floor_probe`` of the split, commit 6c360dd.
FD_FLOOR_PROBE = 0.00012799994727956312
OPTIONS = dict(extractor=lambda w: np.concatenate([w.mean(axis=1), w.std(axis=1)], axis=1), wind_repeats=2,
               wind_resamples=3, fd_resamples=4, resamples=20, workers=1, wind_cache=None, seed=3)


class _Expert:
    """A deterministic stand-in for a learned sync expert."""

    def sync(self, track, samples, rate):
        return types.SimpleNamespace(offset=int(round(float(track[:, 0].mean()) * 40)) - 2,
                                     confidence=float(track.std()) + len(samples) / rate)


@pytest.fixture(scope="module")
def split():
    ds = FakeBlendVOCA(seed=7, test=2, sentences=3, frames=(150, 190))
    keys = [(s, q) for s in ds.split("test") for q in ds.sentences(s)]
    rng = np.random.default_rng(11)
    generated = {k: np.clip(ds.coeffs(*k)[None] + rng.normal(0, 0.05, (3, *ds.coeffs(*k).shape)), 0, 1) for k in keys}
    return ds, generated


def _check(scores, expected):
    assert set(scores) == set(expected)
    for name, (mean, std, lo, hi, sample_std, replicates, rows) in expected.items():
        entry = scores[name]
        got = (entry["mean"], entry["std"], *entry["ci95"], entry.get("sample_std"),
               float(np.sum(scores.replicates.get(name, []))),
               sum(row[name] for row in scores.per_sentence if name in row))
        want = (mean, std, lo, hi, sample_std, replicates, rows)
        assert [g is None for g in got] == [w is None for w in want], name
        assert [g for g in got if g is not None] == pytest.approx([w for w in want if w is not None], rel=1e-9,
                                                                 abs=1e-12), name


def test_every_metric_as_the_old_evaluate_split(split):
    ds, generated = split
    scores = evaluate_split(generated, ds, "test", EvaluationSettings(sync_expert=_Expert(), **OPTIONS))
    from benchmark.evaluation.dynamics import METRICS as DYNAMICS

    added = {n for n in scores if n in DYNAMICS}  # the dynamics family (issue 54) came after the recording
    assert added
    _check(type(scores)({n: e for n, e in scores.items() if n not in added}, scores.per_sentence,
                        scores.replicates), FULL)
    assert scores.protocol == {"fd_floor_probe": pytest.approx(FD_FLOOR_PROBE, rel=1e-9),
                               "evaluation": {"fd_resamples": 4, "resamples": 20, "seed": 3, "wind_repeats": 2,
                                              "wind_resamples": 3}}


def test_a_vertex_rows_own_vertices_as_the_old_evaluate_split(split):
    ds, generated = split
    own = {k: np.stack([ds.vertices(*k) + 0.0003 * (i + 1) for i in range(2)]) for k in generated}
    record = types.SimpleNamespace(tracks={k: v[:2] for k, v in generated.items()}, vertices=own)
    scores = evaluate_split(record, ds, "test", EvaluationSettings(lipsync=False, **OPTIONS))
    mesh = {n: scores[n] for n in scores if n.endswith("_mesh")}
    assert set(mesh) == set(OWN_VERTICES)
    _check(type(scores)(mesh, scores.per_sentence, scores.replicates), OWN_VERTICES)


def test_a_subset_gives_the_same_entries(split):
    ds, generated = split
    scores = evaluate_split(generated, ds, "test", EvaluationSettings(**OPTIONS),
                            metrics=("lve_rig", "fd", "av_offset_geometric"))
    _check(scores, {n: FULL[n] for n in ("lve_rig", "fd", "av_offset_geometric")})


def test_settings_record_only_what_differs_from_the_protocol_and_read_back():
    assert EvaluationSettings().to_dict() == {}
    settings = EvaluationSettings(wind_repeats=2, mesh=False, lipsync=False, workers=1, wind_cache=None,
                                  sync_expert="expert.pt")
    # workers and the cache change no number; the models are recorded with their digests by the runner
    assert settings.to_dict() == {"wind_repeats": 2, "lipsync": False, "mesh": False}
    assert EvaluationSettings.from_dict(settings.to_dict()) == EvaluationSettings(wind_repeats=2, mesh=False,
                                                                                  lipsync=False)
    assert settings.replace(wind_repeats=10).to_dict() == {"lipsync": False, "mesh": False}
    with pytest.raises(ValueError, match="unknown setting.*'workers'"):
        EvaluationSettings.from_dict({"workers": 3})
    with pytest.raises(ValueError, match=r"wind_repeats: expected an integer >= 1, got 0"):
        EvaluationSettings(wind_repeats=0)
    with pytest.raises(ValueError, match="mesh: expected None, True or False, got 'yes'"):
        EvaluationSettings(mesh="yes")


def test_evaluate_split_names_a_wrong_settings_argument(split):
    ds, generated = split
    with pytest.raises(TypeError, match="settings must be an EvaluationSettings, got dict"):
        evaluate_split(generated, ds, "test", {"wind_repeats": 2})
    with pytest.raises(TypeError, match="generated must map .* or have .tracks and .vertices"):
        evaluate_split([1, 2], ds, "test")


def test_each_family_declares_the_metrics_it_computes():
    from benchmark.evaluation import dynamics, latent, lipsync, vertex
    from benchmark.evaluation.registry import FAMILIES, METRICS

    assert FAMILIES == (lipsync, vertex, latent, dynamics)
    declared = [name for family in FAMILIES for name in family.METRICS]
    assert sorted(declared) == sorted(METRICS) and len(set(declared)) == len(declared)
    assert set(FULL) <= set(METRICS)
