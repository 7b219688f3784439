"""The benchmark runner on a real (small) build that was modified after it was made, and
on inputs that used to end in a traceback: each refused with one ``error:`` line and the
exit code of the CLI layer, nothing written."""

from __future__ import annotations

import json
import shutil
import signal
import threading

import numpy as np
import pytest

from blendvoca import format as fmt
from tests.faults.conftest import assert_one_error_line
from tests.methods.fakes import fake_evaluate_split


@pytest.fixture
def build(tmp_path, small_build):
    """A private copy of the small build."""
    out = tmp_path / "B"
    shutil.copytree(small_build, out)
    return out


@pytest.fixture
def fast_scoring(monkeypatch):
    """The runner scores with the tests' fake evaluation (the build is still opened and read)."""
    from benchmark.protocol import scoring

    monkeypatch.setattr(scoring, "evaluate_split", fake_evaluate_split)


def _run(capsys, build, results, *argv):
    from benchmark.run import main

    code = main(["--method", "mean", "--data", str(build), "--results", str(results), "--quiet",
                 "--max-steps", "1", *map(str, argv)])
    return code, capsys.readouterr()


def _scored_csv(build, split="test"):
    """A ground-truth CSV of a speaker of ``split``."""
    subject = fmt.read_splits(build)[split][0]
    return fmt.coeffs_path(build, subject, "sentence01")


def _edit_one_value(path):
    """Change one digit of the CSV (what hand-editing a track does): same shape, new content."""
    lines = path.read_text().splitlines()
    row = lines[1].split(",")
    row[0] = "0.5000" if row[0] != "0.5000" else "0.2500"
    lines[1] = ",".join(row)
    path.write_text("\n".join(lines) + "\n")


def test_a_build_with_an_edited_csv_is_refused_and_no_verify_scores_it(build, tmp_path, capsys, fast_scoring):
    edited = _scored_csv(build)
    _edit_one_value(edited)
    code, out = _run(capsys, build, tmp_path / "r")
    assert code == 4
    assert_one_error_line(out.err, str(edited), "manifest.json", "--no-verify")
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())
    code, out = _run(capsys, build, tmp_path / "r", "--no-verify")
    assert code == 0, out.err
    (path,) = (tmp_path / "r").glob("*.json")
    assert json.loads(path.read_text())["protocol"]["verified"] is False


def test_a_pristine_build_is_verified_and_recorded(build, tmp_path, capsys, fast_scoring):
    # every split is checked (issue 56: the method trains on the other splits): an edited
    # file of the validation split is refused too
    edited = _scored_csv(build, "val")
    original = edited.read_bytes()
    _edit_one_value(edited)
    code, out = _run(capsys, build, tmp_path / "r")
    assert code == 4
    assert_one_error_line(out.err, str(edited), "manifest.json")
    edited.write_bytes(original)
    code, out = _run(capsys, build, tmp_path / "r")
    assert code == 0, out.err
    (path,) = (tmp_path / "r").glob("*.json")
    assert json.loads(path.read_text())["protocol"]["verified"] is True


@pytest.mark.parametrize("what", ["audio", "rig"])
def test_an_edited_audio_or_rig_of_the_split_is_refused(what, build, tmp_path, capsys, fast_scoring):
    subject = fmt.read_splits(build)["test"][0]
    path = fmt.audio_path(build, subject, "sentence01") if what == "audio" else fmt.rig_path(build, subject)
    data = bytearray(path.read_bytes())
    data[-1] ^= 1
    path.write_bytes(bytes(data))
    code, out = _run(capsys, build, tmp_path / "r")
    assert code == 4
    assert_one_error_line(out.err, str(path))


def test_a_listed_file_that_is_gone_is_a_data_error(build, tmp_path, capsys, fast_scoring):
    gone = _scored_csv(build)
    gone.unlink()
    code, out = _run(capsys, build, tmp_path / "r")
    assert code == 2
    assert_one_error_line(out.err, str(gone), "missing")


@pytest.fixture
def sigint_raises():
    """SIGINT raising KeyboardInterrupt in this process, as in a terminal (a test session started
    in the background, nohup or ``&``, has SIGINT ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_in_a_run_is_one_line_exit_130_and_leaves_nothing(build, tmp_path, capsys, monkeypatch, sigint_raises):
    from benchmark.protocol import scoring

    def interrupted(*args, **kwargs):
        # what Ctrl-C does while the metrics are computed: the tracks are staged by then
        signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(scoring, "evaluate_split", interrupted)
    assert threading.current_thread() is threading.main_thread()
    code, out = _run(capsys, build, tmp_path / "r")
    assert code == 130, out.err
    lines = [line for line in out.err.splitlines() if line.strip()]
    assert lines == ["interrupted: rerun the same command to continue"]
    assert "Traceback" not in out.err and "KeyboardInterrupt" not in out.err
    # nothing half-written: no result, no staged tracks folder
    assert not (tmp_path / "r").exists() or [p.name for p in (tmp_path / "r").iterdir()] == []


def test_a_zero_length_wav_is_named(build, tmp_path, capsys, fast_scoring):
    import soundfile

    from blendvoca.io.audio import AudioFormatError, load_audio

    subject = fmt.read_splits(build)["test"][0]
    empty = fmt.audio_path(build, subject, "sentence01")
    soundfile.write(empty, np.zeros(0, np.float32), 16000, subtype="PCM_16", format="WAV")
    with pytest.raises(AudioFormatError, match="no samples"):
        load_audio(empty)
    # scored as it is (the check would refuse the changed file first): the reader names it
    code, out = _run(capsys, build, tmp_path / "r", "--no-verify")
    assert code == 2
    line = assert_one_error_line(out.err, str(empty), "no samples")
    assert "got shape" not in line
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").iterdir())
