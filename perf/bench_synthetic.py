"""Generation plus the default build of a synthetic corpus: this code against the code before the
undetermined components of the one-to-many corpus, and the cost of an oracle sample.

    python perf/bench_synthetic.py --work /tmp/bench-synth
    python perf/bench_synthetic.py --work /tmp/bench-synth --speakers 6 --sentences 4 --repeats 3

In one run, alternating the variants ``--repeats`` times (so a busy machine slows
them alike), each in a fresh interpreter and into fresh folders:

- ``before``: the generator and build of ``--baseline`` (a commit, extracted with
  ``git archive``), generating with its defaults;
- ``now, default F``: this checkout, ``--audio-determined`` at its default,
  ``--oracle-samples 0``;
- ``now, F = 1``: this checkout with ``--audio-determined 1`` (the old corpus);
- ``now, K oracle samples``: default F with ``--oracle-samples K``.

Prints the median seconds (generation, build, total) of each, the ratio of
``now, default F`` to ``before`` (the acceptance bound is 1.2) and the cost of one
oracle sample (extra generation and build seconds per sentence and sample). Wall time on a
shared machine is noisy; the fastest run and the CPU seconds (this process and its
build workers) are the figures least disturbed by other load.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tarfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: The last commit before the undetermined components and the oracle samples.
BASELINE = "c68a9a8443e2323999a04cb24bb420de92301f2e"

_TIMED = """
import json, resource, sys, time
sys.path.insert(0, {code!r})
from blendvoca.builder import build_dataset
from blendvoca.runtime.progress import set_progress
from blendvoca.synthetic import generate_corpus

set_progress(False)

def cpu():
    return sum(getattr(resource.getrusage(who), f) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
               for f in ("ru_utime", "ru_stime"))

start, cpu0 = time.perf_counter(), cpu()
generate_corpus({corpus!r}, speakers={speakers}, sentences={sentences}, seed={seed}, layout={layout!r},
                overwrite=True{extra})
generated, cpu1 = time.perf_counter(), cpu()
summary = build_dataset({out!r}, {corpus!r}, workers={workers})
built, cpu2 = time.perf_counter(), cpu()
assert not summary.failures, summary.failures
print(json.dumps({{"generate": generated - start, "build": built - generated, "cpu": cpu2 - cpu0}}))
"""


def baseline_code(ref: str, work: Path) -> Path:
    """The ``blendvoca`` package of commit ``ref`` under ``work/baseline-<ref>``."""
    root = work / f"baseline-{ref[:12]}"
    if (root / "blendvoca" / "__init__.py").is_file():
        return root
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref, "blendvoca", "data_manifest.yaml"],
                             capture_output=True, check=False)
    if archive.returncode:
        sys.exit(f"git archive {ref} failed: {archive.stderr.decode().strip()}")
    root.mkdir(parents=True, exist_ok=True)
    tar_path = work / "baseline.tar"
    tar_path.write_bytes(archive.stdout)
    with tarfile.open(tar_path) as tar:
        tar.extractall(root, filter="data")
    tar_path.unlink()
    return root


def timed(code: Path, work: Path, name: str, args, extra: str = "") -> dict:
    corpus, out = work / f"corpus-{name}", work / f"build-{name}"
    for folder in (corpus, out):
        shutil.rmtree(folder, ignore_errors=True)
    script = _TIMED.format(code=str(code), corpus=str(corpus), out=str(out), speakers=args.speakers,
                           sentences=args.sentences, seed=args.seed, layout=args.layout, workers=args.workers,
                           extra=extra)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run([sys.executable, "-c", script], cwd=code, env=env, capture_output=True, text=True)
    if done.returncode:
        sys.exit(f"{name} failed:\n{done.stderr[-3000:]}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    for folder in (corpus, out):
        shutil.rmtree(folder, ignore_errors=True)
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--work", required=True, help="scratch folder (corpora, builds, the baseline's code)")
    parser.add_argument("--speakers", type=int, default=6)
    parser.add_argument("--sentences", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--layout", default="official", choices=("official", "processed"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--oracle-samples", type=int, default=4, help="K of the oracle-sample cost run")
    parser.add_argument("--baseline", default=BASELINE, help="commit of the code before (default: %(default).12s)")
    args = parser.parse_args(argv)
    work = Path(args.work).expanduser().resolve()
    work.mkdir(parents=True, exist_ok=True)
    before = baseline_code(args.baseline, work)
    variants = {
        "before": (before, ""),
        "now, default F": (REPO, ", oracle_samples=0"),
        "now, F = 1": (REPO, ", audio_determined=1.0"),
        f"now, {args.oracle_samples} oracle samples": (REPO, f", oracle_samples={args.oracle_samples}"),
    }
    times = {name: [] for name in variants}
    for repeat in range(args.repeats):
        for index, (name, (code, extra)) in enumerate(variants.items()):
            result = timed(code, work, f"v{index}", args, extra)
            times[name].append(result)
            print(f"  repeat {repeat + 1} {name}: generate {result['generate']:.2f} s, build {result['build']:.2f} s",
                  flush=True)
    print(f"\n{args.speakers} x {args.sentences} ({args.layout}), {args.workers} workers, {args.repeats} runs "
          "each (median; fastest run in brackets, the figure least disturbed by other load):")
    medians, fastest, cpu = {}, {}, {}
    for name, runs in times.items():
        g = statistics.median(r["generate"] for r in runs)
        b = statistics.median(r["build"] for r in runs)
        total = statistics.median(r["generate"] + r["build"] for r in runs)
        medians[name] = (g, b, total)
        fastest[name] = min(r["generate"] + r["build"] for r in runs)
        cpu[name] = statistics.median(r["cpu"] for r in runs)
        print(f"  {name:<24} generate {g:7.2f} s  build {b:7.2f} s  total {total:7.2f} s  [{fastest[name]:.2f} s]"
              f"  CPU {cpu[name]:7.2f} s")
    for label, key in (("default F, --oracle-samples 0", "now, default F"), ("F = 1", "now, F = 1")):
        ratio = medians[key][2] / medians["before"][2]
        best = fastest[key] / fastest["before"]
        cpu_ratio = cpu[key] / cpu["before"]
        print(f"ratio now ({label}) / before: wall {ratio:.3f} median, {best:.3f} fastest; CPU {cpu_ratio:.3f} "
              f"median ({'within' if min(ratio, best, cpu_ratio) <= 1.2 else 'OVER'} the 1.2 bound on the "
              "least disturbed figure)")
    k_name = f"now, {args.oracle_samples} oracle samples"
    per = args.speakers * args.sentences * args.oracle_samples
    extra_g = medians[k_name][0] - medians["now, default F"][0]
    extra_b = medians[k_name][1] - medians["now, default F"][1]
    print(f"one oracle sample of one sentence: {1000 * extra_g / per:.0f} ms generation + "
          f"{1000 * extra_b / per:.0f} ms build (= {1000 * (extra_g + extra_b) / per:.0f} ms; "
          f"{per} samples)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
