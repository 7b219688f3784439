"""The synthetic VOCASET corpus: speakers, sentences, audio, motion, ground truth, files.

``generate_corpus`` writes a corpus in the official VOCASET layout (or the
processed one) plus a ground-truth sidecar, so that the real VOCASET readers,
the BlendVOCA build and the benchmark run on it exactly as on VOCASET. Every
item is drawn from its own random stream (``default_rng([seed, kind, speaker,
sentence])``), so the corpus is deterministic for a seed and a bigger corpus
contains the smaller ones as a prefix.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from blendvoca.errors import UserError
from blendvoca.io.atomic import permissions_for
from blendvoca.synthetic.audio import speech_audio
from blendvoca.synthetic.groundtruth import write_npz
from blendvoca.synthetic.headpose import apply_pose, head_motion as draw_head_motion
from blendvoca.synthetic.identity import speaker_neutral, speaker_profile
from blendvoca.synthetic.motion import animate_face
from blendvoca.synthetic.plan import sentence_plan
from blendvoca.synthetic.regions import face_regions
from blendvoca.synthetic.signals import FPS, SIGNAL_NAMES, motion_signals
from blendvoca.vocaset.splits import proportional_split
from blendvoca.vocaset.write import OfficialWriter, ProcessedWriter, quantize_pcm16

GENERATOR_VERSION = "1"
DEFAULT_CORPUS = dict(speakers=6, sentences=4, seed=0, duration=(3.0, 5.0))

# Stream ids of the per-item random generators.
_SPEAKER, _SENTENCE, _LENGTH, _HEAD = 0, 1, 2, 3

#: Where the head turns, relative to the jaw hinge (metres): the top of the neck.
_NECK_FROM_HINGE = np.array([0.0, -0.05, -0.02])


def speaker_name(index: int) -> str:
    """VOCASET-shaped but clearly synthetic: ``Synth_000_TA``."""
    return f"Synth_{index:03d}_TA"


def sentence_name(index: int) -> str:
    """``sentence01`` for index 0."""
    return f"sentence{index + 1:02d}"


def sentence_lengths(speakers: int, sentences: int, seed: int, duration: tuple[float, float]) -> np.ndarray:
    """Frame counts ``(speakers, sentences) int64`` at 60 fps, uniform in ``duration`` seconds."""
    lo, hi = duration
    if not 0.8 <= lo <= hi:
        raise UserError(f"duration must be (low, high) seconds with 0.8 <= low <= high, got {duration!r}")
    out = np.empty((speakers, sentences), dtype=np.int64)
    for i in range(speakers):
        for j in range(sentences):
            out[i, j] = int(round(np.random.default_rng([seed, _LENGTH, i, j]).uniform(lo, hi) * FPS))
    return out


def synthesize_sentence(neutral, regions, profile, num_frames: int, rng: np.random.Generator, *,
                        rate: int = 22000, max_lag_frames: int = 2) -> dict:
    """One sentence of one speaker: audio, motion and the driving signals.

    Parameters
    ----------
    neutral : (V, 3) ndarray
    regions : FaceRegions
    profile : dict
        From ``speaker_profile``.
    num_frames : int
        T at 60 fps; the audio lasts exactly ``T / 60`` s.
    rng : numpy.random.Generator
    rate : int
        Audio sample rate.
    max_lag_frames : int
        The true lag is uniform in ``[-max_lag_frames, max_lag_frames]`` frames.

    Returns
    -------
    dict
        ``frames (T, V, 3)``, ``audio (N,) float32`` (exactly representable as
        16-bit PCM), ``lag_frames``, ``plan``, ``signals`` (dict of (T,) arrays).
    """
    plan = sentence_plan(rng, num_frames / FPS, speaking_rate=profile["speaking_rate"])
    lag = int(rng.integers(-max_lag_frames, max_lag_frames + 1))
    signals = motion_signals(plan, num_frames, rng, lag_frames=lag, profile=profile)
    frames = animate_face(neutral, regions, signals)
    audio = speech_audio(plan, rng, rate=rate, f0=profile["f0"], formant_scale=profile["formant_scale"])
    audio = quantize_pcm16(audio).astype(np.float32) / np.float32(32768.0)
    return {"frames": frames, "audio": audio, "lag_frames": lag, "plan": plan, "signals": signals}


def _groundtruth_arrays(item: dict) -> dict[str, np.ndarray]:
    plan = item["plan"]
    arrays = {k: np.asarray(item["signals"][k], dtype=np.float64) for k in (*SIGNAL_NAMES, "envelope")}
    arrays.update(
        lag_frames=np.int64(item["lag_frames"]),
        fps=np.int64(FPS),
        phones=np.array(plan.phones, dtype="<U1"),
        phone_starts=plan.starts,
        phone_ends=plan.ends,
        syllables=plan.syllables,
        stress=plan.stress,
    )
    return arrays


def _write_corpus(out: Path, *, speakers: int, sentences: int, seed: int, layout: str,
                  duration: tuple[float, float], rate: int, max_lag_frames: int, frame_faces: bool,
                  head_motion: float, progress: bool) -> None:
    from tqdm.auto import tqdm

    from blendvoca.assets import load_index_list, resolve
    from blendvoca.io.mesh import read_ply

    template, faces = read_ply(resolve("flame-sample"))
    landmarks = load_index_list("flame-landmarks")
    lengths = sentence_lengths(speakers, sentences, seed, duration)
    if layout == "official":
        writer = OfficialWriter(out, frame_faces=frame_faces, num_vertices=len(template))
    elif layout == "processed":
        writer = ProcessedWriter(out, int(lengths.sum()), num_vertices=len(template))
    else:
        raise UserError(f"generate_corpus: layout must be 'official' or 'processed', got {layout!r}")
    if head_motion and layout != "official":
        raise UserError("generate_corpus: head motion is written as VOCASET's posed data (registereddata/), "
                         f"which only the official layout has; got layout {layout!r}")
    names = [speaker_name(i) for i in range(speakers)]
    meta = {
        "generator": "blendvoca.synthetic",
        "version": GENERATOR_VERSION,
        "seed": seed,
        "layout": layout,
        "fps": FPS,
        "sample_rate": rate,
        "duration_range": list(duration),
        "max_lag_frames": max_lag_frames,
        "lag_convention": "motion frame t shows the articulation of audio time (t - lag_frames) / fps; "
                          "positive lag: the face moves after the sound",
        "splits": proportional_split(names),
        "subjects": {},
    }
    if head_motion:
        meta["head_motion"] = {"max_angle_deg": head_motion, "max_translation_m": 0.003,
                               "posed_frames": "registereddata/<subject>/<sentence>/<sentence>.NNNNNN.ply",
                               "convention": "posed = unposed @ head_rotations[t].T + head_translations[t] "
                                             "(groundtruth npz, metres)"}
    bar = tqdm(total=speakers * sentences, desc="synthetic VOCASET", unit="sentence", disable=not progress)
    for i, subject in enumerate(names):
        rng = np.random.default_rng([seed, _SPEAKER, i])
        neutral = speaker_neutral(template, rng)
        profile = speaker_profile(rng)
        regions = face_regions(neutral, faces, landmarks)
        writer.add_template(subject, neutral, faces)
        items = {}
        for j in range(sentences):
            sentence = sentence_name(j)
            item = synthesize_sentence(neutral, regions, profile, int(lengths[i, j]),
                                       np.random.default_rng([seed, _SENTENCE, i, j]),
                                       rate=rate, max_lag_frames=max_lag_frames)
            writer.add_sentence(subject, sentence, item["frames"], item["audio"], rate)
            arrays = _groundtruth_arrays(item)
            if head_motion:
                rotations, translations = draw_head_motion(
                    int(lengths[i, j]), regions.hinge + _NECK_FROM_HINGE,
                    np.random.default_rng([seed, _HEAD, i, j]), max_angle_deg=head_motion)
                writer.add_posed_sentence(subject, sentence, apply_pose(item["frames"], rotations, translations))
                arrays.update(head_rotations=rotations, head_translations=translations)
            write_npz(out / "groundtruth" / subject / f"{sentence}.npz", arrays)
            items[sentence] = {
                "num_frames": int(lengths[i, j]),
                "duration": int(lengths[i, j]) / FPS,
                "lag_frames": item["lag_frames"],
                "lag_seconds": item["lag_frames"] / FPS,
                "num_syllables": item["plan"].num_syllables,
            }
            bar.update()
        meta["subjects"][subject] = {"profile": profile, "sentences": items}
    bar.close()
    writer.finish()
    (out / "synthetic.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n", encoding="utf-8")


def generate_corpus(
    out,
    *,
    speakers: int = DEFAULT_CORPUS["speakers"],
    sentences: int = DEFAULT_CORPUS["sentences"],
    seed: int = DEFAULT_CORPUS["seed"],
    layout: str = "official",
    duration: tuple[float, float] = DEFAULT_CORPUS["duration"],
    rate: int = 22000,
    max_lag_frames: int = 2,
    frame_faces: bool = False,
    head_motion: bool | float = False,
    overwrite: bool = False,
    progress: bool = True,
) -> Path:
    """Generate a synthetic VOCASET corpus in ``out``.

    The corpus is built in a temporary folder beside ``out`` and renamed into
    place, so ``out`` is either absent or complete.

    Parameters
    ----------
    out : path
        Target folder; must not exist (or be empty) unless ``overwrite``.
    speakers : int
        Number of speakers (>= 3 for a train/val/test split; 12 is VOCASET's).
    sentences : int
        Sentences per speaker (VOCASET: 40).
    seed : int
        Everything is a function of the seed.
    layout : {"official", "processed"}
        Per-frame PLY folders like the download, or data_verts.npy + pickles.
    duration : (low, high)
        Sentence length range in seconds (uniform), realistic is 3-5 s.
    rate : int
        Audio sample rate (VOCASET: 22 kHz).
    max_lag_frames : int
        Range of the true audio-motion lag per sentence, in 60 fps frames.
    frame_faces : bool
        Official layout: store triangles in every frame PLY (3x the size).
    head_motion : bool or float
        Also write the frames with a smooth rigid head motion under
        ``registereddata/`` (VOCASET's posed data; official layout only), the
        pose in the ground truth (``head_rotations (T, 3, 3)``,
        ``head_translations (T, 3)``). True: peaks up to 3 degrees and 3 mm per
        axis; a number: that many degrees. The unposed frames are unchanged.
    overwrite : bool
        Replace an existing ``out``.
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    Path
        ``out``, holding the layout plus ``synthetic.json`` and
        ``groundtruth/<subject>/<sentence>.npz``.
    """
    out = Path(out).expanduser()
    if not isinstance(speakers, (int, np.integer)) or speakers < 3:
        raise UserError(f"generate_corpus: speakers must be an integer >= 3 (train/val/test), got {speakers!r}")
    if not isinstance(sentences, (int, np.integer)) or not 1 <= sentences <= 99:
        raise UserError(f"generate_corpus: sentences must be an integer in [1, 99], got {sentences!r}")
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise FileExistsError(f"generate_corpus: {out} exists and is not empty; pass overwrite=True (--overwrite)")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.tmp-"))
    try:
        _write_corpus(tmp, speakers=int(speakers), sentences=int(sentences), seed=int(seed), layout=layout,
                      duration=(float(duration[0]), float(duration[1])), rate=int(rate),
                      max_lag_frames=int(max_lag_frames), frame_faces=frame_faces,
                      head_motion=_head_motion_degrees(head_motion), progress=progress)
        os.chmod(tmp, permissions_for(out, directory=True))
        if out.exists():
            shutil.rmtree(out)
        os.rename(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def _head_motion_degrees(head_motion) -> float:
    if head_motion is True:
        return 3.0
    if head_motion is False or head_motion is None:
        return 0.0
    if isinstance(head_motion, (int, float, np.integer, np.floating)) and 0 < float(head_motion) <= 30:
        return float(head_motion)
    raise UserError(f"generate_corpus: head_motion must be True/False or a peak angle in (0, 30] degrees, "
                     f"got {head_motion!r}")


def default_corpus(cache_dir=None, *, progress: bool = True) -> Path:
    """The bundled default corpus (official layout), generated once into the user cache.

    Parameters
    ----------
    cache_dir : path, optional
        Defaults to ``blendvoca.assets.cache_dir()`` (``$BLENDVOCA_CACHE`` or
        ``$XDG_CACHE_HOME/blendvoca`` or ``~/.cache/blendvoca``).

    Returns
    -------
    Path
        ``<cache>/synthetic-default-v<GENERATOR_VERSION>``; reused when present.
    """
    if cache_dir is None:
        from blendvoca.assets import cache_dir as user_cache

        cache_dir = user_cache()
    root = Path(cache_dir).expanduser() / f"synthetic-default-v{GENERATOR_VERSION}"
    if (root / "synthetic.json").is_file():
        return root
    try:
        return generate_corpus(root, overwrite=True, progress=progress, **DEFAULT_CORPUS)
    except OSError:
        # Another process finished the same corpus first: theirs is identical.
        if (root / "synthetic.json").is_file():
            return root
        raise
