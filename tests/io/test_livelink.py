"""The Live Link Face CSV's one owner: takes written in the app's format (both header
spellings, a 60 fps clock on rows captured at 59.94 or 60 fps, drop-frame timecodes)
read back with their rate, rotations and dropped frames; bad files refused naming the
file and what was expected."""

from __future__ import annotations

import numpy as np
import pytest

from blendvoca.errors import DataError
from blendvoca.io.livelink import (
    format_livelink_csv,
    livelink_timecode,
    parse_livelink_timecode,
    read_livelink_take,
    write_livelink_take,
)
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_HEADER, LIVELINK_ROTATION_COLUMNS
from tests.datasets.livelink_fixtures import NTSC_60, clock_take, pose_at, weights_at


@pytest.mark.parametrize("spelling", ["BlendShapeCount", "BlendshapeCount"])
def test_an_app_take_at_59_94_reads_its_rate_rotations_and_weights(tmp_path, spelling):
    times = clock_take(tmp_path / "take.csv", 20.0, spelling=spelling)
    take = read_livelink_take(tmp_path / "take.csv")
    assert take.fps == pytest.approx(59.94, abs=1e-3) and take.timecode_rate == 60 and not take.drop_frame
    assert take.names == ARKIT_FACE_ORDER and take.pose_names == LIVELINK_ROTATION_COLUMNS
    assert take.weights.shape == (len(times), 52) and take.filled == 0
    np.testing.assert_allclose(take.weights, weights_at(times), atol=1e-9)  # by name: jawLeft/jawRight swapped
    np.testing.assert_allclose(take.pose, pose_at(times), atol=1e-9)
    # the clock's times: row i at i / 59.94 s, not i / 60 (1.2 frames apart after 20 s)
    np.testing.assert_allclose(take.times - take.times[0], times, atol=1e-6)
    assert (take.times[-1] - take.times[0]) * 60 - (len(times) - 1) == pytest.approx(1.2, abs=0.01)


def test_a_60_fps_take_and_columns_in_another_order_read_alike(tmp_path):
    times = clock_take(tmp_path / "a.csv", 3.0, fps=60.0)
    take = read_livelink_take(tmp_path / "a.csv")
    assert take.fps == 60.0 and take.timecode_rate == 60
    lines = (tmp_path / "a.csv").read_text().splitlines()
    order = [0, 1] + list(range(len(LIVELINK_HEADER) - 1, 1, -1))  # shapes and rotations reversed
    shuffled = [",".join(np.array(line.split(","))[order]) for line in lines]
    (tmp_path / "b.csv").write_text("\n".join(shuffled) + "\n")
    again = read_livelink_take(tmp_path / "b.csv")
    np.testing.assert_array_equal(again.weights, take.weights)
    np.testing.assert_array_equal(again.pose, take.pose)
    np.testing.assert_allclose(take.weights, weights_at(times), atol=1e-9)


def test_a_file_without_rotations_has_no_pose(tmp_path):
    header = LIVELINK_HEADER[:-9]
    clock_take(tmp_path / "a.csv", 2.0, header=header)
    text = (tmp_path / "a.csv").read_text().splitlines()
    (tmp_path / "a.csv").write_text("\n".join([text[0]] + [",".join(r.split(",")[:-9]) for r in text[1:]]) + "\n")
    take = read_livelink_take(tmp_path / "a.csv")
    assert take.pose is None and take.weights.shape[1] == 52


@pytest.mark.parametrize("fps", [60.0, 59.94, 30.0, 29.97, 24.0])
def test_the_writer_s_timecodes_count_at_the_take_s_rate_and_tell_it_back(tmp_path, fps):
    weights = weights_at(np.arange(300) / fps)
    write_livelink_take(tmp_path / "a.csv", weights, ARKIT_FACE_ORDER, fps, pose=pose_at(np.arange(300) / fps))
    take = read_livelink_take(tmp_path / "a.csv")
    standard = {59.94: NTSC_60, 29.97: 30000 / 1001}.get(fps, fps)
    assert take.fps == pytest.approx(standard, rel=1e-9) and take.timecode_rate == pytest.approx(standard, rel=1e-9)
    np.testing.assert_allclose(take.weights, weights, atol=1e-9)
    assert livelink_timecode(60, 59.94) == "00:00:01:00.060"  # FF counts at 59.94 within the clock's second


def test_drop_frame_labels_are_smpte_s():
    # SMPTE ST 12-1: 29.97 skips labels ;00 and ;01, 59.94 ;00 to ;03, at every minute not divisible by 10
    for frame, fps, label in [(1799, 29.97, "00:00:59;29"), (1800, 29.97, "00:01:00;02"),
                              (17982, 29.97, "00:10:00;00"), (107892, 29.97, "01:00:00;00"),
                              (3599, 59.94, "00:00:59;59"), (3600, 59.94, "00:01:00;04"),
                              (35964, 59.94, "00:10:00;00")]:
        assert livelink_timecode(frame, fps, drop_frame=True) == label
        rate = 30000 / 1001 if fps < 30 else NTSC_60
        assert parse_livelink_timecode(label, rate) * rate == pytest.approx(frame, abs=1e-6)


@pytest.mark.parametrize("fps", [29.97, 59.94])
def test_a_drop_frame_take_across_a_minute_reads_without_a_gap(tmp_path, fps):
    frames = int(62 * fps)  # past 00:01:00, where drop-frame skips labels
    write_livelink_take(tmp_path / "a.csv", weights_at(np.arange(frames) / fps), ARKIT_FACE_ORDER, fps,
                        drop_frame=True)
    assert ";" in (tmp_path / "a.csv").read_text().splitlines()[1]
    take = read_livelink_take(tmp_path / "a.csv")
    assert take.drop_frame and take.filled == 0 and len(take.weights) == frames
    assert take.fps == pytest.approx(fps, abs=1e-3)


def test_hand_written_drop_frame_rows_around_a_minute(tmp_path):
    labels = ["00:00:59;27", "00:00:59;28", "00:00:59;29", "00:01:00;02", "00:01:00;03", "00:01:00;04"]
    clock_take(tmp_path / "a.csv", 0.2, fps=30, timecodes=labels)
    take = read_livelink_take(tmp_path / "a.csv")
    assert take.timecode_rate == pytest.approx(29.97, abs=1e-3) and take.filled == 0
    np.testing.assert_allclose(np.diff(take.times), 1001 / 30000, atol=1e-9)
    bad = labels[:3] + ["00:01:00;00", "00:01:00;01"]
    clock_take(tmp_path / "b.csv", 0.2, fps=30, timecodes=bad)
    with pytest.raises(DataError, match=r"b\.csv: row 5 .*drop-frame .*skips"):
        read_livelink_take(tmp_path / "b.csv")


def test_a_dropped_frame_is_interpolated_and_counted(tmp_path):
    times = clock_take(tmp_path / "a.csv", 3.0, skip=(50, 51, 120))
    take = read_livelink_take(tmp_path / "a.csv")
    assert take.filled == 3 and len(take.weights) == len(times) + 3
    full = weights_at(np.arange(len(take.weights)) / NTSC_60)
    np.testing.assert_allclose(take.weights[[0, 49, 52, 119, 121]], full[[0, 49, 52, 119, 121]], atol=1e-9)
    np.testing.assert_allclose(take.weights[50], (2 * full[49] + full[52]) / 3, atol=1e-9)


def _bad(tmp_path, name, **kwargs):
    clock_take(tmp_path / name, 2.0, **kwargs)
    return tmp_path / name


def test_bad_takes_are_refused_naming_the_file_and_what_was_expected(tmp_path):
    header = list(LIVELINK_HEADER)
    missing = _bad(tmp_path, "missing.csv", header=[c if c != "JawOpen" else "Jaw_Open" for c in header])
    with pytest.raises(DataError, match=r"missing\.csv: missing ARKit shape columns \['jawOpen'\]; expected all 52"):
        read_livelink_take(missing)
    repeated = _bad(tmp_path, "repeated.csv", header=[c if c != "MouthClose" else "jawopen" for c in header])
    with pytest.raises(DataError, match=r"repeated\.csv: columns repeated in the header .*\['jawOpen'\]"):
        read_livelink_take(repeated)
    codes = [f"00:00:{1 + i // 60:02d}:{i % 60:02d}.000" for i in range(120)]
    codes[70], codes[71] = codes[71], codes[70]
    backwards = _bad(tmp_path, "backwards.csv", fps=60.0, timecodes=codes)
    with pytest.raises(DataError, match=r"backwards\.csv: row 73 \(frame 71\): timecode 00:00:02:10.000 does not "
                                        r"come after 00:00:02:11.000; expected increasing"):
        read_livelink_take(backwards)
    codes = [f"00:00:{1 + i // 60:02d}:{i % 60:02d}.000" for i in range(120)]
    codes[9] = "00:00:01:9.5x"
    garbled = _bad(tmp_path, "garbled.csv", fps=60.0, timecodes=codes)
    with pytest.raises(DataError, match=r"garbled\.csv: row 11 \(frame 9\): not a Live Link timecode: "
                                        r"'00:00:01:9\.5x'; expected HH:MM:SS:FF\.fff"):
        read_livelink_take(garbled)
    brief = _bad(tmp_path, "brief.csv", fps=60.0, timecodes=[f"00:00:01:{i:02d}.000" for i in range(120)])
    (tmp_path / "brief.csv").write_text("\n".join((tmp_path / "brief.csv").read_text().splitlines()[:40]) + "\n")
    with pytest.raises(DataError, match=r"brief\.csv: the 39 timecodes stay within one second.*at least 1 s"):
        read_livelink_take(brief)
    with pytest.raises(DataError, match="no Timecode column"):
        read_livelink_take(_bad(tmp_path, "notime.csv", header=["Time"] + header[1:]))
    lines = _bad(tmp_path, "value.csv").read_text().splitlines()
    fields = lines[1].split(",")
    fields[header.index("JawOpen")] = "abc"
    (tmp_path / "value.csv").write_text("\n".join([lines[0], ",".join(fields)] + lines[2:]) + "\n")
    with pytest.raises(DataError, match=r"value\.csv: row 2 \(frame 0\): JawOpen is 'abc'; expected a finite number"):
        read_livelink_take(tmp_path / "value.csv")


def test_the_writer_refuses_a_track_without_the_52_shapes():
    with pytest.raises(ValueError, match=r"expected \(T, 52\) weights"):
        format_livelink_csv(np.zeros((3, 2)), ["jawOpen", "mouthClose"])
