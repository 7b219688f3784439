from benchmark.methods import get_method
from leaderboard.reproduce import PLAN


def test_rows_that_share_a_training_differ_only_in_sampling_options():
    groups = {}
    for entry in PLAN:
        if entry.shared_training is not None:
            groups.setdefault(entry.shared_training, []).append(entry)
    assert groups, "the CDFace rows share one training"
    for entries in groups.values():
        first = entries[0]
        options = set(get_method(first.method).sampling_options)
        for entry in entries[1:]:
            assert (entry.method, entry.max_steps, entry.samples) == (first.method, first.max_steps, first.samples)
            changed = {k for k in set(entry.config) | set(first.config) if entry.config.get(k) != first.config.get(k)}
            assert changed and changed <= options, changed


def test_an_unknown_only_row_is_refused_before_any_work(tmp_path, capsys):
    from leaderboard.reproduce import main

    assert main(["--work", str(tmp_path / "w"), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
                 "--only", "nothing", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --only: unknown plan entries ['nothing']")
    assert not (tmp_path / "w").exists()
