"""Chunked inference (baselines.common.chunking): the plan, the crossfade, and the seams of
each chunked method on a small trained model."""

import dataclasses

import numpy as np
import pytest

from baselines.common.chunking import (
    RATE_BOUND,
    chunk_plan,
    chunk_setting,
    crossfade_weights,
    frame_sample,
    generate_in_chunks,
    generate_utterance_in_chunks,
    seam_report,
)
from benchmark.methods.base import Budget, TrainingRequest
from benchmark.testing import FakeBlendVOCA


# ---- the plan and the blend ------------------------------------------------------------------

@pytest.mark.parametrize("num_frames", [1, 59, 60, 61, 100, 171, 600, 36000])
def test_plan_covers_every_frame_with_full_chunks(num_frames):
    plan = chunk_plan(num_frames, 60, 20)
    chunks = plan.chunks
    assert chunks[0].start == 0 and chunks[-1].stop == num_frames
    assert plan.chunked == (num_frames > 60)
    for before, after in zip(chunks, chunks[1:]):
        assert after.start == before.stop - after.fade_in  # contiguous: the fade is the overlap
        assert after.fade_in >= 20 and after.start > before.start
    assert all(c.num_frames == min(60, num_frames) for c in chunks)
    assert plan.lookahead_s() == min(60, num_frames) / 60


def test_plan_rejects_bad_lengths():
    for args in ((0, 60, 10), (100, 1, 0), (100, 60, 60), (100, 60, -1)):
        with pytest.raises(ValueError):
            chunk_plan(*args)


def test_audio_slices_follow_the_frames():
    plan = chunk_plan(300, 120, 30)
    n = frame_sample(300)
    assert [c.samples(n) for c in plan.chunks] == [(frame_sample(c.start), frame_sample(c.stop)) for c in plan.chunks]
    assert frame_sample(3) == 800  # 16 kHz at 60 fps: 800 samples per 3 frames


def test_crossfade_is_a_smooth_partition_of_unity():
    w = crossfade_weights(30)
    assert np.all((w > 0) & (w < 1)) and np.all(np.diff(w) > 0)
    np.testing.assert_allclose(w + w[::-1], 1.0)  # symmetric
    assert np.abs(np.diff(np.r_[0.0, w, 1.0])).max() <= np.pi / (2 * 31) + 1e-12


def test_blend_reproduces_a_track_every_chunk_agrees_on():
    truth = np.sin(np.linspace(0, 20, 500))[None, :, None] * np.ones((2, 1, 3))
    audio = np.zeros(frame_sample(500), np.float32)
    plan = chunk_plan(500, 90, 25)
    calls = []

    def chunk(wav, frames, index):
        c = plan.chunks[index]
        calls.append((wav.shape[0], frames))
        return truth[:, c.start:c.stop]

    parts = []
    out = generate_in_chunks(chunk, audio, 500, plan, keep_chunks=parts)
    np.testing.assert_allclose(out, truth)
    assert [f for _, f in calls] == [c.num_frames for c in plan.chunks]
    assert [n for n, _ in calls] == [frame_sample(c.stop) - frame_sample(c.start) for c in plan.chunks]
    report = seam_report(out, plan, parts)
    assert report.ok and report.seam_step <= report.inner_step + 1e-12


def test_seam_step_of_disagreeing_chunks_is_bounded_by_the_crossfade():
    # every chunk constant, each at another level: the blend's steps are the crossfade's
    plan = chunk_plan(400, 100, 40)
    levels = np.linspace(0.0, 1.0, len(plan.chunks))
    parts = []
    out = generate_in_chunks(lambda wav, frames, i: np.full((1, frames, 2), levels[i]),
                             np.zeros(frame_sample(400)), 400, plan, keep_chunks=parts)
    report = seam_report(out, plan, parts)
    assert report.inner_step == 0
    gap = np.diff(levels).max()
    assert 0 < report.seam_step <= gap * np.pi / (2 * 41) + 1e-12
    assert report.seam_step < RATE_BOUND and report.ok


def test_short_audio_is_padded_with_silence_not_stretched():
    plan = chunk_plan(200, 80, 20)
    seen = []
    generate_in_chunks(lambda wav, frames, i: (seen.append(wav.copy()), np.zeros((1, frames, 1)))[1],
                       np.ones(frame_sample(150), np.float32), 200, plan)
    last = plan.chunks[-1]
    assert seen[-1].shape[0] == frame_sample(last.stop) - frame_sample(last.start)
    assert seen[-1][-1] == 0 and seen[-1][0] == 1


def test_chunk_setting_reads_any_section():
    config = {"model": {"a": 1}, "sampling": {"chunk_frames": 90}, "preset": "x"}
    assert chunk_setting(config, "chunk_frames", 600) == 90
    assert chunk_setting(config, "chunk_overlap", 30) == 30
    with pytest.raises(ValueError):
        chunk_setting({"s": {"chunk_frames": 1.5}}, "chunk_frames", 1)


@pytest.mark.parametrize("name", ["said", "faceformer", "codetalker", "cdface"])
def test_chunk_lengths_are_typed_config_options(name):
    from blendvoca.cli import parse_config
    from benchmark.methods import get_method
    from benchmark.methods import method_schema
    from blendvoca.errors import UserError

    schema = method_schema(name)
    config = parse_config(["chunk_frames=120", "chunk_overlap=40"], schema=schema, method=name)
    assert config == {"chunk_frames": 120, "chunk_overlap": 40}
    method = get_method(name)(**config)
    chunked = method.said if name == "said" else method
    assert (chunked.chunk_frames, chunked.chunk_overlap) == (120, 40)
    default = get_method(name)()
    default = default.said if name == "said" else default
    assert default.chunk_frames > 120  # null keeps the method's own default
    with pytest.raises(UserError, match="chunk_frames"):
        parse_config(["chunk_frames=abc"], schema=schema, method=name)


# ---- each method, a small trained model ----------------------------------------------------

def long_utterance(dataset, repeats: int = 3):
    """The test speaker's sentences one after another: an utterance a few chunks long."""
    subject = dataset.split("test")[0]
    parts = [dataset.utterance(subject, s, "test") for s in dataset.sentences(subject)] * repeats
    audio = np.concatenate([p.audio[:frame_sample(p.num_frames)] for p in parts])
    return dataclasses.replace(parts[0], audio=audio, num_frames=sum(p.num_frames for p in parts))


def seams_of(method, utterance, whole_generate, chunk_frames, overlap, samples=2):
    """(blended output, SeamReport) of ``whole_generate`` chunked by ``generate_utterance_in_chunks``."""
    parts = []
    out = generate_utterance_in_chunks(whole_generate, utterance, samples=samples, seed=0,
                                       chunk_frames=chunk_frames, overlap_frames=overlap, keep_chunks=parts)
    plan = chunk_plan(utterance.num_frames, chunk_frames, overlap)
    assert plan.chunked and len(parts) == len(plan.chunks)
    return out, plan, parts


def assert_vertex_seams(out, plan, parts, name):
    # vertex methods: the seams in millimetres against the chunks' own steps (no rate bound in
    # vertex space), then the benchmark's fitted coefficients against the rate bound
    report = seam_report(out * 1000, plan, [p * 1000 for p in parts], rate_bound=0.0)
    print(f"{name}: largest seam step {report.seam_step:.4f} mm, largest in-chunk step {report.inner_step:.4f} mm")
    assert report.ok, report


def test_said_chunks_long_audio_and_its_seams_stay_within_bounds():
    from baselines.said.plugin import SAiDMethod
    from tests.said.test_plugin import TINY, small_dataset

    method = SAiDMethod(**TINY)
    dataset = small_dataset()
    method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=6)))
    said = method.said
    said.config["sampling"]["chunk_frames"], said.config["sampling"]["chunk_overlap"] = 40, 15
    assert said.chunk_frames == 40 and said.chunk_overlap == 15 and method.lookahead_s == 40 / 60
    subject = dataset.split("test")[0]
    base = dataset.utterance(subject, dataset.sentences(subject)[0], "test")
    audio = np.tile(base.audio, 3)
    frames = 3 * base.num_frames
    out = said.generate(audio, frames, samples=2, seed=0)
    assert out.shape == (2, frames, 32) and out.min() >= 0 and out.max() <= 1
    plan = chunk_plan(frames, 40, 15)
    parts = []
    again = generate_in_chunks(
        lambda wav, n, i: said._generate_whole(wav, n, samples=2, seed=0, sampler=None, num_steps=None,
                                               guidance=None, eta=None),
        audio, frames, plan, keep_chunks=parts)
    np.testing.assert_array_equal(out, again)  # generate is the chunked path
    # a batch holding a long utterance samples each on its own, the long one chunked
    many = said.generate_many([(audio, frames), (base.audio, base.num_frames)], samples=2, seeds=[0, 1])
    np.testing.assert_array_equal(many[0], out)
    report = seam_report(out, plan, parts)
    print(f"said: largest seam step {report.seam_step:.4f}, largest in-chunk step {report.inner_step:.4f}")
    assert report.ok, report
    # an utterance of one chunk is the unchunked chain itself
    short = said.generate(base.audio, 40, samples=1, seed=3)
    np.testing.assert_array_equal(short, said._generate_whole(base.audio, 40, samples=1, seed=3, sampler=None,
                                                              num_steps=None, guidance=None, eta=None))


@pytest.mark.parametrize("plugin", ["faceformer", "codetalker"])
def test_autoregressive_vertex_methods_chunk_with_bounded_seams(plugin):
    from baselines.common.vertex_method import StyleVertexMethod

    if plugin == "faceformer":
        from baselines.faceformer.plugin import FaceFormerMethod as cls
        from tests.faceformer.test_plugin import TINY
    else:
        from baselines.codetalker.plugin import CodeTalkerMethod as cls
        from tests.codetalker.test_plugin import TINY
    dataset = FakeBlendVOCA(0, train=2, sentences=1)
    method = cls(**TINY)
    method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=8)))
    assert method.chunk_frames == 600 and method.chunk_overlap == 60 and method.lookahead_s == 10.0
    method.settings["training"]["chunk_frames"], method.settings["training"]["chunk_overlap"] = 120, 40
    utterance = long_utterance(dataset)
    out = method.generate(utterance, samples=2, seed=0)
    assert out.shape[:2] == (2, utterance.num_frames)

    def whole(u, *, samples, seed):
        return StyleVertexMethod.generate(method, u, samples=samples, seed=seed)

    again, plan, parts = seams_of(method, utterance, whole, 120, 40)
    np.testing.assert_array_equal(out, again)
    assert_vertex_seams(out, plan, parts, plugin)


def test_cdface_chunks_long_audio_with_bounded_seams():
    from baselines.cdface.plugin import CDFaceMethod
    from tests.cdface.test_plugin import PLUGIN_TINY

    dataset = FakeBlendVOCA(0, sentences=1)
    method = CDFaceMethod(**PLUGIN_TINY)
    method.train(dataset, TrainingRequest(seed=0, budget=Budget(max_steps=4)))
    assert (method.chunk_frames, method.chunk_overlap) == (480, 48) and method.lookahead_s == 8.0
    method.resolved["training"]["chunk_frames"], method.resolved["training"]["chunk_overlap"] = 120, 40
    utterance = long_utterance(dataset, repeats=2)
    out = method.generate(utterance, samples=2, seed=0)

    def whole(u, *, samples, seed):
        return method.cdface.generate(u.audio, u.num_frames, subject=u.subject, samples=samples, seed=seed)

    again, plan, parts = seams_of(method, utterance, whole, 120, 40)
    np.testing.assert_array_equal(out, again)
    assert_vertex_seams(out, plan, parts, "cdface")


# ---- memory ----------------------------------------------------------------------------------

@pytest.mark.slow
def test_said_long_audio_peak_memory_stays_near_a_short_one():
    # perf/bench_long_audio.py at shorter lengths and 2 DDIM steps (memory does not depend
    # on the steps): unchunked, the 4-minute utterance peaked at 1.75x the 10-second one's peak
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "perf" / "bench_long_audio.py"
    spec = importlib.util.spec_from_file_location("bench_long_audio", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    short, long = bench.measure([10.0, 240.0], num_steps=2)
    assert (short["frames"], long["frames"]) == (600, 14400)
    assert long["peak_rss_mb"] < 1.5 * short["peak_rss_mb"], (short, long)


def test_a_chunked_generation_counts_its_chunks(capsys):
    """Issue 57: chunked SAiD showed 12 restarting bars and no chunk counter."""
    from blendvoca.runtime.progress import progress_bars

    plan = chunk_plan(500, 90, 25)
    audio = np.zeros(frame_sample(500), np.float32)
    with progress_bars(True):
        generate_in_chunks(lambda wav, frames, index: np.zeros((1, frames, 2)), audio, 500, plan)
    err = capsys.readouterr().err
    assert f"chunks:   0%|          | 0/{len(plan.chunks)}" in err  # counted (the bar clears itself when done)
    with progress_bars(True):  # one chunk: no counter
        generate_in_chunks(lambda wav, frames, index: np.zeros((1, frames, 2)), audio[:frame_sample(60)], 60,
                           chunk_plan(60, 90, 25))
    assert "chunks" not in capsys.readouterr().err
