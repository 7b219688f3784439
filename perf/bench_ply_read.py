"""Frames per second of reading VOCASET-layout PLY sequences.

Compares ``blendvoca.io.mesh.read_ply_sequence`` (the fast path the VOCASET
reader uses) with plain ``trimesh.load(path, process=False)`` in the same run,
on frames written like VOCASET's (binary little-endian, float32 vertices, with
faces by default). Prints frames/s of both and their ratio; checks that both
give the same vertices.

    python perf/bench_ply_read.py [--frames 240] [--repeats 3] [--no-faces] [--corpus DIR]

With ``--corpus`` it reads the sentences of an existing official-layout corpus
instead of writing a temporary one.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def _best_time(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _write_sequence(folder: Path, frames: int, with_faces: bool) -> list[Path]:
    from blendvoca.assets import resolve
    from blendvoca.io.mesh import read_ply
    from blendvoca.vocaset.write import OfficialWriter

    V, F = read_ply(resolve("flame-sample"))
    rng = np.random.default_rng(0)
    seq = V[None] + 0.001 * rng.standard_normal((frames, *V.shape))
    writer = OfficialWriter(folder, frame_faces=with_faces)
    writer.add_template("Bench_000_TA", V, F)
    writer.add_sentence("Bench_000_TA", "sentence01", seq, np.zeros(frames * 367, np.float32), 22000)
    return sorted((folder / "unposedcleaneddata" / "Bench_000_TA" / "sentence01").glob("*.ply"))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=240, help="frames of the generated sequence (4 s at 60 fps)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-faces", action="store_true", help="vertex-only frame files")
    parser.add_argument("--corpus", type=Path, help="read an existing official-layout corpus instead")
    args = parser.parse_args(argv)

    import trimesh

    from blendvoca.io.mesh import read_ply_sequence
    from blendvoca.vocaset.official import OfficialVocaset

    with tempfile.TemporaryDirectory() as tmp:
        if args.corpus:
            corpus = OfficialVocaset(args.corpus)
            sequences = [corpus.frame_paths(s, q) for s, q in corpus.items()]
        else:
            sequences = [_write_sequence(Path(tmp), args.frames, not args.no_faces)]
        n = sum(len(s) for s in sequences)

        def fast():
            return [read_ply_sequence(paths) for paths in sequences]

        def plain():
            return [np.stack([np.asarray(trimesh.load(p, process=False).vertices, dtype=np.float64) for p in paths])
                    for paths in sequences]

        same = all(np.array_equal(a, b) for a, b in zip(fast(), plain()))
        t_fast, t_plain = _best_time(fast, args.repeats), _best_time(plain, args.repeats)
    print(f"frames: {n} in {len(sequences)} sequence(s), faces in files: {not args.no_faces or bool(args.corpus)}")
    print(f"read_ply_sequence : {n / t_fast:9.0f} frames/s ({1e3 * t_fast / n:.3f} ms/frame)")
    print(f"trimesh.load      : {n / t_plain:9.0f} frames/s ({1e3 * t_plain / n:.3f} ms/frame)")
    print(f"speed-up          : {t_plain / t_fast:9.1f}x   identical vertices: {same}")
    print(f"VOCASET (~115k frames) at this rate: {115000 * t_fast / n:.0f} s vs {115000 * t_plain / n:.0f} s")


if __name__ == "__main__":
    main()
