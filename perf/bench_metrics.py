"""Time the metric layer and the renderers.

    BLENDVOCA_ASSETS=../shared/assets python perf/bench_metrics.py [--frames 60]

Prints (1) the time of ``evaluate_split`` over a fabricated test split (2 speakers
x 5 sentences, 3 samples each, FLAME-size rigs) split into its latent, vertex and
lip-sync parts, (2) the Frechet distance against a scipy ``sqrtm`` reference in
the same process, and (3) rendering ms/frame of the numpy rasteriser and of
pyrender/EGL (one renderer per sequence) at 224 x 224, with their ratio.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def timed(fn, *args, repeat: int = 1, **kwargs):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*args, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=60, help="frames rendered per backend")
    parser.add_argument("--assets", default=os.environ.get("BLENDVOCA_ASSETS", "../shared/assets"))
    args = parser.parse_args(argv)
    assets = Path(args.assets)

    from scipy import linalg

    from benchmark.data import open_blendvoca
    from benchmark.evaluation import EvaluationSettings, latent_metrics, lipsync_metrics, vertex_metrics
    from benchmark.features import load_published_vae
    from benchmark.metrics import feature_statistics, frechet_distance
    from benchmark.render import render_sequence
    from tests.benchmark.fakes import flame_head, make_dataset

    print("== metrics over a fabricated test split ==")
    with tempfile.TemporaryDirectory() as tmp:
        root = make_dataset(Path(tmp), assets, subjects=("T0", "T1", "T2", "T3"), sentences=5,
                            frames=(240, 300), seed=0)
        ds = open_blendvoca(root)
        test = [(s, n) for s in ds.split("test") for n in ds.sentences(s)]
        gt = {k: ds.coeffs(*k) for k in test}
        rng = np.random.default_rng(0)
        gen = {k: np.clip(v[None] + rng.normal(scale=0.05, size=(3, *v.shape)), 0, 1) for k, v in gt.items()}
        vae = load_published_vae(assets / "said" / "vae.pth")
        rigs = {s: ds.rig(s) for s in ds.split("test")}
        audio = {k: ds.audio(*k) for k in test}
        latent_metrics(gt, gen, vae, EvaluationSettings(wind_repeats=1))  # warm-up: imports, allocator
        t_lat, _ = timed(latent_metrics, gt, gen, vae, EvaluationSettings(wind_repeats=10))
        t_vert, _ = timed(vertex_metrics, gt, gen, rigs, ds.names)
        t_sync, _ = timed(lipsync_metrics, gen, rigs, audio, ds.names)
        frames = sum(v.shape[0] * v.shape[1] for v in gen.values())
        print(f"{len(test)} sentences x 3 samples, {frames} generated frames")
        print(f"latent (VAE + FD + WInD x10 + multimodality): {t_lat:.2f} s")
        print(f"vertex (LVE, MVE, FDD, APD/UPD/LPD/MPD):      {t_vert:.2f} s")
        print(f"lip sync (geometric):                          {t_sync:.2f} s")
        print(f"total:                                         {t_lat + t_vert + t_sync:.2f} s")

    print("== Frechet distance, 64-d, 5000 vs 5000 features ==")
    x = rng.normal(size=(5000, 64)) @ rng.normal(size=(64, 64))
    y = rng.normal(size=(5000, 64)) @ rng.normal(size=(64, 64))

    def reference(x, y):
        (m1, s1), (m2, s2) = feature_statistics(x), feature_statistics(y)
        covmean = linalg.sqrtm(s1 @ s2).real
        return float((m1 - m2) @ (m1 - m2) + np.trace(s1 + s2 - 2 * covmean))

    t_ours, v_ours = timed(frechet_distance, x, y, repeat=3)
    t_ref, v_ref = timed(reference, x, y, repeat=3)
    print(f"ours {t_ours * 1e3:.1f} ms, scipy sqrtm reference {t_ref * 1e3:.1f} ms, ratio {t_ours / t_ref:.2f}, "
          f"relative difference {abs(v_ours - v_ref) / abs(v_ref):.1e}")

    print(f"== rendering, FLAME head (5023 v), 224 x 224, {args.frames} frames ==")
    v, f = flame_head(assets)
    seq = v[None] + np.linspace(0, 0.01, args.frames)[:, None, None] * np.array([0, 1, 0])
    t_soft, _ = timed(render_sequence, seq, f, size=224, backend="software")
    print(f"software rasteriser: {t_soft / args.frames * 1e3:.1f} ms/frame")
    try:
        t_gl, _ = timed(render_sequence, seq, f, size=224, backend="pyrender")
        print(f"pyrender (EGL):      {t_gl / args.frames * 1e3:.1f} ms/frame (incl. context creation)")
        print(f"software / pyrender: {t_soft / t_gl:.2f}")
    except Exception as err:  # noqa: BLE001
        print(f"pyrender unavailable: {err}")


if __name__ == "__main__":
    main()
