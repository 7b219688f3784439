"""The study server under load on loopback: simulated participants answering at once.

Two runs of ``python -m benchmark.study serve`` (a child process) on a synthetic A/B study
(``--pairs`` pairs x 2 questions per participant, 1 s H.264 clips), each with ``--clients``
concurrent participants answering as fast as the server replies for ``--seconds``:

1. a clean run: p50/p99 response time of the answers, answers per second, and the database
   count against the clients' acknowledged count (lost, duplicated);
2. the same with the server killed by SIGKILL ``--kill-at`` seconds in and started again:
   every answer acknowledged before the kill must be in the database, none twice, and the
   participants interrupted by the kill must resume (same session token, next question).

    python perf/study_load.py                                   # 50 clients, 2 minutes each run
    python perf/study_load.py --clients 10 --seconds 20 --kill-at 8
    python perf/study_load.py --think-ms 5000 --skip-kill      # participants' pace: an answer every ~5 s
    python perf/study_load.py --db postgresql://study@127.0.0.1:5432/study   # an empty database
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clients", type=int, default=50, help="concurrent participants (default 50)")
    parser.add_argument("--seconds", type=float, default=120.0, help="length of each run (default 120)")
    parser.add_argument("--kill-at", type=float, default=60.0, help="SIGKILL the server this many seconds "
                        "into the second run (default 60)")
    parser.add_argument("--pairs", type=int, default=24, help="A/B pairs per participant (default 24, as CodeTalker)")
    parser.add_argument("--think-ms", type=float, default=0.0, help="mean pause before each answer (default 0)")
    parser.add_argument("--db", default=None, help="database URL (default a fresh SQLite file per run)")
    parser.add_argument("--skip-clean", action="store_true", help="only the SIGKILL run")
    parser.add_argument("--skip-kill", action="store_true", help="only the clean run")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures here")
    args = parser.parse_args(argv)

    from benchmark.study.server.load import load_run
    from tests.study.server_fixtures import SOUND_WORD, free_port, make_clips, tiny_study

    out = {}
    with tempfile.TemporaryDirectory(prefix="study-load-") as tmp:
        tmp = Path(tmp)
        clips = make_clips(tmp / "clips")
        runs = [("clean", None)] if not args.skip_clean else []
        if not args.skip_kill:
            runs.append(("sigkill", args.kill_at))
        for name, kill_at in runs:
            folder = tmp / name
            tiny_study(folder, clips, pairs=args.pairs, slots=3)
            print(f"== {name}: {args.clients} clients for {args.seconds:g} s"
                  + (f", SIGKILL at {kill_at:g} s" if kill_at else ""), flush=True)
            figures = load_run(folder, clients=args.clients, seconds=args.seconds, kill_at=kill_at,
                               sound_word=SOUND_WORD, port=free_port(), db_url=args.db,
                               think_seconds=args.think_ms / 1000)
            out[name] = figures
            print(f"answers acknowledged {figures['acknowledged']}, stored {figures['stored']}, "
                  f"lost {figures['lost']}, duplicated {figures['duplicated']}, "
                  f"stored but not acknowledged {figures['stored_not_acknowledged']}")
            print(f"answers/s {figures['answers_per_second']:.1f}; answer response time p50 "
                  f"{figures['answer_p50_ms']:.1f} ms, p99 {figures['answer_p99_ms']:.1f} ms; all requests p50 "
                  f"{figures['request_p50_ms']:.1f} ms, p99 {figures['request_p99_ms']:.1f} ms")
            print(f"participants started {figures['participants_started']}, finished "
                  f"{figures['participants_finished']}; statuses {figures['statuses']}")
            if kill_at:
                print(f"killed at {kill_at:g} s, answering again after {figures['restart_s']:.1f} s; "
                      f"acknowledged before the kill {figures['acknowledged_before_kill']}; participants "
                      f"interrupted {figures['interrupted']}, resumed {figures['resumed']}; "
                      f"requests failed in transit (retried) {figures['transport_errors']}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1, default=str) + "\n")
    ok = all(f["lost"] == 0 and f["duplicated"] == 0 for f in out.values())
    ok = ok and all(f.get("resumed") == f.get("interrupted") for f in out.values())
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
