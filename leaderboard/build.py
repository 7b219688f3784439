"""Render every stored result into Markdown and LaTeX tables.

``python -m leaderboard.build [--results DIR] [--out DIR] [--docs PAGE]``; ``--docs`` rewrites the
generated rows of PAGE (docs/leaderboard.md) from the tables just written (leaderboard.docs_rows).
"""

from __future__ import annotations

import sys
from pathlib import Path

from blendvoca import cli
from blendvoca.io.atomic import atomic_write

from .collect import DEFAULT_RESULTS_DIR, load_results
from .docs_rows import refresh_page
from .render import latex_tables, markdown_tables
from .settled import tables_with_statements

__all__ = ["DEFAULT_OUT_DIR", "DEFAULT_RESULTS_DIR", "build_leaderboard", "main", "rendered_tables"]

DEFAULT_OUT_DIR = Path(__file__).resolve().parent / "tables"


def rendered_tables(results: list) -> dict[str, str]:
    """``{"leaderboard.md": text, "leaderboard.tex": text}`` for a list of
    :class:`benchmark.results.Result`."""
    tables = tables_with_statements(results)
    return {"leaderboard.md": markdown_tables(tables), "leaderboard.tex": latex_tables(tables)}


def build_leaderboard(results_dir=DEFAULT_RESULTS_DIR, out_dir=DEFAULT_OUT_DIR) -> list[Path]:
    """Read ``results_dir/*.json`` and write the rendered tables into ``out_dir``.

    Returns
    -------
    list of Path
        The written files.

    Raises
    ------
    UserError, DataError
        No such folder, or a file in it that is not a result (named); nothing is
        written then.
    """
    tables = rendered_tables(load_results(results_dir))  # every file read before anything is written
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, text in tables.items():
        path = out_dir / name
        with atomic_write(path, "w", encoding="utf-8") as handle:
            handle.write(text)
        written.append(path)
    return written


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("leaderboard.build", __doc__)
    parser.add_argument("--out", default=str(DEFAULT_OUT_DIR), help="directory for leaderboard.md / leaderboard.tex")
    cli.add_results_option(parser, default=str(DEFAULT_RESULTS_DIR),
                           help="directory of result JSON files (default: the committed leaderboard/results)")
    parser.add_argument("--docs", help="a page with a generated rows block (docs/leaderboard.md) "
                                       "to rewrite from the tables")
    args = parser.parse_args(argv)
    for path in build_leaderboard(args.results, args.out):
        print(path)
    if args.docs and refresh_page(args.docs, Path(args.out) / "leaderboard.md"):
        print(args.docs)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
