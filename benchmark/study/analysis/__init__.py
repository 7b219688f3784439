"""The analysis of a study's answers (``python -m benchmark.study analyze``), a file per step.

  exclusions     who is left out and why (attention checks, minimum time, incomplete, sound check)
  judgements     the kept answers coded as arrays (A/B choices, MOS ratings)
  bootstrap      the crossed bootstrap: participants and items resampled independently
  preference     per comparison and question, the share preferring A, its interval and test
  mos            mean opinion score per row and question with intervals
  bradley_terry  Bradley-Terry strengths (choix) with intervals, when more than two rows
  agreement      Krippendorff's alpha between participants (krippendorff)
  board          the board's metrics held against the participants' verdicts
  tables         markdown and LaTeX tables in the papers' format
  figure         the figure (matplotlib, Agg)

:func:`analyze` runs the statistical steps on a read study and its exported answers and
returns the JSON-ready record written to ``STUDY/analysis/analysis.json``.
"""

from __future__ import annotations

import numpy as np

from benchmark.study.analysis.agreement import agreement
from benchmark.study.analysis.bootstrap import crossed_weights
from benchmark.study.analysis.board import board_results, metrics_against_people
from benchmark.study.analysis.bradley_terry import bradley_terry
from benchmark.study.analysis.exclusions import apply_exclusions
from benchmark.study.analysis.judgements import ab_judgements, mos_ratings, study_rows
from benchmark.study.analysis.mos import mos_scores
from benchmark.study.analysis.preference import preference_shares
from blendvoca.errors import UserError

DEFAULT_REPLICATES = 2000
__all__ = ["DEFAULT_REPLICATES", "analyze", "board_results"]


def analyze(study, answers: list[dict], participants: list[dict], *, reference: str | None = None,
            replicates: int = DEFAULT_REPLICATES, seed: int = 0, where: str = "the export",
            board: dict | None = None) -> dict:
    """Exclusions, preference shares, MOS, Bradley-Terry and agreement of one study's answers.

    ``reference`` is the row every other row is compared with in the tables ("Ours"; default
    the study's first row). Raises UserError when nothing is left to analyse.
    """
    rows = study_rows(study)
    if reference is None:
        reference = rows[0] if rows else None
    elif reference not in rows:
        raise UserError(f"--reference {reference!r} is not a row of the study: expected one of {', '.join(rows)}")
    if not answers:
        raise UserError(f"{where}: no answers to analyse (answers.csv holds none); has anybody taken the study?")
    kept, exclusions = apply_exclusions(study, answers, participants, where=where)
    if not kept:
        raise UserError(f"{where}: no answers left after the exclusions ({exclusions['summary']})")
    ab = ab_judgements(study, kept, rows, reference)
    mos = mos_ratings(study, kept, rows)
    record = {
        "design": study.design,
        "rows": list(rows),
        "labels": {row: (study.rows.get(row) or {}).get("label") or row for row in rows},
        "reference": reference,
        "questions": [q.id for q in study.questions],
        "exclusions": exclusions,
        "bootstrap": {"replicates": int(replicates), "seed": int(seed), "interval": "percentile, 95 %",
                      "resampled": "participants and items (subject, sentence) independently (crossed)"},
        "preference": [], "mos": [], "bradley_terry": {}, "agreement": {},
    }
    rng = np.random.default_rng(seed)
    if ab.size:
        weights = crossed_weights(ab.participant, ab.item, len(ab.participants), len(ab.items), replicates, rng)
        record["preference"] = preference_shares(ab, weights)
        if len(set(np.concatenate([ab.row_a, ab.row_b]).tolist())) > 2:
            record["bradley_terry"] = bradley_terry(ab, weights, reference)
        record["agreement"].update(agreement(ab, "nominal"))
    if mos.size:
        weights = crossed_weights(mos.participant, mos.item, len(mos.participants), len(mos.items), replicates, rng)
        record["mos"] = mos_scores(mos, weights)
        for question, entry in agreement(mos, "ordinal").items():
            record["agreement"][f"{question} (MOS)" if question in record["agreement"] else question] = entry
    if board is not None:
        if not ab.size:
            raise UserError("--board holds the metrics against A/B judgements; this study has none (a MOS study)")
        record["board"] = metrics_against_people(ab, record, board)
    return record
