"""Time and memory of ``benchmark.render``: the old path against the new one, in one run.

    BLENDVOCA_ASSETS=../shared/assets python perf/bench_render.py [--quick]

1. Rasteriser (in process): ms per 512 px view of a FLAME-size head for the former numpy
   rasteriser (``tests/benchmark/reference_rasterizer.py``) and ``SoftwareRenderer``, and whether their
   images are identical (the largest pixel difference).
2. The README's command ``python -m benchmark.render --coeffs CSV --rig NPZ --audio WAV
   --side --out MP4`` on a 5 s clip, run as a subprocess by the old code (``git archive``
   of ``--old-commit``, run from a temporary folder) and by this tree: wall time, CPU time
   of the process tree, and their ratio; for each backend in ``--backends`` (``auto``: what
   the command picks here; ``software``: the numpy rasteriser, whose decoded frames are
   compared old against new).
3. Peak memory of the new path for the 5 s and the 15 s clip: the largest sum of the
   resident set sizes of the render process and all its descendants (the ffmpeg encoder,
   the drawing workers), sampled every 20 ms from ``/proc`` (Linux), and their ratio.

The clips are cut from one subject of the bundled default build
(``benchmark.protocol.default_data_root()``; ``--data`` another build): its sentences'
coefficient tracks and audio put end to end, the first 5 s and the first 15 s.
``--quick`` leaves out the old path (2) and runs only the new one.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: The last commit with the former renderer (whole clip in memory, sorting rasteriser).
OLD_COMMIT = "c68a9a8443e2323999a04cb24bb420de92301f2e"
FPS = 60
RATE = 16000


# ---------------------------------------------------------------- process tree sampling (Linux /proc)


def _children() -> dict[int, list[int]]:
    kids: dict[int, list[int]] = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        kids.setdefault(ppid, []).append(int(name))
    return kids


def _tree(pid: int) -> list[int]:
    kids = _children()
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(kids.get(p, []))
    return out


def _rss_bytes(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _cpu_seconds(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return 0.0


class TreeSampler(threading.Thread):
    """Samples the summed RSS and the CPU time of a process and its descendants."""

    def __init__(self, pid: int, every: float = 0.02):
        super().__init__(daemon=True)
        self.pid, self.every = pid, every
        self.peak = 0
        self.peak_processes = 0
        self.cpu: dict[int, float] = {}
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            pids = _tree(self.pid)
            total = sum(_rss_bytes(p) for p in pids)
            if total > self.peak:
                self.peak, self.peak_processes = total, len(pids)
            for p in pids:
                self.cpu[p] = max(self.cpu.get(p, 0.0), _cpu_seconds(p))
            self.stop.wait(self.every)


def run_render(cmd: list[str], cwd: Path, env: dict) -> dict:
    """Run one render command; wall time, CPU time and peak RSS of its process tree."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    sampler = TreeSampler(proc.pid)
    sampler.start()
    out, err = proc.communicate()
    wall = time.perf_counter() - t0
    sampler.stop.set()
    sampler.join()
    if proc.returncode != 0:
        raise SystemExit(f"render failed (exit {proc.returncode}) in {cwd}: {' '.join(cmd)}\n{err[-2000:]}")
    return {"wall": wall, "cpu": sum(sampler.cpu.values()), "peak": sampler.peak,
            "processes": sampler.peak_processes, "out": out.strip()}


# ---------------------------------------------------------------- clips


def make_clips(data: Path, subject: str | None, folder: Path, seconds: list[float]) -> tuple[Path, dict]:
    """Coefficient CSV + WAV clips of ``seconds`` each, cut from one subject's sentences end to end."""
    from blendvoca.format import audio_path, coeffs_path, rig_path
    from blendvoca.io.audio import load_audio, write_wav
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv

    subjects = sorted(p.stem for p in (data / "rigs").glob("*.npz"))
    subject = subject or subjects[0]
    sentences = sorted(p.stem for p in (data / "blendshape_coeffs" / subject).glob("*.csv"))
    tracks, audios, names = [], [], None
    need = max(seconds)
    while sum(len(a) for a in audios) < need * RATE + 1:
        for sentence in sentences:
            coeffs, names = read_coeffs_csv(coeffs_path(data, subject, sentence))
            wav = load_audio(audio_path(data, subject, sentence), rate=RATE)
            frames = int(round(len(wav) / RATE * FPS))  # the video frames of this sentence's audio
            coeffs = coeffs[:frames] if len(coeffs) >= frames else np.concatenate(
                [coeffs, np.repeat(coeffs[-1:], frames - len(coeffs), axis=0)])
            tracks.append(coeffs)
            audios.append(wav[:int(round(frames / FPS * RATE))])
    track, audio = np.concatenate(tracks), np.concatenate(audios)
    clips = {}
    for s in seconds:
        csv, wav = folder / f"clip{s:g}s.csv", folder / f"clip{s:g}s.wav"
        write_coeffs_csv(csv, track[:int(round(s * FPS))], names)
        write_wav(wav, audio[:int(round(s * RATE))], RATE)
        clips[s] = (csv, wav)
    return rig_path(data, subject), clips


def old_tree(commit: str, folder: Path) -> Path:
    """The packages of ``commit`` (``git archive``) in ``folder``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "benchmark", "blendvoca"],
                             capture_output=True, check=False)
    if archive.returncode != 0:
        raise SystemExit(f"git archive {commit} failed ({archive.stderr.decode(errors='replace').strip()}); "
                         "pass --quick to measure only the new path")
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
    return folder


# ---------------------------------------------------------------- parts


def rasteriser_part(frames: int) -> None:
    from benchmark.render import face_camera, front_camera
    from benchmark.render.software import SoftwareRenderer
    from tests.benchmark.reference_rasterizer import reference_rasterize
    from tests.benchmark.fakes import fake_rig, flame_head

    assets = Path(os.environ.get("BLENDVOCA_ASSETS", ROOT.parent / "shared" / "assets"))
    v, f = flame_head(assets)
    rig = fake_rig(v, f)
    t = np.arange(frames)[:, None] / 60.0
    seq = rig.evaluate(0.5 + 0.5 * np.sin(2 * np.pi * np.linspace(1, 4, len(rig.names)) * t))
    yfov = np.pi / 8
    print(f"== 1. rasteriser, {frames} frames of a FLAME-size head (5023 vertices), CPU ms per view ==")
    for label, pose, size in (("whole head 256", front_camera(seq, yfov), 256), ("face 512", face_camera(v, yfov), 512),
                              ("profile 512", face_camera(v, yfov, side=True), 512)):
        renderer = SoftwareRenderer(f, pose, yfov, size, size)
        renderer.render(seq[0])
        t0 = time.process_time()
        new = np.stack([renderer.render(x).copy() for x in seq])
        t_new = (time.process_time() - t0) / frames * 1e3
        t0 = time.process_time()
        old = np.stack([reference_rasterize(x, f, pose, yfov, size, size) for x in seq])
        t_old = (time.process_time() - t0) / frames * 1e3
        diff = np.abs(new.astype(int) - old.astype(int))
        print(f"{label:15s} former {t_old:6.1f} ms  new {t_new:5.1f} ms  x{t_old / t_new:4.1f}  "
              f"largest pixel difference {diff.max()} ({(diff.max(axis=-1) > 0).mean():.1e} of pixels differ)")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", help="BlendVOCA build (default: the bundled default)")
    parser.add_argument("--subject", help="subject to cut the clips from (default: the first)")
    parser.add_argument("--old-commit", default=OLD_COMMIT, help="commit of the old path (default: %(default).12s)")
    parser.add_argument("--backends", default="auto,software", help="backends timed old against new (default: %(default)s)")
    parser.add_argument("--quick", action="store_true", help="leave out the old path")
    parser.add_argument("--frames", type=int, default=20, help="frames of the rasteriser comparison (part 1)")
    parser.add_argument("--jobs", type=int, help="--jobs of the new path (default: its own)")
    args = parser.parse_args(argv)

    from benchmark.protocol import default_data_root

    data = Path(args.data) if args.data else default_data_root()
    cpus = len(os.sched_getaffinity(0))
    load = os.getloadavg()[0]
    print(f"machine: {cpus} CPUs, load average {load:.1f} at the start; numpy {np.__version__}")
    rasteriser_part(args.frames)

    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    with tempfile.TemporaryDirectory(prefix="bench-render-") as tmp:
        tmp = Path(tmp)
        rig, clips = make_clips(data, args.subject, tmp, [5.0, 15.0])
        print(f"clips: {rig.stem}, 5 s and 15 s of its sentences end to end ({data})")

        def command(seconds, backend, out, new=True):
            csv, wav = clips[seconds]
            cmd = [sys.executable, "-m", "benchmark.render", "--coeffs", str(csv), "--rig", str(rig), "--audio",
                   str(wav), "--side", "--out", str(out)]
            if backend != "auto":
                cmd += ["--backend", backend]
            if new and args.jobs:
                cmd += ["--jobs", str(args.jobs)]
            return cmd

        results = {}
        print("== 2. the README command on the 5 s clip: old path against new ==")
        if not args.quick:
            old = old_tree(args.old_commit, tmp / "old")
        for backend in args.backends.split(","):
            new_out = tmp / f"new-{backend}.mp4"
            new = run_render(command(5.0, backend, new_out), ROOT, env)
            results[("new", backend)] = new
            line = f"{backend:8s} new {new['wall']:6.1f} s wall, {new['cpu']:6.1f} s CPU, peak {new['peak'] / 2**20:6.0f} MiB"
            if not args.quick:
                old_out = tmp / f"old-{backend}.mp4"
                was = run_render(command(5.0, backend, old_out, new=False), old, env)
                line += (f" | old {was['wall']:6.1f} s wall, {was['cpu']:6.1f} s CPU, peak {was['peak'] / 2**20:6.0f} MiB"
                         f" | {was['wall'] / new['wall']:4.1f}x faster (wall), {was['cpu'] / new['cpu']:4.1f}x less CPU")
                if backend == "software":
                    from benchmark.render.video import read_video

                    a, b = read_video(new_out)[0], read_video(old_out)[0]
                    same = a.shape == b.shape
                    line += (f" | decoded frames {'identical' if same and np.array_equal(a, b) else 'differ'}"
                             + (f" (largest difference {np.abs(a.astype(int) - b.astype(int)).max()})" if same else ""))
            print(line, flush=True)
        print("== 3. peak memory of the new path (process tree: render + ffmpeg + workers) ==")
        first = args.backends.split(",")[0]
        five = results[("new", first)]
        fifteen = run_render(command(15.0, first, tmp / "new15.mp4"), ROOT, env)
        for seconds, r in ((5, five), (15, fifteen)):
            print(f"{seconds:2d} s clip: peak {r['peak'] / 2**20:6.0f} MiB over {r['processes']} processes, "
                  f"{r['wall']:6.1f} s wall; {r['out']}")
        print(f"15 s / 5 s peak memory: {fifteen['peak'] / five['peak']:.2f} (acceptance: at most 1.2)")
    print(f"load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
