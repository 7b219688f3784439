"""``open_vocaset`` / ``detect_layout`` take ``str`` or any ``os.PathLike`` root and name
the file when its content is wrong."""

import shutil

import numpy as np
import pytest

from blendvoca.errors import DataError, UserError
from blendvoca.vocaset import detect_layout, open_vocaset
from tests.fixtures.paths import FsPath


def test_both_layouts_open_from_any_path(synthetic_corpus, synthetic_corpus_processed):
    for root, layout in ((synthetic_corpus, "official"), (synthetic_corpus_processed, "processed")):
        for given in (str(root), FsPath(root), root):
            assert detect_layout(given) == layout
            corpus = open_vocaset(given)
            assert corpus.layout == layout and corpus.root == root
            subject = corpus.subjects[0]
            assert corpus.frames(subject, corpus.sentences(subject)[0]).dtype == np.float64


def test_wrong_roots_and_contents_are_tree_errors(tmp_path, synthetic_corpus_processed):
    with pytest.raises(UserError, match="not a VOCASET folder"):
        open_vocaset(FsPath(tmp_path))
    with pytest.raises(FileNotFoundError, match="VOCASET root not found"):
        detect_layout(FsPath(tmp_path / "none"))
    broken = tmp_path / "processed"
    shutil.copytree(synthetic_corpus_processed, broken)
    (broken / "synthetic.json").write_text("{ not json")
    with pytest.raises(DataError, match=r"synthetic\.json: not a readable synthetic-corpus sidecar"):
        open_vocaset(broken)
    (broken / "synthetic.json").unlink()
    (broken / "data_verts.npy").write_bytes(b"not an npy file at all")
    with pytest.raises(DataError, match=r"data_verts\.npy: not a readable \.npy file"):
        open_vocaset(FsPath(broken))
