"""The dynamics metrics (issue 54) as a "Dynamics" table group: results scored by the
evaluation carry them, and the tables show them between the distribution and the vertex
groups, the ratios without a direction and the closeness ranked."""

import warnings

import numpy as np

from benchmark.evaluation import evaluate_split
from benchmark.evaluation.dynamics import METRICS as DYNAMICS
from benchmark.results import build_result, check
from benchmark.testing import FakeBlendVOCA
from leaderboard import build
from leaderboard.render import DYNAMICS_NOTE

PROV = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}


def _result(label, scores, reference=False):
    metrics = {name: dict(entry) for name, entry in scores.items()}
    # a distance and a vertex error beside them, to place the group
    metrics["fd"] = {"mean": 1.0, "std": None, "higher_is_better": False, "unit": "latent^2", "ci95": [0.9, 1.1]}
    metrics["lve_rig"] = {"mean": 2.0, "std": 0.1, "higher_is_better": False, "unit": "mm", "ci95": [1.9, 2.1]}
    return check(build_result(method={"name": label, "label": label, "reference": reference, "config": {}},
                              dataset={"manifest_hash": "h", "split": "test", "num_sentences": 6},
                              protocol={"samples": 1, "seed": 0}, metrics=metrics, timings={},
                              provenance=PROV).to_json())


def _section(md, title):
    start = md.index(title)
    end = md.find("\n### ", start + 1)
    return md[start:end if end > 0 else len(md)]


def test_scored_results_show_a_dynamics_group():
    ds = FakeBlendVOCA(seed=4, test=2, sentences=3)
    keys = [(s, q) for s in ds.split("test") for q in ds.sentences(s)]
    truth = {k: ds.coeffs(*k) for k in keys}
    rng = np.random.default_rng(0)
    rows = {"ground-truth": {k: v[None] for k, v in truth.items()},
            "damped": {k: (0.9 * v)[None] for k, v in truth.items()},
            "jittery": {k: np.clip(v + rng.normal(0, 0.05, v.shape), 0, 1)[None] for k, v in truth.items()}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scores = {label: evaluate_split(g, ds, "test", metrics=list(DYNAMICS)) for label, g in rows.items()}
    results = [_result(label, s, reference=label == "ground-truth") for label, s in scores.items()]
    md = build.rendered_tables(results)["leaderboard.md"]
    assert md.index("### Distribution") < md.index("### Dynamics") < md.index("### Vertex")
    dynamics = _section(md, "### Dynamics")
    header = dynamics.splitlines()[2]
    assert "Motion ratio lips (x GT) |" in header  # no direction: nothing ranked
    assert "Closeness lips ↑" in header and "Silent-lip ratio (x GT) |" in header
    damped = next(line for line in dynamics.splitlines() if line.startswith("| damped"))
    assert "| 0.90 [0.90, 0.90] |" in damped  # every ratio of a track scaled by 0.9 is 0.9
    # the damped row is closer to the truth's level than the jittery one in every resample: bold
    assert damped.count("**") >= 2
    truth_row = next(line for line in dynamics.splitlines() if line.startswith("| *ground-truth*"))
    assert "| 1.00 [1.00, 1.00] |" in truth_row
    assert DYNAMICS_NOTE in dynamics  # how to read the ratios
    assert DYNAMICS_NOTE not in _section(md, "### Vertex")
