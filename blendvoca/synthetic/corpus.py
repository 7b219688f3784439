"""The synthetic VOCASET corpus: speakers, sentences, audio, motion, ground truth, files.

``generate_corpus`` writes a corpus in the official VOCASET layout (or the
processed one) plus a ground-truth sidecar, so that the real VOCASET readers,
the BlendVOCA build and the benchmark run on it exactly as on VOCASET. Every
item is drawn from its own random stream (``default_rng([seed, kind, speaker,
sentence])``), so the corpus is deterministic for a seed and a bigger corpus
contains the smaller ones as a prefix.

With ``audio_determined < 1`` the motion gains components that the audio and
the speaker id do not determine (:mod:`blendvoca.synthetic.variation`, each on
its own stream); with ``oracle_samples K`` the corpus also holds K conditional
samples of every sentence's motion (``oracle/<subject>/<sentence>.npz``: fresh
draws of everything the inputs do not fix, same plan and audio), as driving
signals that :mod:`blendvoca.synthetic.oracle` turns into meshes.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np

from blendvoca.assets import cache_dir as user_cache, load_index_list, resolve
from blendvoca.errors import UserError
from blendvoca.io.mesh import read_ply
from blendvoca.runtime.progress import bar
from blendvoca.runtime.staging import staged_folder
from blendvoca.synthetic import variation as var
from blendvoca.synthetic.audio import speech_audio
from blendvoca.synthetic.groundtruth import write_npz
from blendvoca.synthetic.headpose import apply_pose, head_motion as draw_head_motion
from blendvoca.synthetic.identity import speaker_neutral, speaker_profile
from blendvoca.synthetic.motion import animate_face
from blendvoca.synthetic.plan import sentence_plan
from blendvoca.synthetic.regions import face_regions
from blendvoca.synthetic.signals import FPS, SIGNAL_NAMES, VARIED_SIGNAL_NAMES, motion_signals
from blendvoca.vocaset.processed import POSED_FILE
from blendvoca.vocaset.splits import proportional_split
from blendvoca.vocaset.write import OfficialWriter, ProcessedWriter, quantize_pcm16

#: The generator's version, written to ``synthetic.json``. A corpus made with
#: ``audio_determined=1`` and no oracle samples is version 1's corpus bit for bit
#: and says ``"1"``.
GENERATOR_VERSION = "2"
#: ``--audio-determined`` default: the share of lip-motion variance that speech
#: acoustics predict in published audio-visual recordings (docs/synthetic.md).
DEFAULT_AUDIO_DETERMINED = 0.7
#: The bundled default corpus (``default_corpus``). It keeps ``audio_determined=1`` (version
#: 1's corpus bit for bit) so that its build keeps the dataset hash the committed
#: leaderboard's bundled-default section was scored on; it moves to the default share
#: together with the board's regeneration.
DEFAULT_CORPUS = dict(speakers=6, sentences=4, seed=0, duration=(3.0, 5.0), audio_determined=1.0)

# Stream ids of the per-item random generators (4 is blendvoca.synthetic.variation's).
_SPEAKER, _SENTENCE, _LENGTH, _HEAD = 0, 1, 2, 3
#: The oracle samples of a sentence, relative to the corpus root (``<subject>/<sentence>.npz``).
ORACLE_DIR = "oracle"
#: The driving signals of the speech shapes (what the measured share is taken over).
SPEECH_SIGNALS = ("jaw", "round", "closure", "labiodental", "smile", "corner_left", "corner_right", "press")

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
                        rate: int = 22000, max_lag_frames: int = 2, variation=None, asymmetry: float = 0.0) -> dict:
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
    variation : callable, optional
        ``variation(plan) -> SentenceVariation``: the undetermined components of
        this draw (:mod:`blendvoca.synthetic.variation`). None: the old model.
    asymmetry : float
        The speaker's lip asymmetry (``animate_face``).

    Returns
    -------
    dict
        ``frames (T, V, 3)``, ``audio (N,) float32`` (exactly representable as
        16-bit PCM), ``lag_frames``, ``plan``, ``signals`` (dict of (T,) arrays),
        ``variation`` (None without one).
    """
    plan = sentence_plan(rng, num_frames / FPS, speaking_rate=profile["speaking_rate"])
    lag = int(rng.integers(-max_lag_frames, max_lag_frames + 1))
    drawn = None if variation is None else variation(plan)
    signals = motion_signals(plan, num_frames, rng, lag_frames=lag, profile=profile, variation=drawn)
    frames = animate_face(neutral, regions, signals) if drawn is None else \
        animate_face(neutral, regions, signals, asymmetry=asymmetry)
    audio = speech_audio(plan, rng, rate=rate, f0=profile["f0"], formant_scale=profile["formant_scale"])
    audio = quantize_pcm16(audio).astype(np.float32) / np.float32(32768.0)
    return {"frames": frames, "audio": audio, "lag_frames": lag, "plan": plan, "signals": signals,
            "variation": drawn}


def oracle_draw(plan, num_frames: int, profile: dict, *, seed: int, speaker: int, sentence: int, sample: int,
                style: dict | None, scale: float, max_lag_frames: int = 2) -> dict:
    """One conditional sample of a sentence's motion signals: same plan (and audio), fresh draws of
    everything the inputs do not fix, each from its component's stream (``sample`` >= 1).

    Returns
    -------
    dict
        ``lag_frames``, ``signals`` (dict of (T,) arrays), ``variation`` (None when ``style`` is None).
    """
    rng = var.component_rng(seed, "resample", speaker, sentence, sample)
    lag = int(rng.integers(-max_lag_frames, max_lag_frames + 1))
    drawn = None if style is None else var.sentence_variation(seed, speaker, sentence, sample, plan, num_frames,
                                                               style, scale)
    signals = motion_signals(plan, num_frames, rng, lag_frames=lag, profile=profile, variation=drawn)
    return {"lag_frames": lag, "signals": signals, "variation": drawn}


def _signal_names(item: dict) -> tuple[str, ...]:
    return SIGNAL_NAMES if item["variation"] is None else VARIED_SIGNAL_NAMES


def _groundtruth_arrays(item: dict) -> dict[str, np.ndarray]:
    plan = item["plan"]
    arrays = {k: np.asarray(item["signals"][k], dtype=np.float64) for k in (*_signal_names(item), "envelope")}
    if item["variation"] is not None:
        arrays.update(item["variation"].arrays)
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


def _truth_variation(seed, speaker, sentence, plan, *, num_frames, style, scale):
    return var.sentence_variation(seed, speaker, sentence, var.TRUTH, plan, num_frames, style, scale)


def _stack_draws(draws: list[dict], names: tuple[str, ...], head: list | None) -> dict[str, np.ndarray]:
    """The oracle samples of one sentence as arrays with a leading sample axis (gestures: a sample column)."""
    arrays = {k: np.stack([np.asarray(d["signals"][k], dtype=np.float64) for d in draws]) for k in names}
    arrays["lag_frames"] = np.array([d["lag_frames"] for d in draws], dtype=np.int64)
    if draws and draws[0]["variation"] is not None:
        for key in draws[0]["variation"].arrays:
            if key == "pause_gestures":
                rows = [np.column_stack([np.full(len(d["variation"].gestures), k, dtype=np.float64),
                                         d["variation"].gestures]) for k, d in enumerate(draws)]
                arrays[key] = np.concatenate(rows).reshape(-1, 5)
            else:
                arrays[key] = np.stack([np.asarray(d["variation"].arrays[key], dtype=np.float64) for d in draws])
    if head:
        arrays["head_rotations"] = np.stack([r for r, _ in head])
        arrays["head_translations"] = np.stack([t for _, t in head])
    return arrays


class _ShareMeter:
    """The share of a speaker's speech-signal variance that the conditional mean explains, from the
    ground truth and the oracle samples of every sentence: 1 - pooled within-sentence variance /
    pooled within-speaker variance (as the build measures it on the fitted coefficients)."""

    def __init__(self):
        self.within, self.truth = 0.0, {}

    def add(self, speaker: int, truth: dict, draws: list[dict]) -> None:
        names = [k for k in SPEECH_SIGNALS if k in truth]
        stack = np.stack([np.stack([truth[k] for k in names], axis=1)]
                         + [np.stack([d["signals"][k] for k in names], axis=1) for d in draws])
        self.within += float(stack.var(axis=0, ddof=1).sum())
        self.truth.setdefault(speaker, []).append(stack[0])

    def share(self) -> float | None:
        per_speaker = [np.concatenate(tracks) for tracks in self.truth.values()]
        total = sum(float(((y - y.mean(axis=0)) ** 2).sum()) for y in per_speaker)
        return 1.0 - self.within / total if total > 0 else None


def _write_corpus(out: Path, *, speakers: int, sentences: int, seed: int, layout: str,
                  duration: tuple[float, float], rate: int, max_lag_frames: int, frame_faces: bool,
                  head_motion: float, audio_determined: float = 1.0,
                  oracle_samples: int = 0, scale: float | None = None) -> dict:
    template, faces = read_ply(resolve("flame-sample"))
    landmarks = load_index_list("flame-landmarks")
    lengths = sentence_lengths(speakers, sentences, seed, duration)
    varied = audio_determined < 1.0 or scale is not None
    if scale is None:
        scale = var.undetermined_scale(audio_determined) if varied else 0.0
    if layout == "official":
        writer = OfficialWriter(out, frame_faces=frame_faces, num_vertices=len(template))
    elif layout == "processed":
        writer = ProcessedWriter(out, int(lengths.sum()), num_vertices=len(template))
    else:
        raise UserError(f"generate_corpus: layout must be 'official' or 'processed', got {layout!r}")
    names = [speaker_name(i) for i in range(speakers)]
    meta = {
        "generator": "blendvoca.synthetic",
        "version": GENERATOR_VERSION if varied or oracle_samples else "1",
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
    if varied:
        meta["audio_determined"] = var.settings(audio_determined, scale)
    if oracle_samples:
        meta["oracle_samples"] = {
            "count": oracle_samples,
            "files": f"{ORACLE_DIR}/<subject>/<sentence>.npz",
            "what": "conditional samples of the motion given the audio and the speaker: the same plan and audio, "
                    "fresh draws of the lag, the articulatory jitter, blinks, brows and every undetermined "
                    "component (sample k uses spawn key sample = k + 1); arrays with a leading sample axis "
                    "(pause_gestures: a leading sample column); meshes: blendvoca.synthetic.oracle",
        }
    if head_motion:
        where = ("registereddata/<subject>/<sentence>/<sentence>.NNNNNN.ply" if layout == "official" else
                 f"{POSED_FILE} (rows as data_verts.npy, indexed by subj_seq_to_idx.pkl)")
        meta["head_motion"] = {"max_angle_deg": head_motion, "max_translation_m": 0.003,
                               "posed_frames": where,
                               "convention": "posed = unposed @ head_rotations[t].T + head_translations[t] "
                                             "(groundtruth npz, metres)"}
    meter = _ShareMeter() if oracle_samples else None
    sentences_bar = bar(total=speakers * sentences, desc="synthetic VOCASET", unit="sentence")
    for i, subject in enumerate(names):
        rng = np.random.default_rng([seed, _SPEAKER, i])
        neutral = speaker_neutral(template, rng)
        profile = speaker_profile(rng)
        regions = face_regions(neutral, faces, landmarks)
        style = var.speaker_style(seed, i) if varied else None
        writer.add_template(subject, neutral, faces)
        items = {}
        for j in range(sentences):
            sentence = sentence_name(j)
            num_frames = int(lengths[i, j])
            # the ground truth's undetermined components: a function of the plan drawn inside
            drawn = functools.partial(_truth_variation, seed, i, j, num_frames=num_frames, style=style,
                                      scale=scale) if varied else None
            item = synthesize_sentence(neutral, regions, profile, num_frames,
                                       np.random.default_rng([seed, _SENTENCE, i, j]),
                                       rate=rate, max_lag_frames=max_lag_frames, variation=drawn,
                                       asymmetry=style["asymmetry"] if varied else 0.0)
            writer.add_sentence(subject, sentence, item["frames"], item["audio"], rate)
            arrays = _groundtruth_arrays(item)
            pivot = regions.hinge + _NECK_FROM_HINGE
            if head_motion:
                rotations, translations = draw_head_motion(
                    num_frames, pivot, np.random.default_rng([seed, _HEAD, i, j]), max_angle_deg=head_motion)
                writer.add_posed_sentence(subject, sentence, apply_pose(item["frames"], rotations, translations))
                arrays.update(head_rotations=rotations, head_translations=translations)
            write_npz(out / "groundtruth" / subject / f"{sentence}.npz", arrays)
            if oracle_samples:
                draws = [oracle_draw(item["plan"], num_frames, profile, seed=seed, speaker=i, sentence=j,
                                     sample=k + 1, style=style, scale=scale, max_lag_frames=max_lag_frames)
                         for k in range(oracle_samples)]
                head = [draw_head_motion(num_frames, pivot, var.component_rng(seed, "head", i, j, k + 1),
                                         max_angle_deg=head_motion) for k in range(oracle_samples)] \
                    if head_motion else None
                write_npz(out / ORACLE_DIR / subject / f"{sentence}.npz",
                          _stack_draws(draws, _signal_names(item), head))
                meter.add(i, item["signals"], draws)
            items[sentence] = {
                "num_frames": num_frames,
                "duration": num_frames / FPS,
                "lag_frames": item["lag_frames"],
                "lag_seconds": item["lag_frames"] / FPS,
                "num_syllables": item["plan"].num_syllables,
            }
            sentences_bar.update()
        meta["subjects"][subject] = {"profile": profile, "sentences": items}
        if varied:
            meta["subjects"][subject]["style"] = style
    sentences_bar.close()
    writer.finish()
    summary = {"audio_determined": audio_determined, "scale": scale, "measured_signal_share": None}
    if meter is not None:
        summary["measured_signal_share"] = meter.share()
        meta["oracle_samples"]["measured_signal_share"] = summary["measured_signal_share"]
        meta["oracle_samples"]["measured_over"] = list(SPEECH_SIGNALS)
    (out / "synthetic.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return summary


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
    audio_determined: float = DEFAULT_AUDIO_DETERMINED,
    oracle_samples: int = 0,
    _scale: float | None = None,
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
        Also write the frames with a smooth rigid head motion: under
        ``registereddata/`` (VOCASET's posed data) in the official layout, in
        ``data_verts_posed.npy`` (rows as ``data_verts.npy``'s) in the processed
        one; the pose in the ground truth (``head_rotations (T, 3, 3)``,
        ``head_translations (T, 3)``). True: peaks up to 3 degrees and 3 mm per
        axis; a number: that many degrees. The unposed frames are unchanged.
    overwrite : bool
        Replace an existing ``out``.
    audio_determined : float
        F in (0, 1]: the share of the speech shapes' coefficient variance that
        the audio and the speaker id determine (default 0.7, docs/synthetic.md).
        Below 1 the motion gets speaker styles, intensity drift, gesture onset
        jitter and pause gestures (:mod:`blendvoca.synthetic.variation`); 1 is
        the corpus without them (generator version 1's, bit for bit).
    oracle_samples : int
        K >= 0 conditional samples of every sentence's motion, written as
        driving signals to ``oracle/<subject>/<sentence>.npz``
        (:mod:`blendvoca.synthetic.oracle` renders them; the build fits them).
    _scale : float, optional
        Calibration only (:mod:`blendvoca.synthetic.calibrate`): the components'
        scale itself instead of the one ``audio_determined`` maps to.

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
    if isinstance(oracle_samples, bool) or not isinstance(oracle_samples, (int, np.integer)) \
            or not 0 <= oracle_samples <= 1000:
        raise UserError(f"generate_corpus: oracle_samples must be an integer in [0, 1000], got {oracle_samples!r}")
    if isinstance(audio_determined, bool) or not isinstance(audio_determined, (int, float, np.integer, np.floating)):
        raise UserError(f"generate_corpus: audio_determined must be a number in (0, 1], got {audio_determined!r}")
    if float(audio_determined) < 1.0:
        var.undetermined_scale(audio_determined)  # refuses an F it cannot make, before anything is written
    elif float(audio_determined) != 1.0:
        raise UserError(f"audio_determined: expected 0 < F <= 1, got {audio_determined!r}")
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise FileExistsError(f"generate_corpus: {out} exists and is not empty; pass overwrite=True (--overwrite)")
    with staged_folder(out, replace=True) as tmp:
        _write_corpus(tmp, speakers=int(speakers), sentences=int(sentences), seed=int(seed), layout=layout,
                      duration=(float(duration[0]), float(duration[1])), rate=int(rate),
                      max_lag_frames=int(max_lag_frames), frame_faces=frame_faces,
                      head_motion=_head_motion_degrees(head_motion),
                      audio_determined=float(audio_determined), oracle_samples=int(oracle_samples),
                      scale=None if _scale is None else float(_scale))
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


def default_corpus(cache_dir=None) -> Path:
    """The bundled default corpus (official layout), generated once into the user cache.

    Parameters
    ----------
    cache_dir : path, optional
        Defaults to ``blendvoca.assets.cache_dir()`` (``$BLENDVOCA_CACHE`` or
        ``$XDG_CACHE_HOME/blendvoca`` or ``~/.cache/blendvoca``).

    Returns
    -------
    Path
        ``<cache>/synthetic-default-v<version>`` (``v1`` while the default keeps
        ``audio_determined=1``); reused when present.
    """
    if cache_dir is None:
        cache_dir = user_cache()
    version = GENERATOR_VERSION if DEFAULT_CORPUS.get("audio_determined", 1.0) < 1.0 else "1"
    root = Path(cache_dir).expanduser() / f"synthetic-default-v{version}"
    if (root / "synthetic.json").is_file():
        return root
    try:
        return generate_corpus(root, overwrite=True, **DEFAULT_CORPUS)
    except OSError:
        # Another process finished the same corpus first: theirs is identical.
        if (root / "synthetic.json").is_file():
            return root
        raise
