"""The FACEGOOD adapter (--dataset facegood): its layout written by tests/datasets/corpora.py, the
map onto ARKit, splits by take, utterances, bad input, and the real takes through the asset resolver."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from blendvoca import format as fmt
from blendvoca.builder.__main__ import main as build_main
from blendvoca.datasets import adapter
from blendvoca.datasets.facegood import ASSET_IDS, DEFAULT_SPLITS
from blendvoca.datasets.utterances import MAX_S, MIN_S
from blendvoca.errors import UserError
from blendvoca.names import FACEGOOD116, FACEGOOD_TO_ARKIT, FACEGOOD_UNMAPPED, controls_to_arkit, convention
from tests.datasets.corpora import write_facegood


def _wav_seconds(path) -> float:
    from blendvoca.io.audio import read_wav

    samples, rate = read_wav(path)
    return len(samples) / rate


def _build(root, out, **options):
    return adapter("facegood")(root, out, **options)


def _check_utterances(out, takes_seconds: dict):
    """Every take's utterances cover it without gap or overlap, in order; returns their lengths."""
    utterances = fmt.read_utterances(out)
    by_take = {}
    for key, record in utterances.items():
        by_take.setdefault(record["take"], []).append((record["start_frame"], record["end_frame"], key))
        coeffs, _ = fmt.read_coeffs(out, *key.split("/"))
        samples, rate = fmt.read_audio(out, *key.split("/"))
        assert len(coeffs) == record["end_frame"] - record["start_frame"]
        assert abs(len(samples) / rate - len(coeffs) / 60) < 1 / 60
    lengths = []
    for take, spans in by_take.items():
        spans.sort()
        assert spans[0][0] == 0 and all(a[1] == b[0] for a, b in zip(spans, spans[1:]))
        assert abs(spans[-1][1] / 60 - takes_seconds[take]) < 2 / 60
        assert len({key.split("/")[0] for *_, key in spans}) == 1  # a take is one subject of the folder
        lengths += [(b - a) / 60 for a, b, _ in spans]
    return lengths


def test_facegood116_is_the_names_order_and_the_map_forms_arkit_shapes_in_range():
    entry = convention("facegood116")
    assert entry.controls == FACEGOOD116 and entry.count == len(FACEGOOD116) == 116 == len(set(FACEGOOD116))
    assert "jawOpen" not in entry.lacks and "mouthClose" in entry.lacks and entry.unverified
    mapped = {c for m in FACEGOOD_TO_ARKIT for c, _ in m.terms}
    assert mapped.isdisjoint(c for c, _ in FACEGOOD_UNMAPPED) and mapped | {c for c, _ in FACEGOOD_UNMAPPED} == set(
        FACEGOOD116)
    values = np.zeros((3, 116))
    k = {n: i for i, n in enumerate(FACEGOOD116)}
    values[0, k["mouth_stretch_c"]], values[0, k["mouth_oh_c"]] = 0.4, 0.8
    values[1, k["mouth_stretch_c"]], values[1, k["mouth_oh_c"]] = 0.95, 1.0
    values[2, k["mouth_lipCornerPull_l"]], values[2, k["mouth_funnel_ul"]] = 0.7, 0.8
    track, names = controls_to_arkit(values, FACEGOOD116, "facegood116")
    column = {n: i for i, n in enumerate(names)}
    assert np.allclose(track[:, column["jawOpen"]], [0.6, 1.0, 0.0])  # stretch + 0.25 oh, clipped to 1
    assert track[2, column["mouthSmileLeft"]] == 0.7 and track[2, column["mouthSmileRight"]] == 0.0
    assert np.isclose(track[2, column["mouthFunnel"]], 0.2)  # the mean of the four lip quarters
    assert track.min() >= 0 and track.max() <= 1
    with pytest.raises(UserError, match=r"expected a \(T, 116\) track"):
        controls_to_arkit(values[:, :115], FACEGOOD116, "facegood116")
    with pytest.raises(UserError, match=r"needs controls the names lack: \['mouth_stretch_c'\]$"):
        controls_to_arkit(values[:, :115], tuple(n for n in FACEGOOD116 if n != "mouth_stretch_c"), "facegood116")
    with pytest.raises(UserError, match="no map of rig controls"):
        controls_to_arkit(values, FACEGOOD116, "arkit52")


def test_a_facegood_root_builds_utterances_split_by_take(tmp_path):
    written = write_facegood(tmp_path / "fg")
    summary = _build(tmp_path / "fg", tmp_path / "out")
    assert not summary.failures and summary.built["speakers"] == 7
    splits = fmt.read_splits(tmp_path / "out")
    assert splits == {name: sorted(t for t, s in DEFAULT_SPLITS.items() if s == name) for name in splits}
    assert sum(len(v) for v in splits.values()) == len({t for v in splits.values() for t in v}) == 7  # disjoint
    lengths = _check_utterances(tmp_path / "out", {t: len(v) / 30 for t, v in written.items()})
    assert len(lengths) >= 14 and MIN_S <= min(lengths) and max(lengths) <= MAX_S
    # the written tracks are the map of the controls, at 60 fps (even frames are the 30 fps frames)
    utterances = fmt.read_utterances(tmp_path / "out")
    key, record = next((k, r) for k, r in utterances.items() if r["start_frame"] % 2 == 0 and r["take"] == "1114_2_03")
    coeffs, names = fmt.read_coeffs(tmp_path / "out", *key.split("/"))
    expected, arkit = controls_to_arkit(written["1114_2_03"], FACEGOOD116, "facegood116")
    first = record["start_frame"] // 2
    for shape in ("jawOpen", "mouthFunnel", "mouthLowerDownLeft"):
        got = coeffs[::2, names.index(shape)]
        assert np.allclose(got, expected[first:first + len(got), arkit.index(shape)], atol=1e-6)  # the CSV keeps 6 decimals
    report = (tmp_path / "out" / "report" / "README.md").read_text()
    assert "## Utterances" in report and "tongue" in report and "speech_tracks.png" in report
    assert "report/speech_tracks.png" in fmt.listed_files(tmp_path / "out")


def test_bad_takes_fail_alone_naming_the_file_and_what_was_expected(tmp_path):
    write_facegood(tmp_path / "fg")
    fg = tmp_path / "fg"
    np.save(fg / "bs_value_1114_2_02.npy", np.full((300, 116), 1.5))
    bad = np.load(fg / "bs_value_1114_2_03.npy")
    bad[10, 5] = np.nan
    np.save(fg / "bs_value_1114_2_03.npy", bad)
    (fg / "1114_2_04.wav").unlink()
    np.save(fg / "bs_value_1114_3_16.npy", np.zeros((45, 116)))  # 1.5 s
    (fg / "1114_3_16.wav").write_bytes((fg / "1114_3_15.wav").read_bytes())
    summary = _build(fg, tmp_path / "out")
    reasons = {f["subject"]: f["reason"] for f in summary.failures}
    assert set(reasons) == {"1114_2_02", "1114_2_03", "1114_2_04", "1114_3_16"}
    assert "bs_value_1114_2_02.npy: value 1.5 at frame 0, control 'brow_lower_l'" in reasons["1114_2_02"]
    assert "expected rig controls in [0, 1]" in reasons["1114_2_02"]
    assert "value nan at frame 10, control 'tongue_Scale_Z'; expected finite values" in reasons["1114_2_03"]
    assert "1114_2_04.wav: no such file; the take bs_value_1114_2_04.npy needs its speech" in reasons["1114_2_04"]
    assert "shorter than one utterance (2 s)" in reasons["1114_3_16"]
    assert fmt.read_splits(tmp_path / "out") == {"train": ["1114_2_01"], "val": ["1114_2_05"], "test": ["1114_3_15"]}
    assert "## Failed" in (tmp_path / "out" / "report" / "README.md").read_text()


def test_a_names_file_of_another_length_fails_every_take_with_one_error_line(tmp_path, capsys):
    write_facegood(tmp_path / "fg", takes=("1114_2_01",), seconds=5.0)
    np.save(tmp_path / "fg" / "bs_names_1015.npy", np.array(FACEGOOD116[:115]))
    code = build_main(["--dataset", "facegood", "--root", str(tmp_path / "fg"), "--out", str(tmp_path / "out"),
                       "--quiet"])
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error:")]
    assert code == 2 and len(err) == 1
    assert "bs_value_1114_2_01.npy: 116 columns, but" in err[0] and "names 115 controls" in err[0]
    assert not fmt.manifest_path(tmp_path / "out").exists()


def test_fewer_takes_than_splits_go_to_test_and_say_so(tmp_path):
    write_facegood(tmp_path / "fg", takes=("1114_2_01", "1114_2_02"), seconds=8.0)
    summary = _build(tmp_path / "fg", tmp_path / "out")
    assert fmt.read_splits(tmp_path / "out") == {"train": [], "val": [], "test": ["1114_2_01", "1114_2_02"]}
    assert any("all are in the test split" in w["message"] for w in summary.warnings)
    assert "all are in the test split" in (tmp_path / "out" / "report" / "README.md").read_text()


def test_the_users_cut_list_is_honoured_and_a_bad_one_refused(tmp_path, capsys):
    written = write_facegood(tmp_path / "fg", takes=("1114_2_01", "1114_2_05", "1114_3_15"), seconds=12.0)
    cuts = tmp_path / "cuts.json"
    cuts.write_text(json.dumps({"1114_2_01": [3.0, 7.5], "1114_3_15": []}))
    argv = ["--dataset", "facegood", "--root", str(tmp_path / "fg"), "--out", str(tmp_path / "out"), "--quiet"]
    assert build_main(argv + ["--cuts", str(cuts)]) == 0
    utterances = fmt.read_utterances(tmp_path / "out")
    spans = sorted((r["start_s"], r["end_s"], r["cut"]) for r in utterances.values() if r["take"] == "1114_2_01")
    assert spans == [(0.0, 3.0, "user"), (3.0, 7.5, "user"), (7.5, len(written["1114_2_01"]) / 30, "end")]
    assert [(r["start_s"], r["cut"]) for r in utterances.values() if r["take"] == "1114_3_15"] == [(0.0, "end")]
    assert fmt.read_manifest(tmp_path / "out")["recipe"]["parameters"]["cuts"]["1114_2_01"] == [3.0, 7.5]
    capsys.readouterr()
    cuts.write_text(json.dumps({"1114_9_99": [3.0]}))
    assert build_main(argv[:-3] + ["--out", str(tmp_path / "other"), "--cuts", str(cuts)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert err[-1].startswith("error: --cuts") and "takes not in the corpus: ['1114_9_99']" in err[-1]
    assert not (tmp_path / "other").exists()
    assert build_main(["--dataset", "beat", "--root", str(tmp_path / "fg"), "--out", str(tmp_path / "o2"),
                       "--cuts", str(cuts)]) == 2  # BEAT's layout error, the option itself is accepted
    with pytest.raises(SystemExit):
        build_main(["--vocaset", str(tmp_path / "fg"), "--out", str(tmp_path / "o3"), "--cuts", str(cuts)])


def test_the_real_takes_build_through_the_asset_resolver(realdata_resolver, tmp_path, capsys):
    """The seven takes of FACEGOOD-Audio2Face (../shared/realdata) without --root: names order,
    splits by take, utterances of 2-10 s covering every take, the map's jaw on the real values."""
    from blendvoca.assets import resolve

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        names = np.load(resolve("facegood-names"), allow_pickle=False, encoding="latin1")
    assert tuple(names.tolist()) == FACEGOOD116
    assert len(ASSET_IDS) == 15
    assert build_main(["--dataset", "facegood", "--out", str(tmp_path / "out"), "--quiet"]) == 0
    out = tmp_path / "out"
    assert fmt.read_manifest(out)["dataset"]["root"] == str((realdata_resolver / "facegood").resolve())
    assert fmt.read_splits(out) == {"train": ["1114_2_01", "1114_2_02", "1114_2_03", "1114_2_04"],
                                    "val": ["1114_2_05"], "test": ["1114_3_15", "1114_3_16"]}
    seconds = {}
    for take in DEFAULT_SPLITS:
        short = take.replace("_", "-")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            frames = len(np.load(resolve(f"facegood-{short}-values")))
        seconds[take] = min(frames / 30, _wav_seconds(resolve(f"facegood-{short}-wav")))
    lengths = _check_utterances(out, seconds)
    assert len(lengths) >= 100 and MIN_S <= min(lengths) and max(lengths) <= MAX_S
    assert 650 < sum(lengths) < 657  # the 10.9 minutes, cut to the audio where it is shorter
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        values = np.load(resolve("facegood-1114-3-15-values"))
    k = {n: i for i, n in enumerate(FACEGOOD116)}
    key = next(k2 for k2, r in fmt.read_utterances(out).items() if r["take"] == "1114_3_15" and r["start_frame"] == 0)
    coeffs, cols = fmt.read_coeffs(out, *key.split("/"))
    jaw = np.clip(values[:, k["mouth_stretch_c"]] + 0.25 * values[:, k["mouth_oh_c"]], 0, 1)
    assert np.allclose(coeffs[::2, cols.index("jawOpen")], jaw[: len(coeffs[::2])], atol=1e-6)  # the CSV keeps 6 decimals


def test_a_take_outside_the_default_splits_and_a_root_without_names_file(tmp_path, capsys):
    write_facegood(tmp_path / "fg", takes=("1114_2_01", "1114_2_05", "1114_3_15", "1114_2_06"), seconds=6.0)
    summary = _build(tmp_path / "fg", tmp_path / "out")
    splits = fmt.read_splits(tmp_path / "out")
    assert sorted(t for v in splits.values() for t in v) == ["1114_2_01", "1114_2_05", "1114_2_06", "1114_3_15"]
    assert all(splits.values()) and any("names 3 of the 4" in w["message"] for w in summary.warnings)
    (tmp_path / "fg" / "bs_names_1015.npy").unlink()
    code = build_main(["--dataset", "facegood", "--root", str(tmp_path / "fg"), "--out", str(tmp_path / "o2")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("error: --root") and "no bs_names_1015.npy" in err[-1]
    assert not (tmp_path / "o2").exists()
