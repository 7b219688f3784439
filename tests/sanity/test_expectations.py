"""The declaration table and the verdict logic."""

import math

import pytest

from benchmark.sanity.disturbances import DISTURBANCES
from benchmark.sanity.expectations import EXPECTATIONS, KINDS, Expectation, declared, spearman, verdict
from benchmark.sanity.report import failures, sanity_table

LEVELS = [0, 1, 2, 4, 8]


def test_spearman():
    assert spearman(LEVELS, [0, 1, 2, 3, 4]) == pytest.approx(1.0)
    assert spearman(LEVELS, [5, 4, 3, 2, 1]) == pytest.approx(-1.0)
    assert spearman(LEVELS, [0, 2, 1, 3, 4]) == pytest.approx(0.9)  # one swapped neighbouring pair
    assert math.isnan(spearman(LEVELS, [1, 1, 1, 1, 1]))
    assert math.isnan(spearman(LEVELS, [0, 1, float("nan"), 3, 4]))


def _e(expected, **kw):
    return Expectation("m", "d", expected, "because", **kw)


def test_rises_and_falls():
    assert verdict(_e("rises"), LEVELS, [0, 1, 2, 3, 4])["ok"]
    assert verdict(_e("rises"), LEVELS, [0, 2, 1, 3, 4])["ok"]  # rho 0.9: one swap allowed
    bad = verdict(_e("rises"), LEVELS, [0, 2, 1, 4, 3])          # two swaps: rho 0.8
    assert not bad["ok"] and "rho" in bad["why"]
    assert not verdict(_e("rises"), LEVELS, [4, 3, 2, 1, 0])["ok"]
    assert not verdict(_e("rises"), LEVELS, [1, 1, 1, 1, 1])["ok"]  # no reaction at all
    assert verdict(_e("falls"), LEVELS, [4, 3, 2, 1, 0])["ok"]
    assert not verdict(_e("falls"), LEVELS, [0, 1, 2, 3, 4])["ok"]
    entry = verdict(_e("rises"), LEVELS, [0, 1, 2, 3, 4])
    assert set(entry) >= {"levels", "values", "rho", "expected", "ok", "reason"}
    assert entry["levels"] == [0.0, 1.0, 2.0, 4.0, 8.0] and entry["expected"] == "rises"


def test_rises_up_to_a_noise_floor():
    e = _e("rises", tolerance=1.5)
    assert verdict(e, LEVELS, [0, 1.2, 1.15, 0.9, 5])["ok"]     # rho 0.7, but within the floor
    assert not verdict(e, LEVELS, [0, 3, 1.2, 1.1, 5])["ok"]   # rho 0.6 and falls back by 1.9
    assert not verdict(e, LEVELS, [0, 0.5, 0.7, 1.0, 1.2])["ok"]  # never leaves the floor
    assert not verdict(_e("rises"), LEVELS, [0, 1.2, 1.15, 0.9, 5])["ok"]  # without one: rho 0.7 fails
    assert verdict(_e("falls", tolerance=1.0), LEVELS, [5, 3, 3.5, 1, 0])["ok"]


def test_must_not_react_with_absolute_and_relative_tolerance():
    assert verdict(_e("must not react", tolerance=0.1), LEVELS, [1, 1.05, 0.95, 1.09, 1.0])["ok"]
    bad = verdict(_e("must not react", tolerance=0.1), LEVELS, [1, 1.05, 0.95, 1.2, 1.0])
    assert not bad["ok"] and bad["tolerance"] == 0.1
    # relative: 10 % of the largest response to the reference disturbance
    rel = _e("must not react", relative_to="damping", share=0.1)
    assert verdict(rel, LEVELS, [0, 0.05, 0.08, 0.09, 0.1], reference=[0, 0.5, 0.8, 0.9, 1.0])["ok"]
    assert not verdict(rel, LEVELS, [0, 0.5, 0.8, 0.9, 0.89], reference=[0, 0.5, 0.8, 0.9, 1.0])["ok"]
    # the reference not run: the absolute tolerance alone, and a note
    alone = verdict(rel, LEVELS, [0, 0, 0, 0, 0])
    assert alone["ok"] and "note" in alone


def test_equals_level():
    e = _e("equals level", tolerance=0.5)
    assert verdict(e, LEVELS, [0, 1, 2, 4, 8])["ok"]
    assert verdict(e, LEVELS, [0.25, 1.25, 1.75, 4.25, 8.4])["ok"]
    bad = verdict(e, LEVELS, [0, 1, 2, 4, 7])
    assert not bad["ok"] and "7" in bad["why"]
    assert verdict(_e("equals level", tolerance=0.5, scale=-1.0), LEVELS, [0, -1, -2, -4, -8])["ok"]


def test_any_never_fails_and_a_reason_is_required():
    assert verdict(_e("any"), LEVELS, [3, -1, 7, 0, 2])["ok"]
    with pytest.raises(ValueError, match="reason"):
        Expectation("m", "d", "rises", "")
    with pytest.raises(ValueError, match="kind"):
        Expectation("m", "d", "goes up", "why")


def test_the_table_is_keyed_by_protocol_v3_names_and_known_disturbances():
    from benchmark.evaluation.registry import metric_info

    v3 = True
    try:
        metric_info("lve_rig")
    except (KeyError, ValueError):
        v3 = False  # a registry before protocol v3: the names are checked once it has them
    for (metric, kind), e in EXPECTATIONS.items():
        assert kind in DISTURBANCES and e.expected in KINDS and e.reason
        assert e.metric == metric and e.disturbance == kind
        assert metric not in ("lve", "mve", "fdd", "lve_squared", "apd", "upd", "lpd", "mpd")  # v3 names only
        if v3:
            metric_info(metric)  # every declared name is a registered metric
    # the acceptance check of protocol v3: a k-frame delay reads k
    e = EXPECTATIONS[("av_lag_bias_geometric", "time_shift")]
    assert e.expected == "equals level" and e.tolerance == 0.5 and e.scale == 1.0
    assert EXPECTATIONS[("av_lag_bias_syncnet", "time_shift")].scale == pytest.approx(25 / 60)
    assert declared("nope", "noise").expected == "any"


def _scores(values_by_kind):
    return {kind: [(level, dict(values)) for level, values in zip(LEVELS, rows)]
            for kind, rows in values_by_kind.items()}


def test_sanity_table_statuses():
    table = {("lve_rig", "noise"): Expectation("lve_rig", "noise", "rises", "r"),
             ("lve_rig", "damping"): Expectation("lve_rig", "damping", "falls", "deliberately wrong"),
             ("energy_rig", "noise"): Expectation("energy_rig", "noise", "rises", "r")}
    rising = [{"lve_rig": v, "lve": v} for v in (0, 1, 2, 3, 4)]
    result = sanity_table(_scores({"noise": rising, "damping": rising}), table)
    assert result["lve_rig"]["noise"]["status"] == "held"
    assert result["lve_rig"]["damping"]["status"] == "failed"
    assert result["lve"]["noise"]["status"] == "no claim"  # an old name: recorded, never failed
    assert result["energy_rig"]["noise"] == {"levels": [0.0, 1.0, 2.0, 4.0, 8.0], "values": None, "rho": None,
                                             "expected": "rises", "ok": True, "reason": "r",
                                             "status": "not scored"}
    assert [(m, d) for m, d, _e in failures(result)] == [("lve_rig", "damping")]


def test_reference_claims_and_their_verdicts():
    from benchmark.evaluation.registry import metric_info
    from benchmark.sanity.expectations import REFERENCE_CLAIMS, ReferenceClaim, reference_verdict

    for (metric, row), claim in REFERENCE_CLAIMS.items():
        metric_info(metric)  # every claimed name is a registered metric
        assert claim.metric == metric and claim.row == row and claim.reason
    # the acceptance of issue 54: closeness static 0, ground truth 1, oracle-sample near 1, oracle-mean below
    for region in ("lips", "jaw", "upper"):
        name = f"motion_closeness_{region}"
        assert (REFERENCE_CLAIMS[(name, "static")].expected, REFERENCE_CLAIMS[(name, "static")].target) == ("equals", 0)
        assert REFERENCE_CLAIMS[(name, "ground_truth")].target == 1 and REFERENCE_CLAIMS[(name, "ground_truth")] \
            .tolerance == 0
        assert REFERENCE_CLAIMS[(name, "oracle_sample")].expected == "within interval of"
        assert REFERENCE_CLAIMS[(name, "oracle_mean")].expected == "below"

    def judged(kind, mean, ci, target=1.0, tolerance=0.0):
        claim = ReferenceClaim("m", "ground_truth", kind, target, "because", tolerance)
        return reference_verdict(claim, {"mean": mean, "ci95": ci})["ok"]

    assert judged("equals", 1.0, [1.0, 1.0]) and not judged("equals", 0.999, [0.99, 1.0])
    assert judged("equals", 0.999, [0.99, 1.0], tolerance=0.01)
    assert judged("interval contains", 1.05, [0.97, 1.12]) and not judged("interval contains", 1.2, [1.1, 1.3])
    assert judged("within interval of", 0.95, [0.9, 0.99]) and not judged("within interval of", 0.8, [0.78, 0.83])
    assert judged("below", 0.7, [0.6, 0.8]) and not judged("below", 0.95, [0.9, 1.01])
    assert not judged("equals", float("nan"), [0, 1])
    with pytest.raises(ValueError, match="unknown row"):
        ReferenceClaim("m", "mean-ish", "equals", 1.0, "r")
    with pytest.raises(ValueError, match="unknown kind"):
        ReferenceClaim("m", "static", "about", 1.0, "r")


def test_reference_table_scores_static_zero_and_the_truth_one():
    import warnings

    from benchmark.sanity.report import reference_table
    from benchmark.testing import FakeBlendVOCA

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = reference_table(FakeBlendVOCA(seed=2, test=2, sentences=3))
    for region in ("lips", "jaw", "upper"):
        for name in (f"motion_ratio_{region}", f"motion_closeness_{region}"):
            assert table[name]["static"]["status"] == "held" and table[name]["static"]["mean"] == 0.0
            assert table[name]["ground_truth"]["status"] == "held" and table[name]["ground_truth"]["mean"] == 1.0
            # the fake build has no oracle samples: those claims are kept, not scored
            assert table[name]["oracle_sample"]["status"] == "not scored"
    # its noise-burst 'speech' pauses between syllables: the silent-lip ratio is judged too
    assert table["silent_lip_ratio"]["static"]["mean"] == 0.0 and table["silent_lip_ratio"]["ground_truth"]["mean"] == 1
    assert all(row["static"]["status"] == "held" for row in table.values())
