import ast
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from blendvoca.builder import build_dataset, coeffs_std, head_faces, lip_aperture
from blendvoca.builder.__main__ import main
from blendvoca.builder.report import TIMINGS
from blendvoca.cli import EXIT_PARTIAL
from blendvoca.format.hashing import file_digest
from blendvoca.format.layout import STATE_DIR
from blendvoca.format.manifest import blas_kernels
from blendvoca.io.coeffs import read_coeffs_csv
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.rig import Rig
from blendvoca.vocaset import open_vocaset


def _tree(root, skip_state=True):
    """``{relpath: bytes}`` of every file under root (without the stage records and, being
    volatile by design, without the stage timings, which no manifest lists)."""
    root = Path(root)
    return {
        p.relative_to(root).as_posix(): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and not (skip_state and p.relative_to(root).parts[0] == ".buildstate")
        and not (skip_state and p.relative_to(root).as_posix() == TIMINGS)
    }


def test_layout_and_contents(built_dataset, synthetic_corpus):
    corpus = open_vocaset(synthetic_corpus)
    for subject in corpus.subjects:
        rig = Rig.load(built_dataset / "rigs" / f"{subject}.npz")
        assert rig.names == BLENDVOCA_NAMES
        np.testing.assert_array_equal(rig.neutral, corpus.template(subject))
        assert (built_dataset / "templates_head" / f"{subject}.obj").is_file()
        for name in BLENDVOCA_NAMES:
            assert (built_dataset / "blendshapes_head" / subject / f"{name}.obj").is_file()
        for sentence in corpus.sentences(subject):
            coeffs, names = read_coeffs_csv(built_dataset / "blendshape_coeffs" / subject / f"{sentence}.csv")
            assert names == BLENDVOCA_NAMES
            assert coeffs.shape == (corpus.frames(subject, sentence).shape[0], 32)
            assert coeffs.min() >= 0 and coeffs.max() <= 1
            assert np.abs(np.diff(coeffs, axis=0)).max() <= 0.1 + 2e-6  # CSV rounding
            assert (built_dataset / "audio" / subject / f"{sentence}.wav").is_file()
    splits = json.loads((built_dataset / "splits.json").read_text())
    assert splits == corpus.splits
    std, std_names = read_coeffs_csv(built_dataset / "coeffs_std.csv")
    assert std_names == BLENDVOCA_NAMES and std.shape == (1, 32) and np.all(std >= 0)
    report = (built_dataset / "report" / "README.md").read_text()
    assert "RMSE" in report and (built_dataset / "report" / "tracks.png").is_file()
    timings = (built_dataset / TIMINGS).read_text()
    rows = {line.split(" | ")[0].lstrip("| "): line.split(" | ")[1:] for line in timings.splitlines()
            if line.startswith("| ") and not line.startswith("| stage")}
    assert set(rows) >= {"rigs", "fits", "report", "total"}
    assert rows["rigs"][0] == str(len(corpus.subjects)) and rows["fits"][0] == str(len(corpus.items()))
    assert TIMINGS not in json.loads((built_dataset / "manifest.json").read_text())["files"]


def test_manifest_lists_every_output_with_its_digest(built_dataset):
    manifest = json.loads((built_dataset / "manifest.json").read_text())
    files = set(_tree(built_dataset)) - {"manifest.json"}
    assert set(manifest["files"]) == files
    for rel, digest in manifest["files"].items():
        assert file_digest(built_dataset / rel) == digest
    assert manifest["parameters"] == {"shapes": "speech", "delta": 0.1}
    assert manifest["version"]
    # built on this machine, so on the kernels this process runs (the build's numbers depend on them)
    assert manifest["blas"] == blas_kernels() and manifest["blas"]
    speaker = next(iter(manifest["inputs"]["speakers"].values()))
    assert speaker["template"]["template"] and all(s["frames"] for s in speaker["sentences"].values())


@pytest.mark.skipif(not any(k.startswith("openblas ") for k in blas_kernels()), reason="numpy runs no OpenBLAS here")
def test_blas_kernels_name_the_kernel_openblas_runs():
    # OPENBLAS_CORETYPE picks the kernel (Haswell runs on any x86-64 CPU with AVX2)
    if os.uname().machine not in ("x86_64", "AMD64"):
        pytest.skip("OpenBLAS's Haswell kernel is x86-64 only")
    code = "from blendvoca.format.manifest import blas_kernels; print(repr(blas_kernels()))"
    env = {**os.environ, "OPENBLAS_CORETYPE": "Haswell"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    kernels = ast.literal_eval(out)
    openblas = [k for k in kernels if k.startswith("openblas ")]
    assert openblas and all(k.endswith(" Haswell") for k in openblas), kernels


def test_fit_reproduces_the_input_meshes(built_dataset, synthetic_corpus):
    # The synthetic motion is not made with the ARKit rig: the fit is an approximation,
    # but a close one on the face (millimetres), and the report says how close.
    corpus = open_vocaset(synthetic_corpus)
    subject = corpus.subjects[0]
    sentence = corpus.sentences(subject)[0]
    rig = Rig.load(built_dataset / "rigs" / f"{subject}.npz")
    coeffs, _ = read_coeffs_csv(built_dataset / "blendshape_coeffs" / subject / f"{sentence}.csv")
    from blendvoca.assets import load_index_list

    head = load_index_list("flame-head-idx")
    frames = corpus.frames(subject, sentence)[:, head]
    neutral_error = np.sqrt(np.mean((frames - rig.neutral[head]) ** 2))
    fitted_error = np.sqrt(np.mean((rig.evaluate(coeffs)[:, head] - frames) ** 2))
    assert fitted_error < neutral_error  # the fit explains part of the motion
    record = json.loads((built_dataset / ".buildstate" / "sentences" / subject / f"{sentence}.json").read_text())
    assert 0 < record["stats"]["rmse_mm"] < 10


def test_rerun_does_nothing(built_dataset, synthetic_corpus, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(built_dataset, out)
    lock = out / ".buildstate" / "lock"  # holds the pid of the build running now

    def tree():
        return {rel: data for rel, data in _tree(out, skip_state=False).items() if rel != ".buildstate/lock"}

    before = tree()
    mtimes = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p != lock}
    summary = build_dataset(out, synthetic_corpus, workers=1)
    assert summary.built == {"speakers": 0, "sentences": 0} and summary.ok
    assert summary.skipped["sentences"] == 12
    assert tree() == before
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p != lock} == mtimes


def test_changed_parameter_and_input_rebuild_only_dependents(built_dataset, synthetic_corpus, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(built_dataset, out)
    corpus_copy = tmp_path / "corpus"
    shutil.copytree(synthetic_corpus, corpus_copy)
    corpus = open_vocaset(corpus_copy)
    subject = corpus.subjects[1]
    sentence = corpus.sentences(subject)[0]
    # A changed input: this sentence's audio.
    wav = corpus_copy / "audio" / subject / f"{sentence}.wav"
    import soundfile

    samples, rate = soundfile.read(wav)
    soundfile.write(wav, samples * 0.5, rate)
    summary = build_dataset(out, corpus_copy, workers=1, report=False)
    assert summary.built == {"speakers": 0, "sentences": 1}
    # A changed parameter: every fit, no rig.
    summary = build_dataset(out, corpus_copy, workers=1, delta=0.2, report=False)
    assert summary.built == {"speakers": 0, "sentences": 12}
    assert json.loads((out / "manifest.json").read_text())["parameters"]["delta"] == 0.2


def test_failed_sentence_is_reported_and_the_build_carries_on(built_dataset, synthetic_corpus, tmp_path, capsys):
    out = tmp_path / "copy"
    shutil.copytree(built_dataset, out)
    corpus_copy = tmp_path / "corpus"
    shutil.copytree(synthetic_corpus, corpus_copy)
    subject = open_vocaset(corpus_copy).subjects[0]
    (corpus_copy / "audio" / subject / "sentence02.wav").unlink()
    code = main(["--vocaset", str(corpus_copy), "--out", str(out), "--workers", "1", "--quiet"])
    assert code == EXIT_PARTIAL
    assert "FAILED" in capsys.readouterr().err
    report = (out / "report" / "README.md").read_text()
    assert "## Failures" in report and subject in report
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["failures"][0]["sentence"] == "sentence02"
    # The other sentences are still there.
    assert (out / "blendshape_coeffs" / subject / "sentence01.csv").is_file()


@pytest.mark.slow
def test_killed_build_resumes_to_identical_outputs(built_dataset, synthetic_corpus, tmp_path):
    out = tmp_path / "killed"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    cmd = [sys.executable, "-m", "blendvoca.build", "--vocaset", str(synthetic_corpus), "--out", str(out),
           "--workers", "2", "--quiet"]
    process = subprocess.Popen(cmd, env=env, start_new_session=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 600
        # Kill (SIGKILL, no clean-up) once the first sentences are recorded as done (their
        # stage records are written after their files, so a written CSV alone is not enough).
        while time.time() < deadline and process.poll() is None:
            done = list((out / STATE_DIR / "sentences").rglob("*.json")) if out.exists() else []
            if len(done) >= 2:
                break
            time.sleep(0.05)
        assert process.poll() is None, "the build finished before it could be killed"
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert not (out / "manifest.json").exists()
    summary = build_dataset(out, synthetic_corpus, workers=2)
    assert summary.ok and summary.skipped["speakers"] == 6 and summary.skipped["sentences"] >= 1
    assert _tree(out) == _tree(built_dataset)


def test_helpers_closed_forms():
    frames = np.zeros((2, 5, 3))
    frames[1, 3] = [0, 0.003, 0.004]
    np.testing.assert_allclose(lip_aperture(frames, 3, 0), [0.0, 0.005])
    faces = np.array([[0, 1, 2], [2, 3, 4], [1, 2, 3]])
    np.testing.assert_array_equal(head_faces(faces, np.array([3, 2, 1]), 5), [[2, 1, 0]])
    tracks = [np.array([[0.0], [1.0]]), np.array([[0.0], [1.0]])]
    np.testing.assert_allclose(coeffs_std(tracks), [0.5])
