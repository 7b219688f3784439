"""The size the docs give for the bundled default is the corpus's real size."""

import re
from pathlib import Path

from blendvoca.synthetic.corpus import DEFAULT_CORPUS

ROOT = Path(__file__).resolve().parents[1]


def test_the_docs_state_the_bundled_default_size():
    pages = [ROOT / "docs" / "leaderboard.md", ROOT / "docs" / "build.md"]
    found = []
    for page in pages:
        for match in re.finditer(r"bundled default[^.]*?\((?:synthetic, )?(\d+) speakers x (\d+) ", page.read_text()):
            found.append((page.name, int(match.group(1)), int(match.group(2))))
    assert {name for name, *_ in found} == {"leaderboard.md", "build.md"}, found
    for name, speakers, sentences in found:
        assert (speakers, sentences) == (DEFAULT_CORPUS["speakers"], DEFAULT_CORPUS["sentences"]), name
