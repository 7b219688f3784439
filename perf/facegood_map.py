"""The measurements behind FACEGOOD's map onto ARKit (blendvoca.names.FACEGOOD_TO_ARKIT).

    python perf/facegood_map.py [--root DIR]

DIR is FACEGOOD's layout (``bs_value_<take>.npy``, ``<take>.wav``, ``bs_names_1015.npy``);
default: the seven takes through the asset resolver (``BLENDVOCA_ASSETS`` naming
``shared/realdata``). Printed, as markdown tables for docs/results/datasets-measurements.md:

1. per take, the controls that move (largest value >= 0.01);
2. left/right symmetry: Pearson r of each moving ``_l``/``_r`` pair over all frames, and
   the largest difference;
3. the speech envelope (``benchmark.lipsync.envelope.speech_envelope``: log RMS energy at
   the 30 fps frame times) against candidate jawOpen formulas, mouth_stretch_c + w *
   mouth_oh_c clipped to [0, 1] for w in 0, 0.25, 0.5, 0.75, 1, and max(stretch, oh):
   r at lag 0 per take and its mean, and the best lag within +-3 frames;
4. the same correlation for every mapped ARKit shape that moves (the map as the build
   applies it), to show which shapes follow the speech.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmark.lipsync.envelope import speech_envelope  # noqa: E402
from blendvoca.datasets.facegood import FPS, NAMES_FILE, VALUES_FILE, read_names, resolved_root  # noqa: E402
from blendvoca.io.audio import load_audio  # noqa: E402
from blendvoca.names import controls_to_arkit  # noqa: E402

MOVES = 0.01
WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)


def pearson(a, b) -> float:
    """Pearson r, nan when either is constant."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.std() == 0 or b.std() == 0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])


def lagged(a, b, lag: int) -> float:
    """r of ``a`` delayed by ``lag`` frames against ``b`` (positive: ``a`` after ``b``)."""
    if lag >= 0:
        return pearson(a[lag:], b[: len(b) - lag])
    return pearson(a[:lag], b[-lag:])


def best_lag(a, b, reach: int = 3) -> tuple[float, int]:
    return max((lagged(a, b, k), k) for k in range(-reach, reach + 1))


def takes(root: Path):
    """``[(take, values (T, 116), envelope (T,))]`` of ``root``, in name order."""
    found = []
    for path in sorted(p for p in root.iterdir() if VALUES_FILE.match(p.name)):
        take = VALUES_FILE.match(path.name).group("take")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            values = np.load(path)
        samples = load_audio(root / f"{take}.wav", rate=16000)
        frames = min(len(values), int(len(samples) / 16000 * FPS))
        found.append((take, values[:frames], speech_envelope(samples, 16000, FPS, num_frames=frames)))
    return found


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    p.add_argument("--root", default=None, help="FACEGOOD's layout (default: through the asset resolver)")
    args = p.parse_args(argv)
    root = Path(args.root) if args.root else resolved_root()
    names = read_names(root / NAMES_FILE)
    index = {n: k for k, n in enumerate(names)}
    data = takes(root)
    print(f"FACEGOOD takes at {root}: {len(data)}, {sum(len(v) for _, v, _ in data)} frames at {FPS:g} fps\n")

    print("## Controls that move (largest value >= 0.01)\n")
    print("| take | frames | moving | controls |\n|---|---|---|---|")
    every = np.concatenate([v for _, v, _ in data])
    for take, values, _ in data:
        moving = [n for n in names if values[:, index[n]].max() >= MOVES]
        print(f"| {take} | {len(values)} | {len(moving)} | {', '.join(moving)} |")
    moving_all = [n for n in names if every[:, index[n]].max() >= MOVES]
    print(f"\nIn all takes: {len(moving_all)} of {len(names)}; range of every value "
          f"[{every.min():.3g}, {every.max():.3g}]\n")

    print("## Left/right symmetry of the moving pairs (all frames)\n")
    print("| pair | r | largest difference |\n|---|---|---|")
    for name in moving_all:
        if name.endswith("_l") and name[:-2] + "_r" in index:
            right = every[:, index[name[:-2] + "_r"]]
            left = every[:, index[name]]
            print(f"| {name[:-2]}_l/_r | {pearson(left, right):.4f} | {np.abs(left - right).max():.3f} |")

    print("\n## jawOpen candidates against the speech envelope (r at lag 0; best lag within +-3 frames)\n")
    header = " | ".join(take for take, _, _ in data)
    print(f"| jawOpen | {header} | mean r | best lags |\n|---|" + "---|" * (len(data) + 2))
    candidates = {f"stretch_c + {w:g} oh_c": w for w in WEIGHTS}
    candidates["max(stretch_c, oh_c)"] = None
    for label, w in candidates.items():
        rs, lags = [], []
        for _, values, envelope in data:
            stretch, oh = values[:, index["mouth_stretch_c"]], values[:, index["mouth_oh_c"]]
            jaw = np.maximum(stretch, oh) if w is None else np.clip(stretch + w * oh, 0.0, 1.0)
            rs.append(lagged(jaw, envelope, 0))
            lags.append(best_lag(jaw, envelope)[1])
        print(f"| {label} | " + " | ".join(f"{r:.3f}" for r in rs) + f" | {np.nanmean(rs):.3f} | "
              f"{', '.join(str(k) for k in lags)} |")
    oh_only = [lagged(v[:, index["mouth_oh_c"]], e, 0) for _, v, e in data]
    print(f"| oh_c alone | " + " | ".join(f"{r:.3f}" for r in oh_only) + f" | {np.nanmean(oh_only):.3f} | |")
    together = pearson(every[:, index["mouth_stretch_c"]], every[:, index["mouth_oh_c"]])
    over = np.mean(every[:, index["mouth_stretch_c"]] + 0.25 * every[:, index["mouth_oh_c"]] > 1)
    print(f"\nr(stretch_c, oh_c) over all frames {together:.3f}; stretch_c + 0.25 oh_c exceeds 1 (clipped) on "
          f"{100 * over:.2f} % of frames\n")

    print("## Mapped ARKit shapes against the speech envelope (r at lag 0 over each take, mean; moving shapes)\n")
    print("| ARKit shape | mean r | takes where it moves |\n|---|---|---|")
    mapped = [(take, *controls_to_arkit(values, names, "facegood116"), envelope) for take, values, envelope in data]
    for shape in mapped[0][2]:
        rs = [lagged(track[:, arkit.index(shape)], env, 0) for _, track, arkit, env in mapped
              if track[:, arkit.index(shape)].max() >= MOVES]
        if rs:
            print(f"| {shape} | {np.nanmean(rs):.3f} | {len(rs)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
