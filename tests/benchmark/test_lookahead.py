"""The look-ahead probe (benchmark.protocol.lookahead): known look-aheads recovered, a plug-in
that reads past its declaration caught and marked in the tables, a probe time outside the
utterance refused before anything is stored."""

import dataclasses
import json

import numpy as np
import pytest

from benchmark.methods import AUDIO_RATE, FPS, Budget, Method
from benchmark.protocol import RunSpec, UsageError, run
from benchmark.protocol.generation import measure_latency
from benchmark.protocol.lookahead import FRAME_S, exceeds_declaration, probe_cut_frames
from benchmark.protocol.spec import checked_probe_times
from benchmark.results import build_result, check
from tests.methods.fakes import fake_evaluate, speech_dataset


def _frame_loudness(audio: np.ndarray, frames: int) -> np.ndarray:
    """RMS of each frame's own audio (its ``AUDIO_RATE / FPS`` samples)."""
    edges = np.round(np.arange(frames + 1) * AUDIO_RATE / FPS).astype(int)
    return np.array([np.sqrt(np.mean(np.square(audio[a:b], dtype=np.float64))) if b > a else 0.0
                     for a, b in zip(edges[:-1], edges[1:])])


class LooksAhead(Method):
    """jawOpen of frame ``j``: the loudness of frame ``j + ahead`` (the last frame's past the end),
    so frame ``j`` listens exactly ``ahead`` frames ahead of itself; ``normalise``: offset by the
    whole utterance's loudness (a "streaming" model that reads everything); ``stochastic``: plus
    noise from the seed's stream; ``unseeded``: plus noise from a stream the seed does not fix."""

    name = "looks-ahead"
    contract = 3

    def __init__(self, ahead=0, declared=0.0, normalise=False, stochastic=False, unseeded=False):
        super().__init__()
        self.ahead, self.lookahead_s, self.normalise = int(ahead), declared, normalise
        self.stochastic, self.unseeded = stochastic, unseeded
        self.rng = np.random.default_rng()

    def train(self, dataset, request):
        pass

    def generate(self, utterance, *, samples=1, seed=0):
        frames = utterance.num_frames
        loud = _frame_loudness(utterance.audio, frames)
        y = loud[np.minimum(np.arange(frames) + self.ahead, frames - 1)]
        if self.normalise:
            y = 0.5 * y + 0.1 * np.sqrt(np.mean(np.square(utterance.audio, dtype=np.float64)))
        out = np.full((samples, frames, 32), 0.05)
        out[:, :, 0] = np.clip(y, 0.0, 1.0)
        if self.stochastic:
            out[:, :, 1] += 0.01 * np.random.default_rng(seed).random((samples, frames))
        if self.unseeded:
            out[:, :, 2] += 0.01 * self.rng.random((samples, frames))
        return out


def _latency(method, sentences=2, **kwargs):
    dataset = speech_dataset(seed=1, sentences=sentences, seconds=2.0)
    return measure_latency(method, dataset, split="test", seed=0, sentences=sentences, **kwargs)


@pytest.mark.parametrize("ahead", [0, 3, 12, 30])
def test_a_method_that_looks_k_frames_ahead_measures_k_frames(ahead):
    latency = _latency(LooksAhead(ahead=ahead, declared=ahead / FPS))
    assert abs(latency["measured_lookahead_s"] - ahead / FPS) <= FRAME_S + 1e-9
    assert not exceeds_declaration(latency["measured_lookahead_s"], latency["lookahead_s"])
    probe = latency["lookahead_probe"]
    assert probe["note"] is None and not probe["whole_utterance"]
    # each cut after the declared look-ahead: the first frames never changed
    assert all(p["cut_s"] >= ahead / FPS + 2 * FRAME_S - 1e-9 and p["changed_from_s"] > 0 for p in probe["probes"])


def test_a_method_that_declares_nothing_is_measured_all_the_same():
    latency = _latency(LooksAhead(ahead=6, declared=None))
    assert latency["lookahead_s"] is None
    assert abs(latency["measured_lookahead_s"] - 6 / FPS) <= FRAME_S + 1e-9


def test_a_causal_method_passes_and_one_reading_half_a_second_ahead_is_caught():
    causal = _latency(LooksAhead(ahead=0, declared=0.1))
    assert causal["measured_lookahead_s"] <= 0.1 + FRAME_S
    assert not exceeds_declaration(causal["measured_lookahead_s"], causal["lookahead_s"])
    cheat = _latency(LooksAhead(ahead=30, declared=0.1))
    assert abs(cheat["measured_lookahead_s"] - 0.5) <= FRAME_S + 1e-9
    assert exceeds_declaration(cheat["measured_lookahead_s"], cheat["lookahead_s"])


def test_a_method_normalising_by_the_whole_utterance_reads_all_of_it():
    latency = _latency(LooksAhead(ahead=0, declared=0.1, normalise=True))
    probe = latency["lookahead_probe"]
    assert probe["whole_utterance"] and all(p["changed_from_s"] == 0.0 for p in probe["probes"])
    longest = max(p["duration_s"] for p in probe["probes"])
    assert latency["measured_lookahead_s"] == longest  # recorded as the utterance's length
    assert exceeds_declaration(latency["measured_lookahead_s"], latency["lookahead_s"])


def test_a_method_whose_declaration_covers_the_sentence_may_read_all_of_it():
    latency = _latency(LooksAhead(ahead=0, declared=10.0, normalise=True))  # one 10 s chunk, 2 s sentences
    assert latency["lookahead_probe"]["whole_utterance"]
    assert latency["measured_lookahead_s"] == max(p["duration_s"] for p in latency["lookahead_probe"]["probes"])
    assert not exceeds_declaration(latency["measured_lookahead_s"], latency["lookahead_s"])


def test_a_sampling_method_is_probed_with_its_random_streams_fixed():
    latency = _latency(LooksAhead(ahead=3, declared=3 / FPS, stochastic=True))
    assert abs(latency["measured_lookahead_s"] - 3 / FPS) <= FRAME_S + 1e-9


def test_a_method_the_seed_does_not_reproduce_is_not_measured():
    latency = _latency(LooksAhead(ahead=0, declared=0.0, unseeded=True))
    assert latency["measured_lookahead_s"] is None
    assert "fixed seed" in latency["lookahead_probe"]["note"]
    assert latency["lookahead_probe"]["generate_calls"] == 1  # the repeat only


def test_the_probe_costs_a_repeat_and_two_calls_per_cut_at_the_times_asked():
    method = LooksAhead(ahead=3, declared=3 / FPS)
    calls = []
    original = method.generate
    method.generate = lambda utterance, **kw: calls.append(utterance.audio.copy()) or original(utterance, **kw)
    latency = _latency(method, sentences=2, probe_times=(0.5, 1.0))
    probe = latency["lookahead_probe"]
    assert [p["cut_s"] for p in probe["probes"]] == [0.5, 1.0, 0.5, 1.0]
    assert probe["generate_calls"] == 1 + 2 * 4 and len(calls) == 1 + 2 + probe["generate_calls"]
    # the cut at 0.5 s of the first sentence: silence, then noise, from sample 8000 on; the rest unchanged
    silence, noise = calls[4], calls[5]
    assert np.array_equal(silence[:8000], calls[1][:8000]) and not silence[8000:].any()
    assert np.array_equal(noise[:8000], calls[1][:8000]) and np.all(noise[8000:] != 0)
    assert silence.shape == noise.shape == calls[1].shape


def test_default_cuts_leave_the_declared_look_ahead_before_them():
    assert probe_cut_frames(300, None, 0) == [150]
    assert probe_cut_frames(300, 4.0, 0) == [242]      # after 4 s + two frames
    assert probe_cut_frames(300, 4.9, 0) == [296]      # just long enough
    assert probe_cut_frames(300, 10.0, 0) == [150]     # a sentence the declaration covers: any cut is within it
    assert probe_cut_frames(300, None, 0, times=(0.5, 0.51)) == [30, 31]


@pytest.mark.parametrize("times", [(0.0,), (2.5,), (-1.0,), (float("nan"),)])
def test_a_probe_time_outside_the_utterance_is_refused_naming_the_option_and_length(times):
    with pytest.raises(UsageError) as refused:
        checked_probe_times(times, {("D", "sentence01"): 2.0})
    message = str(refused.value)
    assert "--lookahead-probes" in message
    assert "expected times" in message or ("D/sentence01" in message and "2.000 s long" in message)


def test_a_run_with_a_probe_time_outside_the_utterance_stores_nothing(tmp_path):
    dataset = speech_dataset(seed=1, sentences=2, seconds=1.0)
    longest = max(len(dataset.coeffs("D", s)) for s in dataset.sentences("D")) / FPS
    spec = RunSpec("random", data_root="unused", samples=1, budget=Budget(max_steps=2), results_dir=tmp_path,
                   lookahead_probes=(longest + 1.0,))
    with pytest.raises(UsageError, match=r"--lookahead-probes .*outside the utterance D/sentence\d+, which is "):
        run(spec, evaluate=fake_evaluate, open_dataset=lambda root: dataset)
    assert not [p for p in tmp_path.iterdir() if not p.name.startswith(".")]
    for bad in (("soon",), (), (float("inf"),), 0.5):
        with pytest.raises(UsageError, match="--lookahead-probes: expected times"):
            RunSpec("random", lookahead_probes=bad)
    with pytest.raises(UsageError, match=r"--lookahead-probes -0.5: outside the utterance D/sentence01, which is "):
        run(dataclasses.replace(spec, lookahead_probes=(-0.5,)), evaluate=fake_evaluate,
            open_dataset=lambda root: dataset)


def test_the_command_line_refuses_a_probe_time_outside_the_utterance_in_one_line(tmp_path, capsys):
    from benchmark.protocol import default_data_root
    from benchmark.run import main

    data = default_data_root()  # builds the bundled default on a fresh machine, with progress on stderr
    capsys.readouterr()
    code = main(["--method", "mean", "--data", str(data), "--results", str(tmp_path),
                 "--lookahead-probes", "0.5,999", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith("error: --lookahead-probes 999: outside the utterance ") and " s long" in err[0]
    assert not list(tmp_path.glob("*.json"))
    assert main(["--method", "mean", "--lookahead-probes", "half", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("error: --lookahead-probes: expected comma-separated")


def test_the_probe_record_round_trips_and_files_without_it_stay_valid():
    base = {"method": {"name": "m", "config": {}}, "dataset": {"manifest_hash": "h"}, "protocol": {},
            "metrics": {"fd": {"mean": 1.0, "std": 0.0, "higher_is_better": False, "unit": ""}}, "timings": {},
            "provenance": {}}
    old = build_result(**base, latency={"lookahead_s": 0.5, "first_frame_s": 0.1, "compute_per_audio_s": 1,
                                        "rtf": 0.5})
    assert old.latency.measured_lookahead_s is None and "measured_lookahead_s" not in old.to_json()["latency"]
    assert not old.latency.exceeds_declaration()
    latency = _latency(LooksAhead(ahead=30, declared=0.1))
    new = build_result(**base, latency=latency)
    record = json.loads(json.dumps(new.to_json()))
    assert check(record).to_json() == record
    assert record["latency"]["lookahead_probe"] == latency["lookahead_probe"]
    assert new.latency.exceeds_declaration() and new.latency.lookahead_probe.probes[0].cut_s > 0.1
    for bad in ({"measured_lookahead_s": -1.0}, {"lookahead_probe": {"probes": [{"cut_s": "late"}]}},
                {"lookahead_probe": {"generate_calls": 1.5}}):
        with pytest.raises(ValueError, match="latency"):
            check({**record, "latency": {**record["latency"], **bad}})


def test_tables_mark_a_row_reading_past_its_declaration_with_a_note(tmp_path):
    from leaderboard.build import build_leaderboard
    from tests.leaderboard.test_build import _result, write_result

    honest = _result("honest", "h1", {"fd": (2.0, 0.1, False, "latent^2", (1.9, 2.1))})
    cheat = _result("cheat", "h1", {"fd": (1.0, 0.1, False, "latent^2", (0.9, 1.1))})
    whole = _result("whole", "h1", {"fd": (1.5, 0.1, False, "latent^2", (1.4, 1.6))})
    honest["latency"] = build_result(**_parts(honest), latency=_latency(LooksAhead(ahead=3, declared=0.1))
                                     ).to_json()["latency"]
    cheat["latency"] = build_result(**_parts(cheat), latency=_latency(LooksAhead(ahead=30, declared=0.1))
                                    ).to_json()["latency"]
    whole["latency"] = build_result(**_parts(whole), latency=_latency(LooksAhead(normalise=True, declared=None))
                                    ).to_json()["latency"]
    for result in (honest, cheat, whole):
        write_result(result, tmp_path / "results")
    md, tex = (p.read_text() for p in build_leaderboard(tmp_path / "results", tmp_path / "tables"))
    lines = md.splitlines()
    row = {name: next(line for line in lines if line.startswith(f"| {name} |")) for name in ("honest", "cheat", "whole")}
    assert row["cheat"].endswith(" ‡ |")
    assert not row["honest"].endswith("‡ |") and not row["whole"].endswith("‡ |")  # within, or declares none
    notes = [line for line in lines if line.startswith("‡ ")]
    assert len(notes) == 1 and "cheat: measured 0.5 s, declared 0.1 s" in notes[0]
    assert "honest" not in notes[0] and "whole" not in notes[0]
    assert r"$^\ddagger$ \\" in tex and r"{\footnotesize $^\ddagger$ Reads further ahead" in tex


def _parts(result: dict) -> dict:
    return {key: result[key] for key in ("method", "dataset", "protocol", "metrics", "timings", "provenance")}


def test_the_run_summary_says_the_declared_and_measured_look_ahead(capsys):
    from benchmark.run import _print_lookahead

    _print_lookahead(_latency(LooksAhead(ahead=30, declared=0.1)))
    _print_lookahead(_latency(LooksAhead(ahead=0, declared=None)))
    _print_lookahead({"lookahead_s": 0.5, "rtf": 0.1})  # written before the probe: nothing to say
    lines = capsys.readouterr().err.splitlines()
    assert lines == ["  look-ahead: declared 0.1 s, measured 0.5 s: READS FURTHER AHEAD THAN IT DECLARES "
                     "(marked in the tables)", "  look-ahead: declared the whole utterance, measured 0 s"]
