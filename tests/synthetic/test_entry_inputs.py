"""``generate_corpus`` takes ``str`` or any ``os.PathLike`` folder; arguments it cannot
use are :class:`~blendvoca.errors.UserError` (exit 2 on the command line)."""

import pytest

from blendvoca.errors import UserError
from blendvoca.synthetic import generate_corpus
from blendvoca.synthetic.__main__ import main
from blendvoca.vocaset import open_vocaset
from tests.fixtures.paths import FsPath


def test_generate_corpus_into_a_pathlike(tmp_path, assets_dir):
    out = generate_corpus(FsPath(tmp_path / "c"), speakers=3, sentences=1, duration=(0.8, 0.8))
    assert out == tmp_path / "c" and (out / "synthetic.json").is_file()
    assert open_vocaset(FsPath(out)).subjects == ["Synth_000_TA", "Synth_001_TA", "Synth_002_TA"]


@pytest.mark.parametrize("kwargs, message", [
    (dict(speakers=2), "speakers must be an integer >= 3"),
    (dict(sentences=0), "sentences must be an integer in"),
    (dict(layout="zip"), "layout must be 'official' or 'processed'"),
    (dict(head_motion=40.0), r"head_motion must be True/False or a peak angle in \(0, 30\]"),
])
def test_arguments_it_cannot_use_are_user_errors(tmp_path, kwargs, message):
    with pytest.raises(UserError, match=message):
        generate_corpus(tmp_path / "c", **kwargs)
    assert not (tmp_path / "c").exists()


def test_the_command_reports_what_the_library_refuses_in_one_line(tmp_path, capsys):
    # --head-motion 40 passes the command's own check (<= 45) and is refused by the library (<= 30)
    assert main(["--out", str(tmp_path / "c"), "--head-motion", "40", "--speakers", "3", "--sentences", "1",
                 "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: generate_corpus: head_motion")
