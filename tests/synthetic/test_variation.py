"""Motion the inputs do not determine: F = 1 is the old corpus bit for bit, every component has its own
random stream, the sidecar records every draw, the oracle samples, the command's refusals."""

import json
import os
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest

from blendvoca.errors import UserError
from blendvoca.synthetic import generate_corpus, read_npz
from blendvoca.synthetic import variation as var
from blendvoca.synthetic.__main__ import main
from blendvoca.synthetic.corpus import VARIED_SIGNAL_NAMES, oracle_draw
from blendvoca.synthetic.plan import sentence_plan
from blendvoca.synthetic.signals import SIGNAL_NAMES

#: The last commit before the undetermined components: its generator is the reference of F = 1.
BASELINE_COMMIT = "c68a9a8443e2323999a04cb24bb420de92301f2e"
REPO = Path(__file__).resolve().parents[2]
SMALL = dict(speakers=3, sentences=2, seed=7, duration=(1.0, 1.2))


def frozen_package(tmp_path: Path) -> Path:
    """The baseline commit's ``blendvoca`` package, extracted into ``tmp_path`` (skips without git history)."""
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("needs the git history (git archive of the baseline commit)")
    archive = subprocess.run(["git", "-C", str(REPO), "archive", BASELINE_COMMIT, "blendvoca",
                              "data_manifest.yaml"], capture_output=True, check=False)
    if archive.returncode:
        pytest.skip(f"baseline commit {BASELINE_COMMIT[:8]} is not in this clone (shallow?)")
    root = tmp_path / "frozen"
    root.mkdir()
    (tmp_path / "frozen.tar").write_bytes(archive.stdout)
    with tarfile.open(tmp_path / "frozen.tar") as tar:
        tar.extractall(root, filter="data")
    return root


def run_frozen(frozen: Path, code: str) -> None:
    """Run ``code`` with the frozen package first on the path (a fresh interpreter)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if env.get("BLENDVOCA_ASSETS"):  # the baseline package reads one asset folder (now a list may be given)
        env["BLENDVOCA_ASSETS"] = env["BLENDVOCA_ASSETS"].split(os.pathsep)[0]
    subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, {str(frozen)!r})\n{code}"],
                   cwd=frozen, env=env, check=True)


def digests(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("layout,head", [("official", 2.0), ("processed", False)])
def test_f1_is_the_old_corpus_bit_for_bit(tmp_path, assets_dir, layout, head):
    frozen = frozen_package(tmp_path)
    old = tmp_path / "old"
    kwargs = dict(SMALL, layout=layout, head_motion=head)
    run_frozen(frozen, f"from blendvoca.synthetic import generate_corpus\n"
                       f"generate_corpus({str(old)!r}, **{kwargs!r})")
    new = generate_corpus(tmp_path / "new", audio_determined=1.0, **kwargs)
    a, b = digests(old), digests(new)
    assert sorted(a) == sorted(b) and len(a) > 5
    assert [name for name in a if a[name] != b[name]] == []
    assert json.loads(b["synthetic.json"])["version"] == "1"


def test_audio_lag_and_blinks_do_not_depend_on_f(tmp_path):
    one = generate_corpus(tmp_path / "one", audio_determined=1.0, **SMALL)
    varied = generate_corpus(tmp_path / "varied", audio_determined=0.6, **SMALL)
    for subject in ("Synth_000_TA", "Synth_002_TA"):
        for sentence in ("sentence01", "sentence02"):
            wav = f"audio/{subject}/{sentence}.wav"
            assert (one / wav).read_bytes() == (varied / wav).read_bytes()
            a = read_npz(one / "groundtruth" / subject / f"{sentence}.npz")
            b = read_npz(varied / "groundtruth" / subject / f"{sentence}.npz")
            # the old per-sentence stream is drawn from exactly as before: same plan, lag, blinks
            assert int(a["lag_frames"]) == int(b["lag_frames"])
            np.testing.assert_array_equal(a["phone_ends"], b["phone_ends"])
            np.testing.assert_array_equal(a["blink"], b["blink"])
            assert not np.array_equal(a["jaw"], b["jaw"])
        assert (one / f"templates/{subject}.ply").read_bytes() == (varied / f"templates/{subject}.ply").read_bytes()


def test_component_streams_are_spawned_children():
    seed = 11
    child = np.random.SeedSequence([seed, var.STREAM_KIND]).spawn(len(var.COMPONENTS))[var.COMPONENTS.index("onset")]
    expected = np.random.default_rng(child.spawn(3)[2]).random(4)  # spawn key (index, 2)
    np.testing.assert_array_equal(var.component_rng(seed, "onset", 2).random(4), expected)
    assert not np.array_equal(var.component_rng(seed, "onset", 2).random(4),
                              var.component_rng(seed, "intensity", 2).random(4))
    with pytest.raises(ValueError, match="unknown component"):
        var.component_rng(seed, "nope", 0)


def _draws(plan, num_frames):
    style = var.speaker_style(5, 1)
    drawn = var.sentence_variation(5, 1, 0, 0, plan, num_frames, style, 1.0)
    return style, drawn


def test_adding_or_changing_a_component_leaves_the_others_draws(monkeypatch):
    plan = sentence_plan(np.random.default_rng(3), 3.0)
    style, base = _draws(plan, 180)
    # A new component appended to the list: every existing stream is the same.
    monkeypatch.setattr(var, "COMPONENTS", (*var.COMPONENTS, "new-component"))
    style2, appended = _draws(plan, 180)
    assert style2 == style
    for key, value in base.arrays.items():
        np.testing.assert_array_equal(appended.arrays[key], value, err_msg=key)
    monkeypatch.undo()
    # One component drawing more (or being switched off) leaves the others' draws alone.
    original = var.draw_pauses

    def greedy_pauses(rng, plan, scale):
        rng.random(1000)
        return original(rng, plan, scale)

    monkeypatch.setattr(var, "draw_pauses", greedy_pauses)
    _, changed = _draws(plan, 180)
    for key in ("intensity_utterance", "intensity_phrases", "intensity_drift", "onset_shifts"):
        np.testing.assert_array_equal(changed.arrays[key], base.arrays[key], err_msg=key)
    monkeypatch.setattr(var, "draw_pauses", lambda rng, plan, scale: np.zeros((0, 4)))
    _, off = _draws(plan, 180)
    np.testing.assert_array_equal(off.arrays["onset_shifts"], base.arrays["onset_shifts"])
    np.testing.assert_array_equal(off.arrays["intensity_gain"], base.arrays["intensity_gain"])


def test_components_are_bounded_and_scaled():
    plan = sentence_plan(np.random.default_rng(4), 4.0)
    shifts = var.draw_onsets(np.random.default_rng(0), plan, 1.0)
    lengths = plan.ends - plan.starts
    assert np.all(np.abs(shifts) <= var.ONSET["limit_sd"] * var.ONSET["sd_s"] + 1e-12)
    moved = var.jittered_plan(plan, shifts)
    assert np.all(moved.ends - moved.starts >= 0.29 * lengths) and moved.ends[-1] == plan.ends[-1]
    assert np.all(var.draw_onsets(np.random.default_rng(0), plan, 0.0) == 0)
    gain = var.draw_intensity(np.random.default_rng(0), plan, 240, 1.0)["gain"]
    assert np.all(gain > 0) and 0.02 < np.log(gain).std() < 0.5  # phrase levels and drift (the utterance level is constant)
    np.testing.assert_array_equal(var.draw_intensity(np.random.default_rng(0), plan, 240, 0.0)["gain"], 1.0)
    gestures = var.draw_pauses(np.random.default_rng(1), plan, 1.0)
    signals = var.gesture_signals(gestures, 240, 1)
    assert set(signals) == set(var.GESTURE_SIGNALS)
    assert all(s.min() >= 0 and s.max() <= 1 for s in signals.values())
    speech = [(a, b) for p, a, b in zip(plan.phones, plan.starts, plan.ends) if p != "_"]
    for kind, start, duration, _ in gestures:  # gestures stay inside pauses
        assert not any(start < b - 1e-9 and start + duration > a + 1e-9 for a, b in speech)


def test_sidecar_and_groundtruth_record_every_component(tmp_path):
    out = generate_corpus(tmp_path / "c", audio_determined=0.6, oracle_samples=3, **SMALL)
    meta = json.loads((out / "synthetic.json").read_text())
    settings = meta["audio_determined"]
    assert settings["declared"] == 0.6 and settings["scale"] == var.undetermined_scale(0.6)
    assert set(settings["components"]) == set(var.COMPONENTS)
    assert "Perkell" in settings["components"]["onset"]["source"]
    style = meta["subjects"]["Synth_001_TA"]["style"]
    assert style == var.speaker_style(7, 1) and set(style["targets"]) == set(var.PHONE_CLASSES)
    assert meta["version"] == "2" and meta["oracle_samples"]["count"] == 3
    assert 0 < meta["oracle_samples"]["measured_signal_share"] < 1
    gt = read_npz(out / "groundtruth" / "Synth_001_TA" / "sentence02.npz")
    for key in (*VARIED_SIGNAL_NAMES, "intensity_gain", "intensity_drift", "intensity_phrases",
                "intensity_utterance", "onset_shifts", "motion_phone_starts", "pause_gestures"):
        assert key in gt, key
    oracle = read_npz(out / "oracle" / "Synth_001_TA" / "sentence02.npz")
    T = len(gt["jaw"])
    assert oracle["jaw"].shape == (3, T) and oracle["lag_frames"].shape == (3,)
    assert oracle["onset_shifts"].shape == (3, len(gt["onset_shifts"]))
    assert oracle["pause_gestures"].shape[1] == 5
    # fresh draws: every sample differs from the ground truth and from the others
    for k in range(3):
        assert not np.array_equal(oracle["jaw"][k], gt["jaw"])
    assert not np.array_equal(oracle["jaw"][0], oracle["jaw"][1])


def test_oracle_draw_is_the_ground_truths_distribution_at_f1():
    plan = sentence_plan(np.random.default_rng(2), 3.0)
    profile = {"jaw_gain": 1.0, "round_gain": 1.0, "brow_gain": 0.7, "blink_rate": 0.3}
    draw = oracle_draw(plan, 180, profile, seed=0, speaker=0, sentence=0, sample=1, style=None, scale=0.0)
    assert draw["variation"] is None and set(SIGNAL_NAMES) <= set(draw["signals"])
    assert abs(draw["lag_frames"]) <= 2
    again = oracle_draw(plan, 180, profile, seed=0, speaker=0, sentence=0, sample=1, style=None, scale=0.0)
    np.testing.assert_array_equal(draw["signals"]["jaw"], again["signals"]["jaw"])


def test_processed_layout_has_head_motion_too(tmp_path):
    from blendvoca.synthetic.headpose import apply_pose
    from blendvoca.vocaset import open_vocaset

    out = generate_corpus(tmp_path / "p", layout="processed", head_motion=2.0, audio_determined=1.0, **SMALL)
    corpus = open_vocaset(out)
    posed = np.load(out / "data_verts_posed.npy", mmap_mode="r")
    rows = corpus.frame_rows("Synth_001_TA", "sentence02")
    gt = read_npz(out / "groundtruth" / "Synth_001_TA" / "sentence02.npz")
    expected = apply_pose(corpus.frames("Synth_001_TA", "sentence02"), gt["head_rotations"], gt["head_translations"])
    np.testing.assert_allclose(posed[rows], expected, atol=2e-7)
    where = json.loads((out / "synthetic.json").read_text())["head_motion"]["posed_frames"]
    assert where.startswith("data_verts_posed")
    # the processed reader serves them like the official reader serves registereddata/
    assert corpus.has_posed("Synth_001_TA", "sentence02")
    np.testing.assert_array_equal(corpus.posed_frames("Synth_001_TA", "sentence02"), posed[rows].astype(np.float64))
    plain = open_vocaset(generate_corpus(tmp_path / "q", layout="processed", audio_determined=1.0, **SMALL))
    assert not plain.has_posed("Synth_001_TA", "sentence02")
    from blendvoca.vocaset import VocasetError

    with pytest.raises(VocasetError, match="data_verts_posed.npy"):
        plain.posed_frames("Synth_001_TA", "sentence02")


def test_undetermined_scale_covers_what_it_can_make():
    assert var.undetermined_scale(1.0) == 0.0
    shares = [f for _, f in var.CALIBRATION]
    scales = [var.undetermined_scale(f) for f in shares]
    assert scales == sorted(scales)
    for bad in (0.0, -0.1, 1.2, float("nan")):
        with pytest.raises(UserError, match="0 < F <= 1"):
            var.undetermined_scale(bad)
    with pytest.raises(UserError, match="cannot be made"):
        var.undetermined_scale((shares[0] + 1.0) / 2)
    with pytest.raises(UserError, match="below what"):
        var.undetermined_scale(shares[-1] / 2)


def test_command_refuses_bad_f_and_k(tmp_path, capsys):
    base = ["--speakers", "3", "--sentences", "1", "--min-duration", "1", "--max-duration", "1.1", "--quiet"]
    assert main(["--out", str(tmp_path / "a"), "--audio-determined", "0", *base]) == 2
    assert "--audio-determined: expected 0 < F <= 1" in capsys.readouterr().err
    assert main(["--out", str(tmp_path / "b"), "--audio-determined", "0.97", *base]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "cannot be made" in err[0]
    assert main(["--out", str(tmp_path / "c"), "--oracle-samples", "-1", *base]) == 2
    assert "--oracle-samples" in capsys.readouterr().err
    assert not any((tmp_path / name).exists() for name in "abc")
    assert main(["--out", str(tmp_path / "d"), "--oracle-samples", "2", *base]) == 0
    printed = capsys.readouterr().out
    assert "declared F = 0.7" in printed and "2 oracle samples" in printed


@pytest.mark.slow  # two builds of 3 x 2 short sentences (about 15 s on 2 cores)
def test_a_build_of_the_old_corpus_is_the_old_build(tmp_path, assets_dir):
    """The build of a corpus without oracle samples writes what the baseline commit's build wrote."""
    from blendvoca.builder import build_dataset

    frozen = frozen_package(tmp_path)
    corpus, old = tmp_path / "corpus", tmp_path / "old"
    kwargs = dict(SMALL, audio_determined=1.0)
    generate_corpus(corpus, **kwargs)
    run_frozen(frozen, f"from blendvoca.builder import build_dataset\n"
                       f"assert build_dataset({str(old)!r}, {str(corpus)!r}, workers=2).ok")
    new = tmp_path / "new"
    assert build_dataset(new, corpus, workers=2).ok
    a, b = json.loads((old / "manifest.json").read_text()), json.loads((new / "manifest.json").read_text())
    # ``blas`` records the BLAS libraries loaded in the building process (this test
    # session loads more than a fresh interpreter): the environment, not the data
    a.pop("blas", None), b.pop("blas", None)
    # the dataset identity (recipe id, per-file tolerances) came after the baseline commit:
    # records about the build, not its files, which must be the same
    assert set(b) - set(a) == {"recipe", "tolerances"}
    b.pop("recipe"), b.pop("tolerances")
    # the report's pictures (the rig sheet, the worst fit) came after it too, and the report links them
    assert set(b["files"]) - set(a["files"]) == {"report/rigs.png", "report/worst_fit.png"}
    for name in ("report/rigs.png", "report/worst_fit.png", "report/README.md"):
        a["files"].pop(name, None), b["files"].pop(name, None)
    assert a == b
    assert not (new / "oracle_coeffs").exists() and not (new / ".buildstate" / "oracle").exists()
