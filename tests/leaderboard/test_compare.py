"""leaderboard.compare: two boards' orders per metric, Kendall's tau and the flips each board decides."""

import json

import numpy as np
import pytest

from benchmark.results import check
from leaderboard.collect import tables_by_manifest
from leaderboard.compare import compared_metrics, main, section_by_key
from tests.leaderboard.test_build import SENTENCES, _sentence_result

A, B = "aaaaaa111111", "bbbbbb222222"


def _boards():
    """Board A orders a < b < c < mean (each by 1 mm on every sentence: decided); board B swaps a and b
    by 0.5 mm on every sentence (decided) and puts the mean just ahead of c with sentence noise (undecided)."""
    rng = np.random.default_rng(3)
    base = rng.normal(3.0, 1.0, size=len(SENTENCES))
    noise = rng.normal(0.0, 1.0, size=len(SENTENCES))
    noise -= noise.mean()
    board_a = {"a": base, "b": base + 1.0, "c": base + 2.0, "mean": base + 3.0, "ground-truth": base * 0}
    board_b = {"b": base, "a": base + 0.5, "c": base + 1.0, "mean": base + 1.0 + noise - 0.02,
               "ground-truth": base * 0 + 0.01}
    results = []
    for manifest, board in ((A, board_a), (B, board_b)):
        for label, values in board.items():
            results.append(_sentence_result(label, values, manifest=manifest,
                                            reference=label in ("mean", "ground-truth")))
    return results


def test_the_orders_tau_and_the_flips_each_board_decides():
    a, b = (section_by_key(tables_by_manifest([check(r) for r in _boards()]), key) for key in (A[:6], B))
    (lve,) = compared_metrics(a, b)
    assert lve.metric == "lve_rig"
    assert lve.order_a == ("a", "b", "c", "mean") and lve.order_b == ("b", "a", "mean", "c")
    # 6 pairs, 2 discordant (a-b, c-mean): tau = (4 - 2) / 6
    assert lve.tau == pytest.approx(2 / 6)
    flips = {(f.first, f.second): f for f in lve.flips}
    assert set(flips) == {("a", "b"), ("c", "mean")}
    assert flips["a", "b"].decided_a() and flips["a", "b"].decided_b()
    assert flips["c", "mean"].decided_a() and not flips["c", "mean"].decided_b()
    assert [(f.first, f.second) for f in lve.decided_flips] == [("a", "b")]
    assert "ground-truth" not in lve.order_a + lve.order_b  # first by construction: left out


def test_the_command_writes_the_page_and_refuses_unknown_sections_in_one_line(tmp_path, capsys):
    results = tmp_path / "results"
    results.mkdir()
    for k, record in enumerate(_boards()):
        (results / f"r{k}.json").write_text(json.dumps(record))
    page = tmp_path / "page.md"
    assert main(["--results", str(results), "--page", str(page), "--names", "synthetic,real"]) == 2  # which is which?
    assert "--names: name the sections too" in capsys.readouterr().err
    assert main(["--results", str(results), "--page", str(page), "--sections", f"{A},{B}",
                 "--names", "synthetic,real"]) == 0
    text = page.read_text()
    assert "| LVE" in text and "| a, b, c, mean | b, a, mean, c | 0.33 | 2 | 1 |" in text
    assert "Recorded " in text and "## The decided disagreements" in text
    assert "| a | b | 1.00 | 1.00 |" in text.split("## The decided disagreements")[1].replace("*", "")
    capsys.readouterr()
    assert main(["--results", str(results), "--sections", "nothing,else"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --sections nothing: expected one section's") \
        and A in err[0] and B in err[0]
    assert main(["--results", str(results), "--sections", A]) == 2
    assert "expected two sections A,B, got 1" in capsys.readouterr().err
