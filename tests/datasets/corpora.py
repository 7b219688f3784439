"""Small corpora written in the layouts the coefficient adapters read (docs/datasets.md).

Each writer returns the weights it wrote as ARKit-order tracks, so tests can compare
the build's files with what went in. Motion is smooth and speech-like (jawOpen and a
few mouth shapes follow a slow envelope); the audio is a tone whose loudness follows
the same envelope, at 16 kHz, as long as the motion.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blendvoca.io.audio import write_wav
from blendvoca.names import ARKIT_FACE_ORDER, convention_names

RATE = 16000


def motion(frames: int, fps: float, names, seed: int) -> np.ndarray:
    """``(frames, len(names))`` weights in [0, 1]: a slow envelope on the mouth shapes, small noise elsewhere."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    envelope = 0.5 + 0.4 * np.sin(2 * np.pi * (1.5 + 0.3 * rng.random()) * t)
    out = 0.05 * rng.random((frames, len(names)))
    for k, name in enumerate(names):
        if name in ("jawOpen", "mouthFunnel", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthClose"):
            out[:, k] = envelope * (0.6 + 0.4 * rng.random())
    return np.clip(out, 0.0, 1.0)


def speech(seconds: float, seed: int) -> np.ndarray:
    """``(N,)`` float32 audio at 16 kHz."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * RATE))) / RATE
    return (0.3 * np.sin(2 * np.pi * 180 * t) * (0.5 + 0.5 * np.sin(2 * np.pi * 1.7 * t))
            + 0.01 * rng.standard_normal(len(t))).astype(np.float32)


def write_beat(root: Path, speakers=(("1", "wayne"), ("2", "scott"), ("3", "solomon")), takes: int = 2,
               seconds: float = 2.5) -> dict:
    """BEAT's layout: ``<root>/<id>/<id>_<name>_0_<k>_<k>.json`` (names, frames of time/weights) and ``.wav``.

    The JSON lists the 52 ARKit shapes in Live Link's order (not ARKit's): the
    adapter must map them by name. Returns ``{(subject, take): (T, 52) ARKit-order weights}``.
    """
    names = convention_names("livelink")
    written = {}
    for s, (sid, speaker) in enumerate(speakers):
        folder = root / sid
        folder.mkdir(parents=True, exist_ok=True)
        for k in range(1, takes + 1):
            take = f"{sid}_{speaker}_0_{k}_{k}"
            frames = int(round(seconds * 60))
            weights = motion(frames, 60.0, names, seed=100 * s + k)
            doc = {"names": list(names),
                   "frames": [{"time": round(t / 60.0, 6), "rotation": [0.0, 0.0, 0.0], "weights": row.tolist()}
                              for t, row in enumerate(weights)]}
            (folder / f"{take}.json").write_text(json.dumps(doc))
            write_wav(folder / f"{take}.wav", speech(seconds, seed=100 * s + k), RATE)
            (folder / f"{take}.TextGrid").write_text("not read\n")
            written[(f"{sid}_{speaker}", take)] = weights[:, [names.index(n) for n in ARKIT_FACE_ORDER]]
    return written


def write_unitalker_layout(root: Path, *, annot_type: str, convention: str, fps: float = 30.0,
                           speakers=("spk_a", "spk_b", "spk_c", "spk_d"), takes: int = 2, seconds: float = 2.5,
                           split_by_speaker: bool = True, npy_audio: bool = False) -> dict:
    """UniTalker's layout: ``train.json``/``val.json``/``test.json`` naming ``(T, K)`` .npy weights and audio.

    With ``split_by_speaker`` each speaker's takes are in one split (the last two
    speakers in val and test); otherwise every speaker has a take in each split.
    Returns ``{(subject, take name): (T, K) weights in the convention's order}``.
    """
    names = convention_names(convention)
    root.mkdir(parents=True, exist_ok=True)
    (root / "annot").mkdir(exist_ok=True)
    (root / "audio").mkdir(exist_ok=True)
    splits = {"train": [], "val": [], "test": []}
    written = {}
    for s, speaker in enumerate(speakers):
        for k in range(takes):
            name = f"{speaker}_{k:03d}"
            frames = int(round(seconds * fps))
            weights = motion(frames, fps, names, seed=10 * s + k)
            np.save(root / "annot" / f"{name}.npy", weights.astype(np.float32))
            samples = speech(seconds, seed=10 * s + k)
            if npy_audio:
                np.save(root / "audio" / f"{name}.npy", samples)
                audio = f"audio/{name}.npy"
            else:
                write_wav(root / "audio" / f"{name}.wav", samples, RATE)
                audio = f"audio/{name}.wav"
            if split_by_speaker:
                split = "test" if s == len(speakers) - 1 else "val" if s == len(speakers) - 2 else "train"
            else:
                split = ("train", "val", "test")[k % 3]
            splits[split].append({"annot_path": f"annot/{name}.npy", "audio_path": audio, "id": s,
                                  "annot_type": annot_type, "dataset": "DX", "fps": fps})
            written[(speaker, f"annot/{name}")] = weights.astype(np.float32).astype(np.float64)
    for split, items in splits.items():
        doc = {"info": {"id_list": list(speakers)}, "data": items}
        (root / f"{split}.json").write_text(json.dumps(doc))
    np.save(root / "id_template.npy", np.zeros((len(speakers), len(names)), dtype=np.float32))
    return written


def write_facegood(root: Path, takes=("1114_2_01", "1114_2_02", "1114_2_03", "1114_2_04", "1114_2_05",
                                      "1114_3_15", "1114_3_16"), seconds: float = 14.0, seed: int = 0) -> dict:
    """FACEGOOD's layout: ``bs_value_<take>.npy`` ((T, 116) controls at 30 fps in [0, 1]), ``<take>.wav``
    (16 kHz) and ``bs_names_1015.npy`` (the 116 names, in FACEGOOD's order, as a Python 3 array).

    Each take is sentences of syllables (noise bursts) with a 0.7 s pause every ~4.5 s; the
    jaw controls (``mouth_stretch_c``, ``mouth_oh_c``) and the lips follow the syllables, left
    and right alike. Returns ``{take: (T, 116) values}``.
    """
    from blendvoca.names import FACEGOOD116

    root.mkdir(parents=True, exist_ok=True)
    np.save(root / "bs_names_1015.npy", np.array(FACEGOOD116))
    index = {n: k for k, n in enumerate(FACEGOOD116)}
    written = {}
    for number, take in enumerate(takes):
        rng = np.random.default_rng([seed, number])
        frames = int(round(seconds * 30))
        samples = 1e-4 * rng.standard_normal(int(round(seconds * RATE)))
        values = np.zeros((frames, len(FACEGOOD116)))
        t = 0.5
        while t < seconds - 0.8:
            sentence_end = min(t + rng.uniform(3.5, 5.0), seconds - 0.8)
            while t < sentence_end:
                length = rng.uniform(0.2, 0.35)
                a, b = int(t * RATE), int((t + length) * RATE)
                samples[a:b] += 0.3 * rng.standard_normal(b - a) * np.hanning(b - a)
                fa, fb = int(t * 30), int(np.ceil((t + length) * 30))
                shape = np.sin(np.linspace(0, np.pi, fb - fa))
                values[fa:fb, index["mouth_stretch_c"]] = rng.uniform(0.3, 0.8) * shape
                values[fa:fb, index["mouth_oh_c"]] = rng.uniform(0.0, 0.6) * shape
                for side in ("l", "r"):
                    values[fa:fb, index[f"mouth_lowerLipDepress_{side}"]] = 0.3 * shape
                for quarter in ("ul", "ur", "dl", "dr"):
                    values[fa:fb, index[f"mouth_funnel_{quarter}"]] = 0.4 * shape
                t += length + rng.uniform(0.05, 0.12)
            t += 0.7
        np.save(root / f"bs_value_{take}.npy", np.clip(values, 0.0, 1.0))
        write_wav(root / f"{take}.wav", samples.astype(np.float32), RATE)
        written[take] = np.clip(values, 0.0, 1.0)
    return written
