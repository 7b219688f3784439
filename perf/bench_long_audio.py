"""Peak memory of SAiD ``cpu-demo`` generating from a long WAV, against a 10-second one.

Each length runs ``baselines.said.generate.generate_files`` (the command line's path:
read the WAV, sample, write the CSV) in a fresh subprocess, whose peak resident size
(``ru_maxrss``, C allocations and torch's included) is its own. The WAVs are synthetic
(voiced bursts over noise at 16 kHz); the network is an untrained ``cpu-demo`` SAiD
(memory does not depend on the weights' values), saved once as a checkpoint. A long
utterance goes chunk by chunk (``baselines.common.chunking``), so the peak should stay
near the short one's: the ratio printed last is long over short.

    python perf/bench_long_audio.py                           # 10 s and 10 min, 50 DDIM steps (~2-3 min)
    python perf/bench_long_audio.py --seconds 10 60 --num-steps 2   # quicker
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

_CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {root!r})
from baselines.said.generate import generate_files
start = time.perf_counter()
paths = generate_files({wav!r}, {out!r}, checkpoint={checkpoint!r}, num_steps={steps})
seconds = time.perf_counter() - start
with open(paths[0]) as fh:
    frames = sum(1 for _ in fh) - 1
print(json.dumps({{"peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                  "seconds": seconds, "frames": frames}}))
"""


def synthetic_speech(seconds: float, rate: int = 16000, seed: int = 0) -> np.ndarray:
    """``(N,)`` float32: voiced bursts (a 120-220 Hz tone with harmonics, 0.1-0.4 s each) over quiet noise."""
    rng = np.random.default_rng(seed)
    n = int(round(seconds * rate))
    audio = 0.01 * rng.standard_normal(n).astype(np.float32)
    t = 0
    while t < n:
        length = int(rng.uniform(0.1, 0.4) * rate)
        f0 = rng.uniform(120, 220)
        k = np.arange(min(length, n - t))
        burst = sum(np.sin(2 * np.pi * h * f0 * k / rate) / h for h in (1, 2, 3)) * np.hanning(k.size)
        audio[t:t + k.size] += 0.3 * burst.astype(np.float32)
        t += k.size + int(rng.uniform(0.05, 0.25) * rate)
    return audio


def untrained_checkpoint(path: Path) -> Path:
    """Save an untrained ``cpu-demo`` SAiD (seeded) as ``path``."""
    import torch

    from baselines.said.pipeline import SAiD
    from blendvoca.names import BLENDVOCA_NAMES

    torch.manual_seed(0)
    SAiD.from_preset(BLENDVOCA_NAMES, "cpu-demo").save(path)
    return path


def peak_memory(seconds: float, work: Path, checkpoint: Path, num_steps: int) -> dict:
    """Generate from a synthetic WAV of ``seconds`` in a subprocess; its peak RSS (MB), time and frames."""
    from blendvoca.io.audio import write_wav

    wav = work / f"speech-{seconds:g}s.wav"
    write_wav(wav, synthetic_speech(seconds), 16000)
    code = _CHILD.format(root=str(ROOT), wav=str(wav), out=str(work / f"out-{seconds:g}s.csv"),
                         checkpoint=str(checkpoint), steps=int(num_steps))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    record = json.loads(done.stdout.strip().splitlines()[-1])
    wav.unlink()
    return {"audio_s": float(seconds), **record}


def measure(seconds_list, num_steps: int = 50) -> list[dict]:
    """One :func:`peak_memory` record per length, in order."""
    with tempfile.TemporaryDirectory(prefix="bench-long-audio-") as tmp:
        work = Path(tmp)
        checkpoint = untrained_checkpoint(work / "said.pt")
        return [peak_memory(s, work, checkpoint, num_steps) for s in seconds_list]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, nargs="+", default=[10.0, 600.0],
                        help="audio lengths; the first is the reference (default 10 600)")
    parser.add_argument("--num-steps", type=int, default=50, help="DDIM steps (default the preset's 50)")
    args = parser.parse_args(argv)
    records = measure(args.seconds, args.num_steps)
    base = records[0]["peak_rss_mb"]
    print(f"{'audio (s)':>10} {'frames':>8} {'peak RSS (MB)':>14} {'time (s)':>9} {'ratio':>6}")
    for r in records:
        print(f"{r['audio_s']:>10g} {r['frames']:>8d} {r['peak_rss_mb']:>14.1f} {r['seconds']:>9.1f} "
              f"{r['peak_rss_mb'] / base:>6.3f}")
    print(f"peak memory ratio {records[-1]['audio_s']:g} s / {records[0]['audio_s']:g} s: "
          f"{records[-1]['peak_rss_mb'] / base:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
