"""Untrusted corpus files and names, broken method plug-ins, and the synthetic CLI's checks."""

from __future__ import annotations

import json
import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

from blendvoca.errors import DataError
from blendvoca.vocaset import UnsafeNameError, open_vocaset
from blendvoca.vocaset.processed import UnsafePickleError, load_data_pickle
from tests.faults.conftest import assert_one_error_line, build_cli

# ----------------------------------------------------------------------------- pickles run no code


class _MakesADirectory:
    """What a crafted pickle does: call a function of the attacker's choice while loading."""

    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return (os.mkdir, (self.path,))


def _processed_copy(tmp_path, small_processed):
    root = tmp_path / "P"
    shutil.copytree(small_processed, root)
    return root


def _load(path):
    with open(path, "rb") as f:
        return pickle.load(f, encoding="latin1")


def _dump(obj, path):
    with open(path, "wb") as f:
        pickle.dump(obj, f, protocol=2)


@pytest.mark.parametrize("name", ["templates.pkl", "subj_seq_to_idx.pkl", "raw_audio_fixed.pkl"])
def test_a_crafted_pickle_runs_no_code(tmp_path, small_processed, capsys, name):
    root = _processed_copy(tmp_path, small_processed)
    target = tmp_path / "pwned"
    data = _load(root / name)
    subject = next(iter(data))
    data[subject] = {"sentence01": _MakesADirectory(str(target))} if name != "templates.pkl" else \
        _MakesADirectory(str(target))
    _dump(data, root / name)
    with pytest.raises(UnsafePickleError, match=rf"{name}: refusing to load posix.mkdir"):
        open_vocaset(root)
    code, err = build_cli(capsys, "--vocaset", root, "--out", tmp_path / "out", "--workers", 1)
    assert code == 2
    assert_one_error_line(err, name, "refusing to load")
    assert not target.exists()


def test_the_processed_pickles_load_as_plain_data(small_processed):
    templates = load_data_pickle(small_processed / "templates.pkl")
    audio = load_data_pickle(small_processed / "raw_audio_fixed.pkl")
    assert all(isinstance(v, np.ndarray) and v.shape == (5023, 3) for v in templates.values())
    entry = next(iter(next(iter(audio.values())).values()))
    assert entry["audio"].dtype == np.int16 and entry["sample_rate"] > 0
    # identical to what the unrestricted unpickler gives
    reference = _load(small_processed / "templates.pkl")
    for subject, vertices in reference.items():
        np.testing.assert_array_equal(templates[subject], vertices)


@pytest.mark.parametrize("cut", [1, 40, 1000])
def test_a_truncated_pickle_is_an_error_naming_the_file(tmp_path, small_processed, cut):
    root = _processed_copy(tmp_path, small_processed)
    path = root / "subj_seq_to_idx.pkl"
    path.write_bytes(path.read_bytes()[:-cut])
    with pytest.raises(UnsafePickleError, match="subj_seq_to_idx.pkl: not a readable pickle"):
        open_vocaset(root)


def test_a_pickle_that_is_not_a_dict_is_refused(tmp_path, small_processed):
    root = _processed_copy(tmp_path, small_processed)
    _dump([1, 2, 3], root / "templates.pkl")
    with pytest.raises(UnsafePickleError, match="templates.pkl: expected a dict"):
        open_vocaset(root)


# ----------------------------------------------------------------------------- names never leave --out


@pytest.mark.parametrize("name", ["templates.pkl", "subj_seq_to_idx.pkl", "raw_audio_fixed.pkl"])
def test_unsafe_subject_names_in_pickles_are_refused(tmp_path, small_processed, capsys, name):
    root = _processed_copy(tmp_path, small_processed)
    data = _load(root / name)
    data["../../ESC"] = data.pop(next(iter(data)))
    _dump(data, root / name)
    out = tmp_path / "deep" / "er" / "out"
    code, err = build_cli(capsys, "--vocaset", root, "--out", out, "--workers", 1)
    assert code == 2
    assert_one_error_line(err, name, "'../../ESC'", "not a safe file name")
    assert not (tmp_path / "ESC").exists() and not (tmp_path / "deep" / "ESC").exists() and not out.exists()


def test_unsafe_sentence_names_in_pickles_are_refused(tmp_path, small_processed):
    root = _processed_copy(tmp_path, small_processed)
    data = _load(root / "subj_seq_to_idx.pkl")
    subject = next(iter(data))
    data[subject]["../x"] = data[subject].pop("sentence01")
    _dump(data, root / "subj_seq_to_idx.pkl")
    with pytest.raises(UnsafeNameError, match=r"sentence name '\.\./x'"):
        open_vocaset(root)


@pytest.mark.parametrize("bad", [".hidden", "with space", "a" * 200])
def test_unsafe_folder_names_in_the_official_layout_are_refused(tmp_path, small_corpus, bad):
    root = tmp_path / "S"
    shutil.copytree(small_corpus, root)
    subject = sorted(p.name for p in (root / "unposedcleaneddata").iterdir())[0]
    (root / "unposedcleaneddata" / subject / "sentence01").rename(root / "unposedcleaneddata" / subject / bad)
    with pytest.raises(UnsafeNameError, match="not a safe file name"):
        open_vocaset(root)


# ----------------------------------------------------------------------------- method plug-ins


class NotAMethod:
    pass


def test_a_method_pointing_to_a_missing_module_or_a_non_method_class_is_one_error(tmp_path, small_build, capsys,
                                                                                   monkeypatch):
    import importlib.metadata

    from benchmark.methods import registry
    from benchmark.run import main

    registry.register_lazy("fault-missing-module", "no_such_module_xyz:Method")
    registry.register_lazy("fault-not-a-method", f"{__name__}:NotAMethod")
    real = registry.METHODS._entry_points
    broken = importlib.metadata.EntryPoint("fault-entry-point", "no_such_plugin_xyz:Method", registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry.METHODS, "_entry_points", lambda: {**real(), "fault-entry-point": broken})
    try:
        for name, fragments in (("fault-missing-module", ("cannot import module", "no_such_module_xyz")),
                                ("fault-not-a-method", ("must subclass", "NotAMethod")),
                                ("fault-entry-point", ("cannot load entry point", "no_such_plugin_xyz"))):
            with pytest.raises(registry.UnknownMethodError):
                registry.get_method(name)
            code = main(["--method", name, "--data", str(small_build), "--results", str(tmp_path / "r"), "--quiet"])
            assert code == 2
            assert_one_error_line(capsys.readouterr().err, *fragments)
        with pytest.raises(ImportError):  # still the exception types callers caught before
            registry.get_method("fault-missing-module")
        with pytest.raises(TypeError):
            registry.get_method("fault-not-a-method")
    finally:
        registry.unregister("fault-missing-module")
        registry.unregister("fault-not-a-method")


# ----------------------------------------------------------------------------- the synthetic CLI


@pytest.mark.parametrize("args, fragment", [
    (["--speakers", "2"], "--speakers"), (["--sentences", "0"], "--sentences"), (["--seed", "-1"], "--seed"),
    (["--min-duration", "0"], "duration"), (["--min-duration", "2", "--max-duration", "1"], "duration"),
    (["--max-duration", "inf"], "duration"),
])
def test_synthetic_arguments_are_checked_first(tmp_path, capsys, args, fragment):
    from blendvoca.synthetic.__main__ import main

    out = tmp_path / "S"
    assert main(["--out", str(out), "--quiet", *args]) == 2
    assert_one_error_line(capsys.readouterr().err, fragment)
    assert not out.exists()


def test_synthetic_refuses_to_replace_what_it_did_not_write(tmp_path, capsys):
    from blendvoca.synthetic.__main__ import main

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("precious")
    for extra in ([], ["--overwrite"]):
        assert main(["--out", str(mine), "--speakers", "3", "--sentences", "1", "--quiet", *extra]) == 2
        assert_one_error_line(capsys.readouterr().err, str(mine))
    assert (mine / "thesis.tex").read_text() == "precious"
    afile = tmp_path / "file"
    afile.write_text("x")
    assert main(["--out", str(afile), "--quiet"]) == 2
    assert_one_error_line(capsys.readouterr().err, "is a file")


def test_reproduction_corpus_generates(tmp_path, capsys):
    from blendvoca.synthetic.__main__ import main

    out = tmp_path / "S"
    assert main(["--out", str(out), "--speakers", "3", "--sentences", "2", "--seed", "1", "--min-duration", "1",
                 "--max-duration", "1.5", "--quiet"]) == 0
    assert sorted(p.name for p in (out / "templates").iterdir()) and (out / "synthetic.json").is_file()
    assert Path(out).is_dir()


def test_a_malformed_frame_index_fails_only_its_sentence(tmp_path, small_processed, small_build):
    from blendvoca.builder import build_dataset

    root = _processed_copy(tmp_path, small_processed)
    index = _load(root / "subj_seq_to_idx.pkl")
    subject = sorted(index)[0]
    index[subject]["sentence02"] = [1, 2, 3]  # a list, not {frame: row}
    _dump(index, root / "subj_seq_to_idx.pkl")
    corpus = open_vocaset(root)
    assert "sentence02" not in corpus.sentences(subject)
    assert {(p.subject, p.sentence) for p in corpus.problems} == {(subject, "sentence02")}
    assert "unreadable" in {p.kind for p in corpus.problems}
    out = tmp_path / "out"
    shutil.copytree(small_build, out)  # same arrays in the other layout: every rig and sentence is up to date
    summary = build_dataset(out, root, workers=1, report=False)
    assert summary.built == {"speakers": 0, "sentences": 0}
    assert [(f["subject"], f["sentence"], f["stage"]) for f in summary.failures] == [(subject, "sentence02", "input")]
    assert "expected {frame (int)" in summary.failures[0]["reason"]


# ----------------------------------------------------------------------------- arrays read as numbers only


def test_an_object_array_data_verts_is_refused_before_it_is_mapped(tmp_path, small_processed, capsys):
    root = _processed_copy(tmp_path, small_processed)
    verts = np.load(root / "data_verts.npy")
    objects = np.empty(verts.shape[:1], dtype=object)
    objects[:] = list(verts)  # one (5023, 3) array per row: what np.save writes as a pickle behind an 'O' header
    np.save(root / "data_verts.npy", objects, allow_pickle=True)
    with pytest.raises(DataError, match="data_verts.npy.*dtype object"):
        open_vocaset(root)
    code, err = build_cli(capsys, "--vocaset", root, "--out", tmp_path / "out", "--workers", 2)
    assert code == 2
    assert_one_error_line(err, str(root / "data_verts.npy"), "dtype object")
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------- plausibility


def test_a_template_in_millimetres_fails_its_speaker_naming_the_scale(tmp_path, small_corpus, capsys):
    from blendvoca.io.mesh import read_mesh, write_mesh

    corpus = tmp_path / "S"
    shutil.copytree(small_corpus, corpus)
    template = corpus / "templates" / "Synth_000_TA.ply"
    vertices, faces = read_mesh(template)
    write_mesh(template, vertices * 1000.0, faces)
    out = tmp_path / "out"
    code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1, "--no-report")
    assert code == 5
    failed = [line for line in err.splitlines() if line.startswith("FAILED Synth_000_TA  (rig)")]
    assert len(failed) == 1 and "RMS radius" in failed[0] and "(millimetres?)" in failed[0], err
    assert "x FLAME's" in failed[0]
    manifest = json.loads((out / "manifest.json").read_text())
    assert {f["subject"] for f in manifest["failures"]} == {"Synth_000_TA"}
    assert not (out / "rigs" / "Synth_000_TA.npz").exists() and (out / "rigs" / "Synth_001_TA.npz").is_file()


@pytest.mark.parametrize("factor, shown", [(0.5, "-50.0 %"), (1.37, "+37.0 %")])
def test_audio_and_motion_of_different_lengths_are_a_warning_naming_both(tmp_path, small_corpus, capsys,
                                                                          factor, shown):
    from blendvoca.io.audio import write_wav

    corpus = tmp_path / "S"
    shutil.copytree(small_corpus, corpus)
    opened = open_vocaset(corpus)
    samples, rate = opened.audio("Synth_001_TA", "sentence01")
    frames = opened.frames("Synth_001_TA", "sentence01").shape[0]
    n = int(round(len(samples) * factor))
    write_wav(corpus / "audio" / "Synth_001_TA" / "sentence01.wav", np.resize(samples, n), rate)
    out = tmp_path / "out"
    code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1)
    assert code == 0, err
    warnings = [line for line in err.splitlines() if line.startswith("warning:")]
    motion = f"motion {frames / 60:.3f} s"
    assert len(warnings) == 1 and "Synth_001_TA sentence01" in warnings[0], err
    assert f"audio lasts {n / rate:.3f} s" in warnings[0] and motion in warnings[0] and shown in warnings[0]
    report = (out / "report" / "README.md").read_text()
    assert "## Warnings" in report and motion in report and shown in report
    # the other sentences (durations within 5 %) raise nothing; a rerun repeats the warning
    code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1)
    assert code == 0 and len([line for line in err.splitlines() if line.startswith("warning:")]) == 1


def test_a_split_naming_a_speaker_the_corpus_lacks_is_refused(tmp_path, small_corpus, capsys):
    corpus = tmp_path / "S"
    shutil.copytree(small_corpus, corpus)
    sidecar = json.loads((corpus / "synthetic.json").read_text())
    sidecar["splits"]["test"].append("Synth_009_TA")
    (corpus / "synthetic.json").write_text(json.dumps(sidecar))
    out = tmp_path / "out"
    code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1)
    assert code == 2
    assert_one_error_line(err, "synthetic.json", "Synth_009_TA")
    assert not (out / "splits.json").exists()
