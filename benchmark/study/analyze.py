"""``python -m benchmark.study analyze STUDY``: the exclusions, the preference shares with
intervals and tests, MOS, Bradley-Terry strengths, the agreement between participants, tables
and a figure; with ``--board DIR`` the board's metrics held against the participants.

Reads the answers exported to ``STUDY/export`` (exported first when missing) and writes
``STUDY/analysis/`` (analysis.json, tables.md, tables.tex, figure.png; each file whole or not
at all); the tables are printed. The statistics: :mod:`benchmark.study.analysis`;
the manual: docs/study.md, "Analysing a study".
"""

from __future__ import annotations

import json
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import UserError
from blendvoca.io.atomic import atomic_write

ANALYSIS_FOLDER = "analysis"


def add_arguments(parser) -> None:
    parser.add_argument("study", help="the study folder")
    parser.add_argument("--reference", metavar="ROW",
                        help="the row every other row is compared with ('Ours'); default the study's first row")
    parser.add_argument("--board", metavar="DIR",
                        help="a folder holding the studied rows' result files: hold their metrics against the answers")
    parser.add_argument("--store", action="store_true",
                        help="with --board: store the study's verdict in the studied rows' result files "
                             "(their human_preference part, the leaderboard's 'human preference' column)")
    parser.add_argument("--replicates", type=int, default=None, metavar="B",
                        help="bootstrap replicates (default 2000)")
    parser.add_argument("--seed", type=int, default=0, help="the bootstrap's seed (default 0)")
    parser.add_argument("--db", metavar="URL",
                        help="the answers' database, when STUDY/export is missing and must be exported first")
    cli.add_quiet_option(parser)


def _export_folder(study_folder: Path, db_url) -> Path:
    from benchmark.study.answers import EXPORT_FOLDER

    folder = study_folder / EXPORT_FOLDER
    if not (folder / "answers.csv").is_file():
        try:
            from benchmark.study.export import export_study
        except ImportError:
            raise UserError(f"{folder}: no exported answers; run python -m benchmark.study export {study_folder}") \
                from None
        export_study(study_folder, db_url)
    return folder


def write_outputs(folder: Path, record: dict, markdown: str, latex: str, png: bytes) -> list[Path]:
    """Write the four outputs into ``folder``, each atomically."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, content in (("analysis.json", json.dumps(record, indent=1, allow_nan=False) + "\n"),
                          ("tables.md", markdown), ("tables.tex", latex), ("figure.png", png)):
        path = folder / name
        with atomic_write(path, "wb") as handle:
            handle.write(content if isinstance(content, bytes) else content.encode("utf-8"))
        paths.append(path)
    return paths


def _clean(value):
    """NaN (a p-value with no replicate) as null, for strict JSON."""
    if isinstance(value, float) and value != value:
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_clean(v) for v in value]
    return value


def run(args) -> int:
    from benchmark.study.analysis import DEFAULT_REPLICATES, analyze, board_results
    from benchmark.study.analysis.figure import figure_png
    from benchmark.study.analysis.judgements import study_rows
    from benchmark.study.analysis.tables import latex_tables, markdown_tables
    from benchmark.study.answers import read_answers
    from benchmark.study.design import read_study

    folder = Path(args.study)
    study = read_study(folder)
    replicates = DEFAULT_REPLICATES if args.replicates is None else args.replicates
    if replicates < 100:
        raise UserError(f"--replicates {replicates}: expected at least 100 for a 95 % interval")
    if args.reference is not None and args.reference not in study_rows(study):
        raise UserError(f"--reference {args.reference!r} is not a row of the study {folder}: expected one of "
                        f"{', '.join(study_rows(study))}")
    if args.store and not args.board:
        raise UserError("--store writes into the result files of --board DIR: give --board")
    board = board_results(args.board, study, study_rows(study)) if args.board else None
    export = _export_folder(folder, args.db)
    answers, participants = read_answers(export)
    record = analyze(study, answers, participants, reference=args.reference, replicates=replicates,
                     seed=args.seed, where=str(export), board=board)
    record = _clean({"study": str(folder), **record})
    markdown, latex = markdown_tables(record), latex_tables(record)
    png = figure_png(record)
    paths = write_outputs(folder / ANALYSIS_FOLDER, record, markdown, latex, png)
    if args.store:
        from benchmark.study.analysis.store import store_preferences

        paths += store_preferences(board, record, folder.resolve().name)
    print(record["exclusions"]["summary"])
    print()
    print(markdown, end="")
    print(f"\nwrote {', '.join(str(p) for p in paths)}")
    return 0
