"""The methods on real speech: each trained checkpoint animates recorded WAVs; frames and a table.

Issue 53's deliverable 5. Every method's checkpoint (trained with ``python -m benchmark.run
--method NAME --data BUILD --checkpoint DIR``, e.g. on the FACEGOOD build's training takes)
animates each WAV through the one command a user has, ``python -m benchmark.generate``; the
tracks are drawn through the ARKit reference rig (vertex methods' meshes as they are) at a
few instants of each WAV, one row per method, and each is measured against its speech:
the mouth opening's correlation with the speech envelope at the geometric estimator's lag,
that lag (frames, positive: the motion after the audio) and its confidence, and the mean
mouth opening against the ground truth's over the build's test split.

::

    python perf/real_speech_methods.py --data BUILD --checkpoints DIR \\
        [--methods regression,said,...] [--audio WAV ...] [--out docs/img/real-speech-methods.png]

``DIR/ckpt-<method>`` holds each method's checkpoint. Without ``--audio`` the WAVs are the
VOCASET sentence of ``../shared/realdata`` and the three speech assets (asset ids, through
the resolver). Prints a markdown table (for ``docs/results/``) and writes the figure.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmark.data import open_blendvoca  # noqa: E402
from benchmark.lipsync import geometric_sync, mouth_activity  # noqa: E402
from benchmark.render import render_sequence  # noqa: E402
from benchmark.render.camera import face_camera  # noqa: E402
from blendvoca.assets import resolve  # noqa: E402
from blendvoca.io.audio import load_audio  # noqa: E402
from blendvoca.io.coeffs import read_coeffs_csv  # noqa: E402
from blendvoca.names import BLENDVOCA_NAMES  # noqa: E402
from blendvoca.rig_regions import lip_vertices  # noqa: E402
from blendvoca.runtime.progress import set_progress  # noqa: E402

#: (asset id, label) of the default WAVs: real speech of other speakers and languages than FACEGOOD's.
DEFAULT_AUDIO = (("vocaset-facetalk-170725-00137-ta-sentence01-wav", "VOCASET 00137 s01 (English)"),
                 ("speech-voca", "VOCA test sentence (English)"),
                 ("speech-faceformer", "FaceFormer demo (English)"),
                 ("speech-codetalker", "CodeTalker demo (English)"))
DEFAULT_METHODS = ("regression", "said", "faceformer", "codetalker", "cdface")
INSTANTS = 6


def generated_vertices(method: str, checkpoint: Path, data: Path, wav: Path, rig, work: Path) -> np.ndarray:
    """``(T, V, 3)`` of ``method`` animating ``wav`` through ``benchmark.generate`` (coefficients through ``rig``)."""
    vertex = method in ("faceformer", "codetalker", "cdface")
    out = work / f"{method}-{wav.stem}.{'npy' if vertex else 'csv'}"
    subprocess.run([sys.executable, "-m", "benchmark.generate", "--method", method, "--checkpoint", str(checkpoint),
                    "--data", str(data), "--audio", str(wav), "--out", str(out), "--quiet"], check=True, cwd=ROOT,
                   stdout=subprocess.DEVNULL)
    if vertex:
        return np.asarray(np.load(out), dtype=np.float64)[0]
    coeffs, _ = read_coeffs_csv(out, BLENDVOCA_NAMES)
    return rig.neutral[None] + np.einsum("tk,kvd->tvd", coeffs, rig.deltas)


def sync_row(vertices, neutral, lips, samples) -> tuple[float, int, float, float]:
    """(mean mouth opening, lag, confidence, envelope correlation at that lag) of a track and its speech."""
    activity = mouth_activity(vertices, neutral, lips)
    estimate = geometric_sync(activity, samples)
    lag = int(estimate.offset)
    scores = np.asarray(estimate.scores)
    return float(np.mean(activity)), lag, float(estimate.confidence), float(scores.max())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, required=True)
    p.add_argument("--checkpoints", type=Path, required=True)
    p.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    p.add_argument("--audio", type=Path, action="append", default=None)
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "img" / "real-speech-methods.png")
    p.add_argument("--size", type=int, default=160)
    args = p.parse_args(argv)
    set_progress(False)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dataset = open_blendvoca(args.data)
    subject = dataset.split("train")[0] if dataset.split("train") else dataset.subjects[0]
    rig = dataset.rig(subject).select(BLENDVOCA_NAMES)  # the columns of every track
    neutral = np.asarray(rig.neutral, dtype=np.float64)
    lips = lip_vertices(rig.deltas, rig.names)
    camera = face_camera(neutral)  # one camera for every row
    audio = ([(path, path.stem) for path in args.audio] if args.audio
             else [(resolve(asset), label) for asset, label in DEFAULT_AUDIO])
    methods = [m for m in args.methods.split(",") if (args.checkpoints / f"ckpt-{m}").exists()]
    truth = [mouth_activity(rig.neutral[None] + np.einsum("tk,kvd->tvd", dataset.coeffs(s, t), rig.deltas),
                            neutral, lips).mean() for s in dataset.split("test") for t in dataset.sentences(s)]
    print(f"ground truth (test split, {len(truth)} utterances): mean mouth opening {np.mean(truth) * 1000:.2f} mm\n")
    print("| method | speech | mean opening (mm) | lag (frames) | confidence | envelope r at lag |")
    print("|---|---|---:|---:|---:|---:|")
    wav = audio[0]
    frames = {}
    with tempfile.TemporaryDirectory() as tmp:
        for method in methods:
            for path, label in audio:
                vertices = generated_vertices(method, args.checkpoints / f"ckpt-{method}", args.data, Path(path),
                                              rig, Path(tmp))
                samples = load_audio(path, rate=16000)
                if vertices.shape[1] != len(neutral):
                    print(f"| {method} | {label} | (its own topology, {vertices.shape[1]} vertices) | | | |")
                    continue
                opening, lag, confidence, r = sync_row(vertices, neutral, lips, samples)
                print(f"| {method} | {label} | {opening * 1000:.2f} | {lag:+d} | {confidence:.2f} | {r:.2f} |")
                if (path, label) == wav:
                    picks = np.linspace(0, len(vertices) - 1, INSTANTS + 2)[1:-1].astype(int)
                    frames[method] = (render_sequence(vertices[picks], rig.faces, size=args.size, pose=camera), picks)
    fig, axes = plt.subplots(len(frames), INSTANTS, figsize=(1.6 * INSTANTS, 1.75 * len(frames)), squeeze=False)
    for row, (method, (images, picks)) in enumerate(frames.items()):
        for col in range(INSTANTS):
            ax = axes[row, col]
            ax.imshow(images[col])
            ax.set_xticks([]), ax.set_yticks([])
            if row == 0:
                ax.set_title(f"{picks[col] / 60:.2f} s", fontsize=8)
            if col == 0:
                ax.set_ylabel(method, fontsize=9)
    fig.suptitle(f"Trained on FACEGOOD's training takes, animating {wav[1]}", fontsize=9)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=100)
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
