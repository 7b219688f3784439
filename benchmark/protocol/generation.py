"""The protocol's second step: every sentence of the split asked of the method, each
answer checked against the contract (:mod:`benchmark.methods.contract`)."""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmark.methods import (
    AUDIO_RATE,
    FPS,
    OUTPUT_COEFFICIENTS,
    OUTPUT_KINDS,
    OUTPUT_VERTICES,
    Utterance,
    validated_tracks,
    validated_vertices,
)
from benchmark.protocol.isolation import plugin_call, warn_notes
from benchmark.protocol.limits import GenerateLimit, TimeLimit, generate_limit
from benchmark.protocol.lookahead import lookahead_probe
from benchmark.protocol.spec import LATENCY_SENTENCES
from benchmark.protocol.verification import reverified
from benchmark.results import LATENCY_FIELDS
from blendvoca.errors import (
    DataError,
    MethodError,
    MethodOutputError,
    MethodTimeout,
    UserError,
    out_of_resources,
    ran_out_of,
)
from blendvoca.runtime.progress import bar, progress_bars

__all__ = ["LATENCY_FIELDS", "Generated", "generate", "generated_tracks", "measure_latency",
           "motionless_sentences", "sentence_seed"]



@dataclass(frozen=True)
class Generated:
    """What a method generated for a split, checked.

    Attributes
    ----------
    tracks : dict
        ``{(subject, sentence): (S, T, K) float64 ndarray}`` in the split's order, ``T``
        the ground-truth frames; for ``output = "vertices"`` methods the tracks fitted
        to their vertices with the speaker's rig.
    n_clipped : int
        Values clipped into [0, 1] (``clip`` runs only).
    seconds : float
        Wall time of the generation.
    vertices : mapping or None
        A vertex method's own ``(S, T, V, 3)`` vertices per key (read back from the
        stored run, or kept in memory when nothing is stored); None for coefficient
        methods.
    latency : dict or None
        :func:`measure_latency`'s record (None when not measured).
    motionless : int
        Sentences whose every sample is constant over time (a face that never moves):
        their lip-sync offsets carry no information (:func:`motionless_sentences`).
    """

    tracks: dict
    n_clipped: int = 0
    seconds: float = 0.0
    vertices: object = None
    latency: dict | None = None
    motionless: int = 0


def motionless_sentences(tracks: dict) -> list:
    """``(subject, sentence)`` of the tracks ``{key: (S, T, K)}`` that do not move: every
    sample's every coefficient constant over time (within 1e-9)."""
    still = []
    for key, samples in tracks.items():
        samples = np.asarray(samples, dtype=np.float64)
        if samples.ndim == 3 and samples.shape[1] > 0 and float(np.ptp(samples, axis=1).max(initial=0.0)) <= 1e-9:
            still.append(key)
    return still


def generate(spec, dataset, trained, *, store=None) -> Generated:
    """Ask ``trained.method`` for every sentence of ``spec.split`` (:func:`generated_tracks`).

    Parameters
    ----------
    spec : RunSpec
    dataset : benchmark.data dataset
    trained : Trained
    store : benchmark.runs.TrackWriter, optional
        Receives every checked track (and a vertex method's own vertices).

    Returns
    -------
    Generated
    """
    vertex_method = trained.output == OUTPUT_VERTICES
    in_memory = {} if vertex_method and store is None else None
    results_dir = None if store is None else Path(store.folder).parent
    before = None if results_dir is None else _files_under(results_dir)
    start = time.perf_counter()
    tracks, n_clipped = generated_tracks(trained.method, dataset, split=spec.split, samples=spec.samples,
                                         seed=spec.seed, clip=spec.clip, name=spec.method,
                                         store=store, vertices_out=in_memory,
                                         time_limit=generate_limit(spec.generate_time_limit),
                                         sentence_batch=spec.sentence_batch)
    seconds = time.perf_counter() - start
    if store is not None:
        _check_results_kept(spec.method, results_dir, before, store, tracks)
    vertices = None
    if vertex_method:
        vertices = store.stored_vertices() if store is not None else in_memory
    # after the scored tracks are made, so that the extra calls cannot change them
    latency = measure_latency(trained.method, dataset, split=spec.split, seed=spec.seed, name=spec.method,
                              probe_times=getattr(spec, "lookahead_probes", None))
    reverified(spec, dataset, when="while the method generated")  # a plug-in that wrote into the build: exit 4
    # a face that never moves is scored as it is; the result says so (benchmark.run's summary too)
    still = motionless_sentences(tracks)
    return Generated(tracks=tracks, n_clipped=int(n_clipped), seconds=seconds, vertices=vertices, latency=latency,
                     motionless=len(still))


def _files_under(folder: Path) -> set:
    """The result files in ``folder`` (``*.json``): what other runs only ever replace
    atomically, never remove (their tracks folders and staging folders come and go)."""
    return {p.name for p in folder.glob("*.json") if not p.name.startswith(".")}


def _check_results_kept(name: str, results_dir: Path, before: set, store, tracks: dict) -> None:
    """MethodError when files under ``results_dir`` that were there before the method
    generated, or the tracks it stored since, are gone (a plug-in that deleted them)."""
    from benchmark.runs import track_path

    gone = sorted(before - _files_under(results_dir))
    staging = Path(getattr(store, "staging", store.folder))
    missing = [track_path(staging, subject, sentence, k).relative_to(results_dir).as_posix()
               for (subject, sentence), samples in tracks.items() for k in range(len(samples))
               if not track_path(staging, subject, sentence, k).is_file()]
    if gone or missing:
        lost = gone + missing
        shown = ", ".join(lost[:5]) + (f" and {len(lost) - 5} more" if len(lost) > 5 else "")
        raise MethodError(f"method {name!r}: {len(lost)} file(s) under --results {results_dir} were deleted while "
                          f"it generated ({shown}); nothing was stored, and the deleted files of earlier runs are "
                          "lost (restore them from a copy)")


def measure_latency(method, dataset, *, split: str = "test", seed: int = 0, name: str | None = None,
                    sentences: int = LATENCY_SENTENCES, probe_times=None) -> dict:
    """How long a method makes a listener wait, measured on the first ``sentences`` of ``split``.

    One sample per sentence (the stream a player would show), with the seed the run gives
    the sentence. ``lookahead_s`` is the method's own ``lookahead_s`` (seconds of audio
    after frame ``t`` that frame ``t`` needs, from its architecture and chunk plan; None
    when it does not say, i.e. it needs the whole utterance). ``first_frame_s`` is the
    wall time of generating the first chunk alone (the utterance's first
    ``lookahead_s`` seconds, or all of it), after which the first frame is final: a
    live stream shows it ``lookahead_s + first_frame_s`` after the speech began.
    ``compute_per_audio_s`` is the process's CPU time (every thread) per second of
    audio, ``rtf`` the wall time per second of audio (the real-time factor: below 1 is
    faster than the speech), both over whole sentences. Figures depend on the machine
    (the result's ``provenance.hardware``); no reproducibility check compares them.
    ``measured_lookahead_s`` is the look-ahead the method actually used, from the
    causality probe on the same sentences (:mod:`benchmark.protocol.lookahead`; cut at
    ``probe_times`` seconds, default one cut per sentence), ``lookahead_probe`` its
    record (the probes, their cost in ``generate`` calls and seconds).

    Returns
    -------
    dict
        ``{"lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf", "measured_lookahead_s",
        "lookahead_probe"}``, seconds (None: not known).

    Raises
    ------
    MethodError
        ``generate`` raised.
    """
    name = name or getattr(method, "name", type(method).__name__)
    lookahead = getattr(method, "lookahead_s", None)
    lookahead = None if lookahead is None else float(lookahead)
    items = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    first_frame = wall = cpu = audio_s = 0.0
    measured = 0
    probed, references, seeds = [], [], []
    for index, (subject, sentence) in enumerate(items[:max(1, int(sentences))]):
        audio, rate = dataset.audio(subject, sentence)
        if rate != AUDIO_RATE:
            raise DataError(f"dataset audio for {subject}/{sentence}: expected {AUDIO_RATE} Hz, got {rate}")
        frames = int(np.asarray(dataset.coeffs(subject, sentence)).shape[0])
        utterance = Utterance(subject=subject, sentence=sentence, split=split, audio=audio, num_frames=frames)
        head = frames if lookahead is None else max(1, min(frames, int(math.ceil(lookahead * FPS - 1e-9))))
        head_audio = utterance.audio[:int(round(head * AUDIO_RATE / FPS))] if head < frames else utterance.audio
        prefix = dataclasses.replace(utterance, audio=head_audio, num_frames=head)
        try:
            with progress_bars(False), plugin_call(f"method {name!r}: generate (latency)"):
                if measured == 0:  # the first frame of the first sentence
                    start = time.perf_counter()
                    method.generate(prefix, samples=1, seed=sentence_seed(seed, index))
                    first_frame = time.perf_counter() - start
                start, start_cpu = time.perf_counter(), time.process_time()
                reference = method.generate(utterance, samples=1, seed=sentence_seed(seed, index))
                wall += time.perf_counter() - start
                cpu += time.process_time() - start_cpu
        except (UserError, DataError, OSError):
            raise
        except Exception as exc:
            raise MethodError(f"method {name!r}, subject {subject!r}, sentence {sentence!r}: generate failed "
                              f"while timing it: {type(exc).__name__}: {exc}") from exc
        audio_s += utterance.duration
        measured += 1
        probed.append(utterance)
        references.append(reference)
        seeds.append(sentence_seed(seed, index))
    values = {"lookahead_s": lookahead, "first_frame_s": first_frame,
              "compute_per_audio_s": cpu / audio_s if audio_s else None, "rtf": wall / audio_s if audio_s else None}
    record = {key: None if values[key] is None else round(float(values[key]), 4) for key in LATENCY_FIELDS}
    return {**record, **_probed_lookahead(method, name, probed, references, seeds, lookahead, probe_times)}


def _probed_lookahead(method, name: str, utterances, references, seeds, declared, times) -> dict:
    """:func:`benchmark.protocol.lookahead.lookahead_probe` of ``method`` on the sentences
    :func:`measure_latency` timed (their outputs the unchanged ones), with its cost in seconds."""
    def one_sample(utterance, sentence_seed_):
        try:
            with progress_bars(False), plugin_call(f"method {name!r}: generate (look-ahead probe)"):
                return method.generate(utterance, samples=1, seed=sentence_seed_)
        except (UserError, DataError, OSError):
            raise
        except Exception as exc:
            raise MethodError(f"method {name!r}, subject {utterance.subject!r}, sentence {utterance.sentence!r}: "
                              f"generate failed in the look-ahead probe: {type(exc).__name__}: {exc}") from exc

    start = time.perf_counter()
    try:
        probe = lookahead_probe(one_sample, utterances, references, seeds, declared_s=declared, times=times)
    except MethodOutputError as exc:
        raise MethodOutputError(f"method {name!r}: look-ahead probe: {exc}") from exc
    probe["lookahead_probe"]["wall_s"] = round(time.perf_counter() - start, 3)
    return probe


def sentence_seed(seed: int, index: int) -> int:
    """Seed for the ``index``-th sentence of a run seeded with ``seed`` (independent streams)."""
    return int(np.random.SeedSequence([int(seed), int(index)]).generate_state(1)[0] & 0x7FFFFFFF)


def generated_tracks(method, dataset, *, split: str = "test", samples: int = 1, seed: int = 0,
                     clip: bool = False, name: str | None = None, store=None,
                     vertices_out=None, time_limit: float | None = None, sentence_batch: int = 1):
    """Ask ``method`` for every sentence of ``split`` and check each answer.

    Parameters
    ----------
    method : Method
    dataset : benchmark.data dataset
    split : str
    samples : int
        Samples per sentence for stochastic methods; deterministic methods are
        asked for one.
    seed : int
    clip : bool
        Clip values outside [0, 1] instead of refusing them.
    store : benchmark.runs.TrackWriter, optional
        Receives every scored track (and a vertex method's own vertices).
    vertices_out : dict, optional
        Filled with a vertex method's own ``(S, T, V, 3)`` vertices per key (memory
        permitting; the runner reads them back from ``store`` instead).
    time_limit : float or GenerateLimit, optional
        How long one ``generate`` call may take (stopped with :class:`MethodTimeout`):
        seconds per call, or a :class:`~benchmark.protocol.limits.GenerateLimit` that
        grows with the audio; a call for several sentences may take the sum of
        theirs. None: no limit (the runner passes
        :data:`~benchmark.protocol.limits.DEFAULT_GENERATE_LIMIT` unless told otherwise).
    sentence_batch : int, default 1
        Sentences per call: above 1, the sentences, in order of length, go to
        ``method.generate_many`` in groups of this size (each with the seed it has
        alone, :func:`sentence_seed` of its position in the split).

    Returns
    -------
    generated : dict
        ``{(subject, sentence): (S, T, 32) float64 ndarray}`` in the split's order,
        ``T`` = ground-truth frames; for ``output = "vertices"`` methods the tracks
        fitted to their vertices with the speaker's rig (:mod:`blendvoca.fit.vertex_tracks`).
    n_clipped : int

    Raises
    ------
    MethodError
        ``generate`` raised or ran past ``time_limit`` (message names method, subject and sentence).
    MethodOutputError
        The output broke the contract (shape, frames, NaN, range).
    DataError
        A file of the build is missing or does not read (the audio at another rate, too).
    """
    name = name or getattr(method, "name", type(method).__name__)
    kind = getattr(method, "output", OUTPUT_COEFFICIENTS)
    if kind not in OUTPUT_KINDS:
        raise MethodOutputError(f"method {name!r}: output must be one of {OUTPUT_KINDS}, got {kind!r}")
    if isinstance(sentence_batch, bool) or int(sentence_batch) != sentence_batch or int(sentence_batch) < 1:
        raise UserError(f"sentence_batch: expected an integer >= 1, got {sentence_batch!r}")
    num_samples = int(samples) if getattr(method, "stochastic", False) else 1
    names = tuple(getattr(dataset, "names", ()) or ())
    num_coeffs = len(names) if names else 32
    items = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    if not items:
        raise DataError(f"dataset split {split!r} has no sentences")
    frames = [int(np.asarray(dataset.coeffs(subject, sentence)).shape[0]) for subject, sentence in items]
    if sentence_batch > 1:
        by_length = sorted(range(len(items)), key=lambda i: (frames[i], i))
        groups = [by_length[i:i + int(sentence_batch)] for i in range(0, len(items), int(sentence_batch))]
    else:
        groups = [[i] for i in range(len(items))]
    sentences_bar = bar(total=len(items), desc=f"{name}: generate", unit="sentence", file=sys.stderr)

    def utterance_of(index):
        subject, sentence = items[index]
        audio, rate = dataset.audio(subject, sentence)
        if rate != AUDIO_RATE:
            raise DataError(f"dataset audio for {subject}/{sentence}: expected {AUDIO_RATE} Hz, got {rate}")
        return Utterance(subject=subject, sentence=sentence, split=split, audio=audio, num_frames=frames[index])

    def where_of(group):
        return f"method {name!r}, " + "; ".join(f"subject {items[i][0]!r}, sentence {items[i][1]!r}" for i in group)

    if time_limit is not None and not isinstance(time_limit, GenerateLimit):
        time_limit = GenerateLimit(base_s=float(time_limit)) if float(time_limit) > 0 else None

    generated, n_clipped, notes = {}, 0, []
    for group in groups:
        utterances = [utterance_of(index) for index in group]
        seeds = [sentence_seed(seed, index) for index in group]
        where = where_of(group)
        limit = None if time_limit is None else sum(
            time_limit.seconds(len(u.audio) / AUDIO_RATE) for u in utterances)
        how = None  # how the limit was reckoned, where it is not simply the number said
        if time_limit is not None and (time_limit.per_audio_second_s or len(group) > 1):
            how = time_limit.describe() + (f" per sentence, {len(group)} sentences" if len(group) > 1 else "")
        try:
            with plugin_call(f"{where}: generate", notes=notes), TimeLimit(limit, f"{where}: generate", how):
                many = getattr(method, "generate_many", None) if sentence_batch > 1 else None
                if many is None:  # one sentence per call, or a method without generate_many
                    outputs = [method.generate(u, samples=num_samples, seed=s) for u, s in zip(utterances, seeds)]
                else:
                    outputs = list(many(utterances, samples=num_samples, seeds=seeds))
        except (MethodTimeout, UserError, DataError, OSError) as exc:
            # a build file the method reads that is missing or wrong is the data's fault
            if ran_out_of(exc) is not None and not isinstance(exc, MethodTimeout):
                raise out_of_resources(exc, f"{where}: generate") from exc
            raise
        except MemoryError as exc:
            raise out_of_resources(exc, f"{where}: generate") from exc
        except Exception as exc:
            if ran_out_of(exc) is not None:  # torch's allocator: memory, not the method's fault
                raise out_of_resources(exc, f"{where}: generate") from exc
            raise MethodError(f"{where}: generate failed: {type(exc).__name__}: {exc}") from exc
        if len(outputs) != len(group):
            raise MethodOutputError(f"{where}: generate_many returned {len(outputs)} outputs for "
                                    f"{len(group)} utterances")
        for index, output in zip(group, outputs):
            subject, sentence = items[index]
            num_frames = frames[index]
            if kind == OUTPUT_VERTICES:
                rig = dataset.rig(subject)
                verts = validated_vertices(output, method=name, subject=subject, sentence=sentence,
                                           num_frames=num_frames, samples=num_samples,
                                           num_vertices=int(np.asarray(rig.neutral).shape[0]))
                from blendvoca.fit.vertex_tracks import fitted_sample_tracks

                tracks = fitted_sample_tracks(verts, rig, names or rig.names)
                if store is not None:
                    store.write_vertices(subject, sentence, verts, rig.neutral)
                if vertices_out is not None:
                    vertices_out[(subject, sentence)] = verts
            else:
                tracks, clipped = validated_tracks(output, method=name, subject=subject, sentence=sentence,
                                                   num_frames=num_frames, samples=num_samples, num_coeffs=num_coeffs,
                                                   clip=clip)
                n_clipped += clipped
            if store is not None:
                store.write_tracks(subject, sentence, tracks)
            generated[(subject, sentence)] = tracks
        sentences_bar.update(len(group))
    sentences_bar.close()
    warn_notes(notes)
    return {key: generated[key] for key in items}, n_clipped
