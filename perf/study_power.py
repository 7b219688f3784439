"""How many participants give what interval width in an A/B study (simulated; benchmark.study.analysis).

    python perf/study_power.py [--studies 100] [--replicates 200] [--share 0.7]

CodeTalker's design: 4 comparisons ("Ours" vs. four rows) x 30 sentences = 120 pairs, each
participant judging 24 pairs, so P participants give each pair 24 P / 120 judgements.
Simulated participants prefer Ours with probability ``--share`` in every comparison (known
Bradley-Terry strengths). For each P, over ``--studies`` simulated studies, prints the mean
width of the 95 % interval of a comparison's share (the crossed bootstrap of
``python -m benchmark.study analyze``), its coverage of the truth, how often the test
rejects 50 % at the 5 % level (the power), the width a binomial interval over the same
answers would have (participants and sentences treated as fixed), and the mean width of the
Bradley-Terry log-strengths' intervals. A markdown table, for docs/results/.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--studies", type=int, default=100, help="simulated studies per size")
    parser.add_argument("--replicates", type=int, default=200, help="bootstrap replicates per study")
    parser.add_argument("--share", type=float, default=0.7, help="the true share preferring Ours")
    parser.add_argument("--participants", default="15,30,60,120", help="the study sizes")
    parser.add_argument("--sentences", type=int, default=30, help="sentences per comparison")
    parser.add_argument("--per-participant", type=int, default=24, help="pairs each participant judges")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--figure", metavar="PNG",
                        help="also write the analysis figure of one simulated study of 30 participants, two "
                             "questions (docs/img/study-analysis-figure.png)")
    args = parser.parse_args(argv)

    from benchmark.study.analysis.bootstrap import crossed_weights
    from benchmark.study.analysis.bradley_terry import bradley_terry
    from benchmark.study.analysis.preference import preference_shares
    from benchmark.study.analysis.simulate import simulate_ab

    gap = np.log(args.share / (1 - args.share))
    strengths = np.array([0.0, -gap, -gap, -gap, -gap])
    comparisons = [(0, 1), (0, 2), (0, 3), (0, 4)]
    pairs = len(comparisons) * args.sentences
    rng = np.random.default_rng(args.seed)
    print(f"{len(comparisons)} comparisons x {args.sentences} sentences, {args.per_participant} pairs per participant, "
          f"true share {args.share}, {args.studies} studies x {args.replicates} replicates\n")
    print("| participants | judgements per pair | answers per comparison | interval width (crossed bootstrap) "
          "| coverage | power at 5 % | binomial width | Bradley-Terry width |")
    print("|---|---|---|---|---|---|---|---|")
    start = time.perf_counter()
    for participants in (int(p) for p in args.participants.split(",")):
        judges = max(1, round(participants * args.per_participant / pairs))
        widths, hits, rejected, bt_widths = [], [], [], []
        for _ in range(args.studies):
            judgements = simulate_ab(strengths, comparisons, items=args.sentences, participants=participants,
                                     judges=judges, rng=rng)
            weights = crossed_weights(judgements.participant, judgements.item, len(judgements.participants),
                                      len(judgements.items), args.replicates, rng)
            for entry in preference_shares(judgements, weights):
                widths.append(entry["ci95"][1] - entry["ci95"][0])
                hits.append(entry["ci95"][0] <= args.share <= entry["ci95"][1])
                rejected.append(entry["p_value"] < 0.05)
            bt = bradley_terry(judgements, weights, "row0", progress=False)["q0"]["strengths"]
            bt_widths += [s["ci95"][1] - s["ci95"][0] for s in bt[1:]]
        answers = args.sentences * judges
        binomial = 2 * 1.96 * np.sqrt(args.share * (1 - args.share) / answers)
        print(f"| {participants} | {judges} | {answers} | {np.mean(widths):.3f} | {np.mean(hits):.3f} | "
              f"{np.mean(rejected):.3f} | {binomial:.3f} | {np.mean(bt_widths):.2f} |", flush=True)
    print(f"\n{time.perf_counter() - start:.0f} s")
    if args.figure:
        write_figure(args.figure, strengths, comparisons, args, rng)


def write_figure(path, strengths, comparisons, args, rng) -> None:
    """The figure of ``analyze`` for one simulated study (rows named Ours, X1...; two questions)."""
    from benchmark.study.analysis.bootstrap import crossed_weights
    from benchmark.study.analysis.bradley_terry import bradley_terry
    from benchmark.study.analysis.figure import figure_png
    from benchmark.study.analysis.preference import preference_shares
    from benchmark.study.analysis.simulate import simulate_ab

    strengths = strengths + np.linspace(0, 0.8, strengths.size) * (np.arange(strengths.size) > 0)
    pairs = len(comparisons) * args.sentences
    judgements = simulate_ab(strengths, comparisons, items=args.sentences, participants=30,
                             judges=max(1, round(30 * args.per_participant / pairs)), questions=2, rng=rng)
    judgements.questions = ["lipsync", "realism"]
    judgements.rows = ["Ours"] + [f"X{k}" for k in range(1, strengths.size)]
    weights = crossed_weights(judgements.participant, judgements.item, len(judgements.participants),
                              len(judgements.items), args.replicates, rng)
    record = {"preference": preference_shares(judgements, weights), "mos": [],
              "bradley_terry": bradley_terry(judgements, weights, "Ours", progress=False)}
    Path(path).write_bytes(figure_png(record))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
