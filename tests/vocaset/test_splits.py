import pytest

from blendvoca.vocaset import VOCASET_SPLITS, VOCASET_SUBJECTS, corpus_splits, proportional_split


def test_standard_split_is_8_2_2_and_disjoint():
    assert [len(VOCASET_SPLITS[k]) for k in ("train", "val", "test")] == [8, 2, 2]
    assert len(VOCASET_SUBJECTS) == 12
    assert "FaceTalk_170809_00138_TA" in VOCASET_SPLITS["test"]
    assert "FaceTalk_170725_00137_TA" in VOCASET_SPLITS["train"]


@pytest.mark.parametrize("n, sizes", [(12, (8, 2, 2)), (6, (4, 1, 1)), (3, (1, 1, 1)), (24, (16, 4, 4))])
def test_proportional_split_keeps_vocaset_proportions(n, sizes):
    names = [f"S{i}" for i in range(n)]
    split = proportional_split(names)
    assert tuple(len(split[k]) for k in ("train", "val", "test")) == sizes
    assert sorted(sum(split.values(), [])) == sorted(names)


def test_proportional_split_rejects_bad_input():
    with pytest.raises(ValueError, match="at least 3"):
        proportional_split(["a", "b"])
    with pytest.raises(ValueError, match="duplicate"):
        proportional_split(["a", "a", "b"])


def test_corpus_splits_uses_the_standard_split_for_vocaset_subjects():
    subjects = [s for s in VOCASET_SUBJECTS if s != "FaceTalk_170731_00024_TA"]
    split = corpus_splits(subjects)
    assert split["test"] == ["FaceTalk_170809_00138_TA"]
    assert split["train"] == list(VOCASET_SPLITS["train"])
