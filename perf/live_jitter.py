"""Live output to a loopback receiver: frames lost or reordered, values, and frame-time jitter.

A random track of ``--seconds`` at ``--fps`` is written as a BlendVOCA CSV and sent by
``python -m blendvoca.live`` (a separate process, as a user runs it) to a receiver in
this process (:class:`blendvoca.live.receiver.DatagramRecorder`, stamping arrivals on
the monotonic clock). Printed per protocol: frames received of those sent, frames out
of order, the largest difference from the file's values (float32), the sender's
lateness after each deadline (p50 / p99 / max, from its last line) and the arrival
jitter: each arrival's distance from its ideal time ``first + k / fps`` less the median
distance (p50 / p99 / max of the absolute value), and the p99 of ``|interval - 1/fps|``.

    python perf/live_jitter.py                                  # 60 s at 60 fps, livelink and osc
    python perf/live_jitter.py --seconds 5 --protocols livelink
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _frames(protocol: str, datagrams, names) -> tuple[list[int], np.ndarray]:
    """Frame numbers (Live Link) or arrival indices (OSC, no frame number on the wire) and (N, K) values."""
    if protocol == "livelink":
        from blendvoca.live.livelink_udp import PACKET_NAMES, decode_packet

        packets = [decode_packet(data) for _, data in datagrams]
        slots = [PACKET_NAMES.index(n) for n in names]
        return [p.frame_number for p in packets], np.array([p.values[slots] for p in packets])
    from pythonosc.osc_bundle import OscBundle

    values = np.array([[m.params[0] for m in OscBundle(data)] for _, data in datagrams], dtype=np.float32)
    return list(range(len(values))), values


def measure(protocol: str, csv: Path, values: np.ndarray, names, fps: float) -> dict:
    from blendvoca.live.receiver import DatagramRecorder

    count = len(values)
    with DatagramRecorder() as receiver:
        done = subprocess.run([sys.executable, "-m", "blendvoca.live", "--coeffs", str(csv), "--fps", str(fps),
                               "--to", f"{protocol}://127.0.0.1:{receiver.port}", "--quiet"],
                              capture_output=True, text=True, cwd=ROOT)
        receiver.wait(count, 5.0)
    if done.returncode != 0:
        raise SystemExit(f"blendvoca.live failed: {done.stderr.strip()}")
    numbers, got = _frames(protocol, receiver.datagrams, names)
    arrivals = np.array([t for t, _ in receiver.datagrams])
    late = [float(x) for x in re.search(r"p50 ([\d.]+) ms, p99 ([\d.]+) ms, max ([\d.]+) ms", done.stdout).groups()]
    k = np.arange(len(arrivals))
    offset = arrivals - arrivals[0] - k / fps
    offset = np.abs(offset - np.median(offset)) * 1000
    intervals = np.abs(np.diff(arrivals) - 1 / fps) * 1000
    received = len(numbers)
    return {
        "protocol": protocol, "sent": count, "received": received,
        "out_of_order": int(np.sum(np.diff(numbers) != 1)) if received > 1 else 0,
        "max_value_error": float(np.abs(got - values[:received].astype(np.float32)).max()) if received else None,
        "late_p50": late[0], "late_p99": late[1], "late_max": late[2],
        "jitter_p50": float(np.percentile(offset, 50)), "jitter_p99": float(np.percentile(offset, 99)),
        "jitter_max": float(offset.max()), "interval_p99": float(np.percentile(intervals, 99)),
        "span": float(arrivals[-1] - arrivals[0]),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="track length (default 60)")
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate (default 60)")
    parser.add_argument("--protocols", nargs="+", default=["livelink", "osc"], choices=["livelink", "osc"])
    args = parser.parse_args(argv)

    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
    from blendvoca.names import BLENDVOCA_NAMES

    count = int(round(args.seconds * args.fps))
    with tempfile.TemporaryDirectory() as folder:
        csv = Path(folder) / "track.csv"
        write_coeffs_csv(csv, np.random.default_rng(0).uniform(0, 1, (count, len(BLENDVOCA_NAMES))), BLENDVOCA_NAMES)
        values, names = read_coeffs_csv(csv)
        print(f"{'protocol':>9} {'sent':>6} {'recv':>6} {'reord':>5} {'max |err|':>9} "
              f"{'late p50/p99/max (ms)':>22} {'jitter p50/p99/max (ms)':>24} {'|dt-T| p99 (ms)':>15} {'span (s)':>9}")
        for protocol in args.protocols:
            r = measure(protocol, csv, values, names, args.fps)
            print(f"{r['protocol']:>9} {r['sent']:>6} {r['received']:>6} {r['out_of_order']:>5} "
                  f"{r['max_value_error']:>9.1e} {r['late_p50']:>6.3f}/{r['late_p99']:.3f}/{r['late_max']:.3f}"
                  f" {r['jitter_p50']:>8.3f}/{r['jitter_p99']:.3f}/{r['jitter_max']:.3f}"
                  f" {r['interval_p99']:>15.3f} {r['span']:>9.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
