"""The docs are a manual: measured sections live in docs/results/ (docs/results/README.md,
"What counts as a measurement"), and the leaderboard page's row figures are the generated
block that `leaderboard.build` writes from the committed tables."""

import re
from pathlib import Path

import pytest

from blendvoca.errors import DataError, UserError
from leaderboard.build import main as build_main
from leaderboard.docs_rows import BEGIN, END, check_page, refresh_page, rows_block

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

MONTHS = "January|February|March|April|May|June|July|August|September|October|November|December"
#: rule 1: a sentence that says it reports a measurement
MARKER = re.compile(r"(?<![\w`])(Measured( (on|by|in|with|over|at|so far)\b| ?\()|Recorded (on |\d))")
#: rule 3: a calendar date (ISO, or day month year)
DATE = re.compile(rf"\b(19|20)\d\d-[01]\d-[0-3]\d\b|\b\d{{1,2}} ({MONTHS}) (19|20)\d\d\b")
#: a figure with a unit of time or memory: 0.59 s, 34 ms/frame, 351 MB, 4.0 min, 1.5 h, 2 GiB
TIMING = r"[~≈<>]?\s*\d[\d,]*(\.\d+)?\s*(-\s*\d[\d,]*(\.\d+)?\s*)?(ms|s|min|h|kB|KB|MB|GB|GiB|MiB)(/\w+)?"
TIMING_CELL = re.compile(rf"^{TIMING}$")
#: rule 2: a table header naming a unit of time or memory
TIMING_HEADER = re.compile(r"\((ms|s|min|h|MB|GB)\)|\bseconds\b|\bwall\b|\bpeak RSS\b|\bms per\b", re.I)
#: a measured figure (decimals), or a range of two: 3.54, -0.2, 1e-7, 0.10 - 0.12 (not 30-35, not 600)
NUMBER_CELL = re.compile(r"^[-+]?\d[\d,]*(\.\d+|e[-+]?\d+)(\s*-\s*\d[\d,]*(\.\d+)?)?$")


def _cells(line: str) -> list[str]:
    return [c.strip().strip("*").strip() for c in line.strip().strip("|").split("|")]


def _sections(text: str):
    """(heading, [(line number, line)]) for each section of a Markdown page, code fences
    left out (a fenced block is a command or an example, not a figure of the page)."""
    heading, lines, fenced = "(top)", [], False
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if fenced:
            continue
        if line.startswith("#"):
            yield heading, lines
            heading, lines = line.lstrip("#").strip(), []
        lines.append((number, line))
    yield heading, lines


def _tables(lines):
    """The Markdown tables among ``lines``: lists of consecutive (line number, row), header first."""
    tables, current = [], []
    for n, line in lines:
        if line.lstrip().startswith("|"):
            current.append((n, line))
        elif current:
            tables.append(current)
            current = []
    return tables + ([current] if current else [])


def _figures(table) -> bool:
    """Whether a table's body holds a decimal figure (a measured value, not a count or a default)."""
    return any(NUMBER_CELL.match(c) or TIMING_CELL.match(c) for _, row in table[2:] for c in _cells(row))


def measurements(text: str) -> list[str]:
    """Where a page carries a measurement (the rules of docs/results/README.md), one
    'line N (section): rule: excerpt' per finding; empty for a manual page."""
    found = []
    for heading, lines in _sections(text):
        where = lambda n, rule, line: f"line {n} ({heading}): {rule}: {line.strip()[:80]}"  # noqa: E731
        tables = _tables(lines)
        with_figures = [table for table in tables if _figures(table)]
        for n, line in lines:
            if MARKER.search(line):
                found.append(where(n, "measurement marker", line))
            if DATE.search(line) and with_figures:
                found.append(where(n, f"a date beside a table of figures (line {with_figures[0][0][0]})", line))
        for table in tables:
            (header_n, header), timed = table[0], False
            for n, row in table[2:]:
                if any(TIMING_CELL.match(c) for c in _cells(row)):
                    found.append(where(n, "a timing or memory figure in a table", row))
                    timed = True
            if not timed and TIMING_HEADER.search(header) and _figures(table):
                found.append(where(header_n, "a table of timings", header))
    return found


def reference_pages() -> list[Path]:
    return sorted(p for p in DOCS.rglob("*.md") if DOCS / "results" not in p.parents)


def test_no_measured_section_outside_docs_results():
    found = {p.relative_to(ROOT).as_posix(): measurements(p.read_text()) for p in reference_pages()}
    found = {page: lines for page, lines in found.items() if lines}
    assert not found, "measured sections belong in docs/results/ (docs/results/README.md): " + "; ".join(
        f"{page} {line}" for page, lines in found.items() for line in lines)


def test_the_reference_pages_are_checked():
    names = {p.name for p in reference_pages()}
    assert {"leaderboard.md", "streaming.md", "synthetic.md", "metrics.md"} <= names
    assert "README.md" not in names  # docs/results/README.md is a results page


MANUAL = """# A tool

## Use

```bash
python -m tool --out DIR        # 2 s on a laptop
```

| option | default |
|---|---|
| `--workers` | 2 |

It takes about a minute per speaker.
"""


def test_a_manual_page_passes():
    assert measurements(MANUAL) == []


def test_a_reinserted_timing_table_is_refused():
    page = MANUAL + "\n## Speed\n\n| stage | time |\n|---|---|\n| fit | 0.59 s |\n| render | 34 ms/frame |\n"
    found = measurements(page)
    assert len(found) == 2 and all("(Speed): a timing or memory figure" in f for f in found)


def test_a_dated_table_of_figures_is_refused():
    page = MANUAL + "\n## Results\n\nOn 4 December 2026:\n\n| row | LVE |\n|---|---|\n| said | 2.84 |\n"
    assert measurements(page) == ["line 17 (Results): a date beside a table of figures (line 19): On 4 December 2026:"]
    # the same table undated is a table of the manual (e.g. defaults)
    assert measurements(page.replace("On 4 December 2026:", "Defaults:")) == []


def test_a_measurement_marker_is_refused():
    page = MANUAL + "\nMeasured on the bundled default, the fit settles in 7 alternations.\n"
    assert measurements(page) == [
        "line 15 (Use): measurement marker: Measured on the bundled default, the fit settles in 7 alternations."]
    assert measurements(MANUAL + "\nRecorded 2026-12-01: 3.5x.\n")[0].startswith("line 15 (Use): measurement marker")
    # the verb inside a sentence is manual text
    assert measurements(MANUAL + "\nLip sync is measured on the reference rig.\n") == []


def test_a_timing_table_header_is_refused():
    page = MANUAL + "\n## Cost\n\n| stage | seconds |\n|---|---|\n| fit | 0.10 - 0.12 |\n"
    assert measurements(page) == ["line 17 (Cost): a table of timings: | stage | seconds |"]


def test_the_leaderboard_page_carries_the_generated_rows():
    check_page(DOCS / "leaderboard.md", ROOT / "leaderboard" / "tables" / "leaderboard.md")


TABLES = ROOT / "leaderboard" / "tables" / "leaderboard.md"


def test_the_generated_rows_follow_the_tables():
    block = rows_block(TABLES.read_text())
    assert block.startswith(BEGIN) and block.endswith(END)
    # the cells as the tables print them (vertex table: LVE rig; distribution table: FD), settled as "yes",
    # the † mark as "no †" (the FACEGOOD board's FaceFormer)
    assert "| said | 2.8352 [2.7887, 2.8808] seeds [2.8202, 2.8443] | 13.47 [13.42, 13.55] seeds [13.40, 13.54] | yes |" in block
    assert "| FaceFormer | 7.3 [5.7, 8.6] seeds [5.6, 8.6] | 300.0 [25.0, 542.1] seeds [24.0, 448.8] | no † |" in block
    assert "| *static* | 4.2908 [4.0711, 4.5135] | 6555.64 [6555.64, 6555.64] | reference |" in block
    note = next(line for line in TABLES.read_text().splitlines() if line.startswith("† Not settled"))
    assert note in block.splitlines()


def test_a_hand_edited_row_figure_is_refused_and_refreshed(tmp_path):
    page = tmp_path / "leaderboard.md"
    committed = (DOCS / "leaderboard.md").read_text()
    edited = committed.replace("| said | 2.8352 [2.7887", "| said | 2.8353 [2.7887")
    assert edited != committed
    page.write_text(edited)
    with pytest.raises(DataError, match="python -m leaderboard.build --docs"):
        check_page(page, TABLES)
    assert refresh_page(page, TABLES) and page.read_text() == committed
    assert not refresh_page(page, TABLES)  # nothing to rewrite


def test_build_writes_the_docs_block_from_the_tables_it_wrote(tmp_path):
    page = tmp_path / "leaderboard.md"
    committed = (DOCS / "leaderboard.md").read_text()
    head, rest = committed.split(BEGIN)
    page.write_text(head + BEGIN + "\n| stale |\n" + END + rest.split(END)[1])
    assert build_main(["--results", str(ROOT / "leaderboard" / "results"), "--out", str(tmp_path / "t"),
                       "--docs", str(page)]) == 0
    assert page.read_text() == committed


def test_a_page_without_the_block_or_tables_without_a_column_are_refused(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# no block\n")
    with pytest.raises(DataError, match="expected one generated block"):
        refresh_page(page, TABLES)
    with pytest.raises(UserError, match="no such file"):
        refresh_page(tmp_path / "missing.md", TABLES)
    with pytest.raises(DataError, match="expected a '### Vertex' section"):
        rows_block(TABLES.read_text().replace("### Vertex", "### Vertices"))


def test_every_results_section_would_be_refused_in_a_reference_page():
    """Each section of docs/results/ carries its date ("Recorded ..."), so moving it back into a
    reference page fails the first test."""
    for page in sorted((DOCS / "results").glob("*.md")):
        if page.name == "README.md":
            continue
        sections = re.split(r"^(?=## )", page.read_text(), flags=re.M)[1:]
        assert sections, page
        for section in sections:
            assert measurements(MANUAL + "\n" + section), f"{page.name}: {section.splitlines()[0]} is not dated"


def _anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_relative_links_resolve():
    """Moving sections between pages must not leave a link to a page or heading that is gone."""
    pages = sorted(DOCS.rglob("*.md")) + [ROOT / "README.md"]
    anchors = {page: {_anchor(heading) for heading, _ in _sections(page.read_text()) if heading != "(top)"}
               for page in pages}
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if target.startswith(("http:", "https:", "mailto:")):
                continue
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path).resolve() if path else page
            if not resolved.exists() or (anchor and resolved.suffix == ".md" and anchor not in anchors.get(resolved, ())):
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert not broken, "links to nothing: " + "; ".join(broken)
