"""The stimuli of a study: the rows' stored runs, the sentences chosen, the clips rendered,
the sound check.

Every clip is drawn by the project's renderer (:func:`benchmark.render.stream.render_video`)
with one head per speaker (its rig's neutral mesh and faces), one camera
(:func:`benchmark.render.face_camera` of that neutral), the renderer's lighting, one size
and frame rate, no labels and no waveform, and the sentence's audio muxed (H.264 yuv420p +
AAC in MP4). A clip lasts as long as its audio, cut at ``max_seconds``: every clip of a
sentence has the same duration. Coefficient rows are drawn through the speaker's rig;
vertex rows (``method.output == "vertices"``) with their own stored vertices on the rig's faces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError

#: Frame rate of the stored tracks (SAiD's layout).
TRACK_FPS = 60.0
#: Audio rate of the clips.
RATE = 16000


@dataclass
class Row:
    """A studied row: its name on the command line, its result file and stored run."""

    name: str
    json_path: Path
    run: object  # benchmark.runs.StoredRun
    vertices: bool
    label: str
    stochastic: bool
    dataset_root: Path
    samples_of: dict = field(default_factory=dict)

    def num_samples(self, subject: str, sentence: str) -> int:
        key = (subject, sentence)
        if key not in self.samples_of:
            if self.vertices:
                with np.load(_vertices_file(self.run, subject, sentence)) as data:
                    self.samples_of[key] = int(data["offsets"].shape[0])
            else:
                self.samples_of[key] = len(self.run.track_paths(subject, sentence))
        return self.samples_of[key]

    def record(self) -> dict:
        from benchmark.study.design import sha256_of

        result = self.run.result
        return {"result": str(self.json_path.resolve()), "result_sha256": sha256_of(self.json_path),
                "recipe_id": result.dataset.key, "label": self.label, "method": result.method.name,
                "output": "vertices" if self.vertices else "coefficients", "stochastic": self.stochastic}


def _vertices_file(run, subject, sentence):
    from benchmark.runs import vertices_path

    return vertices_path(run.tracks_dir, subject, sentence)


def _result_files(results: Path) -> list[Path]:
    return sorted(p for p in results.glob("*.json") if p.is_file())


def find_rows(results, names, data=None) -> list[Row]:
    """The rows named on the command line, each from one result file of ``results`` whose
    file name (without ``.json``), label or method name is the name; checked: tracks stored,
    one build (``dataset.recipe_id``) for all."""
    from benchmark.results import read
    from benchmark.runs import read_run

    results = Path(results)
    if not results.is_dir():
        raise UserError(f"--results {results}: no such folder (expected the folder of the rows' result files)")
    if len(set(names)) != len(names):
        raise UserError(f"--rows names a row twice: {','.join(names)}")
    readable = []
    for path in _result_files(results):
        try:
            readable.append((path, read(path)))
        except (DataError, UserError, ValueError, OSError):
            continue  # not a result file: not a row
    rows = []
    for name in names:
        matches = [(p, r) for p, r in readable if name in (p.stem, r.label, r.method.name)]
        if not matches:
            known = sorted({r.label for _, r in readable})
            raise UserError(f"--rows {name}: no result file in {results} is named, labelled or of method {name!r}; "
                            f"the folder has rows {', '.join(known) if known else '(none: no result files)'}")
        exact = [(p, r) for p, r in matches if p.stem == name]
        if len(matches) > 1 and not exact:
            raise UserError(f"--rows {name}: {len(matches)} result files match "
                            f"({', '.join(p.name for p, _ in matches)}); name one by its file name without .json")
        path, result = (exact or matches)[0]
        if not result.tracks:
            raise UserError(f"--rows {name}: {path} holds scores only, no stored tracks (no 'tracks' key); recreate "
                            f"them with python -m benchmark.run --method {result.method.name} --results DIR (or, for "
                            "the committed board, python -m leaderboard.reproduce --work W --results DIR --only "
                            f"{result.method.name}) and pass that DIR")
        try:
            run = read_run(path)
        except FileNotFoundError as error:
            raise UserError(f"--rows {name}: {error}; recreate the tracks with python -m benchmark.run --method "
                            f"{result.method.name} --results {results}") from None
        root = Path(data) if data else Path(result.dataset.path or "")
        if not root.is_absolute():
            root = (path.parent / root).resolve()
        vertices = result.method.output == "vertices" and run.has_vertices()
        rows.append(Row(name, path, run, vertices, result.label, bool(result.method.stochastic), root))
    builds = {row.run.result.dataset.key for row in rows}
    if len(builds) > 1:
        listing = "; ".join(f"{row.name}: {row.run.result.dataset.key[:12]}" for row in rows)
        raise UserError(f"--rows were scored on different builds (dataset.recipe_id differs: {listing}); a study "
                        "compares rows on the same sentences of one build")
    return rows


def candidate_sentences(rows: list[Row]) -> list[tuple[str, str]]:
    """``(subject, sentence)`` that every row stored and whose audio, ground truth and rig exist."""
    from blendvoca.format import audio_path, coeffs_path, rig_path

    common = None
    for row in rows:
        if row.vertices:
            from benchmark.runs import StoredVertices

            keys = set(StoredVertices(row.run.tracks_dir))
        else:
            keys = set(row.run.keys)
        common = keys if common is None else common & keys
    root = rows[0].dataset_root
    found = [(s, q) for s, q in sorted(common or ())
             if audio_path(root, s, q).is_file() and coeffs_path(root, s, q).is_file() and rig_path(root, s).is_file()]
    if not found:
        raise UserError(f"the rows {', '.join(r.name for r in rows)} have no stored sentence in common whose audio, "
                        f"ground truth and rig are in the build {root} (dataset.path of {rows[0].json_path.name}; "
                        "pass --data BUILD where the build has moved)")
    return found


def choose_sentences(candidates, count: int, rng: np.random.Generator) -> list[tuple[str, str]]:
    """``count`` sentences balanced over speakers: speakers in a seeded order take turns, each
    giving its sentences in a seeded order. Asking for more than there are is refused."""
    if count < 1:
        raise UserError(f"--sentences must be at least 1, got {count}")
    if count > len(candidates):
        raise UserError(f"--sentences {count}: the rows share only {len(candidates)} sentences with audio in the build")
    return round_robin(candidates, rng)[:count]


def round_robin(candidates, rng: np.random.Generator) -> list[tuple[str, str]]:
    """All ``candidates`` in the speakers-take-turns order of :func:`choose_sentences`."""
    by_subject: dict[str, list[str]] = {}
    for subject, sentence in candidates:
        by_subject.setdefault(subject, []).append(sentence)
    subjects = [sorted(by_subject)[i] for i in rng.permutation(len(by_subject))]
    queues = {s: [by_subject[s][i] for i in rng.permutation(len(by_subject[s]))] for s in subjects}
    order = []
    while any(queues.values()):
        for s in subjects:
            if queues[s]:
                order.append((s, queues[s].pop(0)))
    return order


def samples_shown(num_samples: int, wanted: int, index: int, offset: int) -> tuple[int, ...]:
    """The samples of a row a clip shows: ``wanted`` consecutive samples (cyclically) from
    ``offset + index * wanted``, so that over the sentences each of a stylised or stochastic
    row's samples (styles) is shown about equally often; a deterministic row shows its one."""
    wanted = max(1, min(wanted, num_samples))
    start = (offset + index * wanted) % num_samples
    return tuple(sorted((start + k) % num_samples for k in range(wanted)))


class Head:
    """One speaker's head: rig, faces and camera, shared by every row's clip of the speaker."""

    def __init__(self, root: Path, subject: str):
        from benchmark.render import face_camera
        from blendvoca.format import rig_path
        from blendvoca.rig import Rig

        path = rig_path(root, subject)
        if not path.is_file():
            raise DataError(f"the rig of {subject} is missing: {path}")
        self.rig = Rig.load(path)
        self.faces = self.rig.faces
        self.yfov = np.pi / 8
        self.pose = face_camera(np.asarray(self.rig.neutral), self.yfov)


def sentence_audio(root: Path, subject: str, sentence: str, max_seconds: float | None) -> np.ndarray:
    """The sentence's audio at :data:`RATE`, cut at ``max_seconds``."""
    from blendvoca.format import audio_path
    from blendvoca.io.audio import load_audio

    audio = load_audio(audio_path(root, subject, sentence), rate=RATE)
    if max_seconds:
        audio = audio[: int(round(max_seconds * RATE))]
    return audio


def coefficient_source(coeffs, head: Head):
    from benchmark.render.sources import RigSource

    return RigSource(np.asarray(coeffs, dtype=np.float64), head.rig)


def row_sources(row: Row, subject: str, sentence: str, samples, head: Head) -> list:
    """Frame sources (at 60 fps) of ``samples`` of ``row`` on the sentence."""
    from benchmark.render.sources import ArraySource
    from blendvoca.io.coeffs import read_coeffs_csv

    if row.vertices:
        vertices = row.run.vertices(subject, sentence)
        if vertices.shape[2] != len(head.rig.neutral):
            raise DataError(f"row {row.name}: {subject}/{sentence} has {vertices.shape[2]} vertices, the speaker's "
                            f"rig {len(head.rig.neutral)}: a vertex row is drawn on its speaker's head, which needs "
                            "the same topology")
        return [ArraySource(vertices[k]) for k in samples]
    paths = row.run.track_paths(subject, sentence)
    return [coefficient_source(read_coeffs_csv(paths[k], names=head.rig.names, missing="zero")[0], head)
            for k in samples]


def ground_truth_source(root: Path, subject: str, sentence: str, head: Head):
    from blendvoca.format import coeffs_path
    from blendvoca.io.coeffs import read_coeffs_csv

    coeffs = read_coeffs_csv(coeffs_path(root, subject, sentence), names=head.rig.names, missing="zero")[0]
    return coefficient_source(coeffs, head)


def static_source(num_frames: int, head: Head):
    """The speaker's neutral face, motionless."""
    return coefficient_source(np.zeros((max(num_frames, 1), len(head.rig.names))), head)


@dataclass(frozen=True)
class Clip:
    frames: int
    width: int
    height: int
    seconds: float


def render_clip(out: Path, sources, head: Head, audio, *, size: int, fps: float, backend: str) -> Clip:
    """Render ``sources`` (60 fps) side by side to ``out`` with ``audio`` muxed; as long as the audio."""
    from benchmark.render.sources import resampled
    from benchmark.render.stream import Panel, render_video
    from blendvoca.runtime.progress import progress_bars

    panels = [Panel("", resampled(source, TRACK_FPS, fps), f"{out.name} panel {k}") for k, source in enumerate(sources)]
    drawn = out.with_name(f".{out.stem}.drawn.mp4")
    try:
        with progress_bars(False):
            frames, width, height = render_video(drawn, panels, head.faces, [head.pose], fps=fps, size=size,
                                                 backend=backend, yfov=head.yfov, audio=audio, rate=RATE,
                                                 waveform=False, jobs=1)
        faststart(drawn, out)
    finally:
        drawn.unlink(missing_ok=True)
    return Clip(frames, width, height, frames / fps)


def faststart(source: Path, out: Path) -> None:
    """Copy an MP4 with its index (``moov``) moved before the media, so that a browser starts
    playing it before the whole file has arrived (the streams are copied, not re-encoded)."""
    import subprocess

    import imageio_ffmpeg

    done = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i", str(source),
                           "-map", "0", "-c", "copy", "-movflags", "+faststart", "-f", "mp4", str(out)],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        out.unlink(missing_ok=True)
        raise DataError(f"ffmpeg could not write {out}: {done.stderr.strip().splitlines()[-1:] or done.returncode}")


# ---------------------------------------------------------------------------------------
# The sound check

#: Digit words accepted for a count.
NUMBER_WORDS = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine")


@dataclass(frozen=True)
class SoundClip:
    audio: np.ndarray
    answer: str
    accepted: tuple[str, ...]
    prompt: str
    source: str


def beeps(count: int, rate: int = RATE) -> np.ndarray:
    """``count`` 0.25 s tones of 660 Hz, 0.45 s apart, with 0.5 s of silence around them."""
    tone = np.sin(2 * np.pi * 660 * np.arange(int(0.25 * rate)) / rate)
    ramp = np.minimum(1, np.minimum(np.arange(len(tone)), np.arange(len(tone))[::-1]) / (0.01 * rate))
    gap = np.zeros(int(0.2 * rate))
    pad = np.zeros(int(0.5 * rate))
    parts = [pad]
    for k in range(count):
        parts += [0.5 * tone * ramp] + ([gap] if k < count - 1 else [])
    parts.append(pad)
    return np.concatenate(parts).astype(np.float32)


def counted_beeps(rng: np.random.Generator) -> SoundClip:
    """The fallback sound check: 3 to 7 beeps; the participant types how many."""
    count = int(rng.integers(3, 8))
    return SoundClip(beeps(count), str(count), (NUMBER_WORDS[count],),
                     "Turn your sound on and play the clip. How many beeps do you hear? Type the number.",
                     "generated: counted beeps (no recording with a known word was given)")


#: Words the default sound check speaks: common, two syllables, spelled as heard, no homophones.
SPOKEN_WORDS = ("apple", "garden", "yellow", "window", "rabbit", "pencil", "button", "candle",
                "monkey", "basket", "planet", "kitten")

#: The speech synthesiser of the default sound check (Debian package ``espeak-ng``).
ESPEAK = "espeak-ng"


def spoken_word(rng: np.random.Generator) -> SoundClip:
    """The default sound check: one of :data:`SPOKEN_WORDS`, spoken by ``espeak-ng`` (American
    English voice, 130 words per minute), with 0.5 s of silence around it; counted beeps
    (:func:`counted_beeps`, the source saying why) where the synthesiser is not installed.

    A synthesiser rather than a recording: the real recordings at hand come without their
    transcripts (docs/study.md, "The sound check"), and a word the participant must type is the
    check the papers' protocol asks for; a listener who cannot hear it cannot pass it."""
    import shutil
    import subprocess
    import tempfile

    from blendvoca.io.audio import load_audio

    word = SPOKEN_WORDS[int(rng.integers(len(SPOKEN_WORDS)))]
    if shutil.which(ESPEAK) is None:
        clip = counted_beeps(rng)
        return SoundClip(clip.audio, clip.answer, clip.accepted, clip.prompt,
                         f"generated: counted beeps ({ESPEAK} is not installed for a spoken word: "
                         f"apt-get install {ESPEAK})")
    with tempfile.TemporaryDirectory(prefix="blendvoca-word-") as tmp:
        wav = Path(tmp) / "word.wav"
        done = subprocess.run([ESPEAK, "-v", "en-us", "-s", "130", "-w", str(wav), word],
                              capture_output=True, text=True, check=False)
        if done.returncode != 0 or not wav.is_file():
            raise DataError(f"{ESPEAK} could not speak {word!r}: {done.stderr.strip() or done.returncode}")
        audio = load_audio(wav, rate=RATE)
    pad = np.zeros(int(0.5 * RATE), dtype=np.float32)
    audio = np.concatenate([pad, 0.9 * audio / max(float(np.abs(audio).max()), 1e-9), pad]).astype(np.float32)
    return SoundClip(audio, word, (), "Turn your sound on and play the clip. Type the word you hear.",
                     f"generated: {ESPEAK} -v en-us speaking {word!r}")


def recorded_word(source: str, answer: str, span: tuple[float, float] | None) -> SoundClip:
    """A spoken word: a WAV (or an asset id, resolved through ``BLENDVOCA_ASSETS``), cut to ``span`` seconds."""
    from blendvoca.io.audio import load_audio

    path = Path(source)
    where = source
    if not path.is_file():
        from blendvoca.assets import AssetError, UnknownAssetError, resolve

        try:
            path = resolve(source, download_missing=False)
        except UnknownAssetError:
            raise UserError(f"--sound-check {source}: neither a file nor an asset id of blendvoca/data_manifest.yaml")
        except AssetError as error:
            raise UserError(f"--sound-check {source}: {error}") from None
        where = f"asset {source}"
    if not answer or not answer.strip():
        raise UserError("--sound-check needs --sound-check-answer WORD (the word spoken in the clip)")
    audio = load_audio(path, rate=RATE)
    if span is not None:
        start, end = span
        if not 0 <= start < end:
            raise UserError(f"--sound-check-span {start},{end}: expected 0 <= START < END seconds")
        if end * RATE > len(audio) + 1:
            raise UserError(f"--sound-check-span {start},{end}: the recording lasts {len(audio) / RATE:.2f} s")
        audio = audio[int(start * RATE):int(end * RATE)]
        where += f" [{start:g} s, {end:g} s]"
    answer = " ".join(answer.strip().lower().split())
    return SoundClip(audio, answer, (), "Turn your sound on and play the clip. Type the word you hear.", where)


def write_sound_check(clip: SoundClip, out: Path) -> None:
    from blendvoca.io.audio import write_wav

    write_wav(out, clip.audio, RATE)
