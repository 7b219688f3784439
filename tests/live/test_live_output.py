"""``python -m blendvoca.live`` against receivers on loopback: every frame arrives once, in order,
with the file's names and values (float32), at the track's rate; bad input is one error line, exit 2."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
from blendvoca.io.livelink import write_livelink_take
from blendvoca.live.__main__ import main
from blendvoca.live.livelink_udp import PACKET_NAMES, decode_packet
from blendvoca.live.receiver import DatagramRecorder
from blendvoca.live.sender import parse_target
from blendvoca.names import ARKIT_FACE_ORDER, BLENDVOCA_NAMES

pythonosc = pytest.importorskip("pythonosc", reason="pip install 'blendvoca[live]'")
from pythonosc.dispatcher import Dispatcher  # noqa: E402
from pythonosc.osc_server import BlockingOSCUDPServer  # noqa: E402

FRAMES = 90  # 1.5 s at 60 fps


@pytest.fixture
def track(tmp_path):
    """A BlendVOCA CSV of 90 frames whose every value differs, and the values as read back."""
    rng = np.random.default_rng(7)
    path = tmp_path / "track.csv"
    write_coeffs_csv(path, rng.uniform(0, 1, (FRAMES, len(BLENDVOCA_NAMES))), BLENDVOCA_NAMES)
    values, names = read_coeffs_csv(path)
    return path, values, names


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def test_livelink_frames_round_trip_in_order_at_60_fps(track, capsys):
    path, values, names = track
    with DatagramRecorder() as receiver:
        assert main(["--coeffs", str(path), "--to", f"livelink://127.0.0.1:{receiver.port}", "--quiet",
                     "--subject", "Mouth"]) == 0
        assert receiver.wait(FRAMES, 5)
    packets = [decode_packet(data) for _, data in receiver.datagrams]
    assert len(packets) == FRAMES
    assert [p.frame_number for p in packets] == list(range(FRAMES))
    assert {(p.subject, p.rate, p.device_id) for p in packets} == {("Mouth", (60, 1), "blendvoca-live")}
    got = np.stack([p.values for p in packets])
    slots = [PACKET_NAMES.index(n) for n in names]
    np.testing.assert_array_equal(got[:, slots], values.astype(np.float32))
    assert np.count_nonzero(np.delete(got, slots, axis=1)) == 0  # the shapes a BlendVOCA track lacks are 0
    arrivals = np.array([t for t, _ in receiver.datagrams])
    # the 90 frames span 89 periods of 1/60 s: paced, not sent in a burst
    assert arrivals[-1] - arrivals[0] > 88 / 60
    assert "sent 90 frames at 60 fps" in capsys.readouterr().out


def test_a_live_link_take_is_sent_at_its_own_rate_with_its_rotations(tmp_path):
    rng = np.random.default_rng(3)
    weights, pose = rng.uniform(0, 1, (40, 52)), rng.uniform(-0.5, 0.5, (40, 9))
    path = tmp_path / "take.csv"
    write_livelink_take(path, weights, ARKIT_FACE_ORDER, fps=30.0, pose=pose)
    with DatagramRecorder() as receiver:
        assert main(["--coeffs", str(path), "--to", f"livelink://localhost:{receiver.port}", "--quiet"]) == 0
        assert receiver.wait(40, 5)
    packets = [decode_packet(data) for _, data in receiver.datagrams]
    assert len(packets) == 40 and {p.rate for p in packets} == {(30, 1)}
    got = np.stack([p.values for p in packets])
    # the CSV holds 10 decimals; the packet float32
    np.testing.assert_allclose(got[:, :52], weights, atol=1e-7)
    np.testing.assert_allclose(got[:, 52:], pose, atol=1e-7)


@pytest.mark.parametrize("style", ["arkit", "vmc"])
def test_osc_bundles_round_trip_through_python_osc_server(track, style, capsys):
    path, values, names = track
    messages = []
    dispatcher = Dispatcher()
    dispatcher.set_default_handler(lambda address, *args: messages.append((address, *args)))
    server = BlockingOSCUDPServer(("127.0.0.1", 0), dispatcher)  # one datagram at a time, in arrival order
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    try:
        port = server.server_address[1]
        assert main(["--coeffs", str(path), "--to", f"osc://127.0.0.1:{port}", "--osc-style", style, "--quiet"]) == 0
        expected = FRAMES * (len(names) + (style == "vmc"))
        for _ in range(100):
            if len(messages) >= expected:
                break
            threading.Event().wait(0.05)
    finally:
        server.shutdown()
        server.server_close()
    assert len(messages) == expected
    if style == "arkit":
        frames = [messages[i:i + len(names)] for i in range(0, expected, len(names))]
        for k, frame in enumerate(frames):
            assert [m[0] for m in frame] == [f"/ARKit/{n}" for n in names]
            np.testing.assert_array_equal(np.array([m[1] for m in frame], np.float32), values[k].astype(np.float32))
    else:
        step = len(names) + 1
        frames = [messages[i:i + step] for i in range(0, expected, step)]
        for k, frame in enumerate(frames):
            assert frame[-1] == ("/VMC/Ext/Blend/Apply",)
            assert [m[:2] for m in frame[:-1]] == [("/VMC/Ext/Blend/Val", n) for n in names]
            np.testing.assert_array_equal(np.array([m[2] for m in frame[:-1]], np.float32),
                                          values[k].astype(np.float32))


def test_osc_prefix_and_pascal_case(track):
    path, values, names = track
    with DatagramRecorder() as receiver:
        assert main(["--coeffs", str(path), "--to", f"osc://127.0.0.1:{receiver.port}", "--quiet",
                     "--osc-prefix", "/avatar/parameters/", "--osc-case", "pascal", "--fps", "240"]) == 0
        assert receiver.wait(FRAMES, 5)
    from pythonosc.osc_bundle import OscBundle

    bundle = OscBundle(receiver.datagrams[0][1])
    assert [m.address for m in bundle][:2] == ["/avatar/parameters/JawForward", "/avatar/parameters/JawLeft"]


def test_method_animates_the_wav_through_benchmark_generate(tmp_path):
    soundfile = pytest.importorskip("soundfile")
    from benchmark.generate import generate_file

    wav = tmp_path / "speech.wav"
    soundfile.write(wav, np.random.default_rng(0).normal(0, 0.1, 16000).astype(np.float32), 16000)  # 1 s
    (reference,) = generate_file("random", wav, tmp_path / "ref.csv", seed=3)
    expected, names = read_coeffs_csv(reference)
    with DatagramRecorder() as receiver:
        assert main(["--method", "random", "--audio", str(wav), "--seed", "3", "--quiet",
                     "--to", f"livelink://127.0.0.1:{receiver.port}"]) == 0
        assert receiver.wait(len(expected), 5)
    got = np.stack([decode_packet(data).values for _, data in receiver.datagrams])
    assert len(got) == len(expected) == 60
    np.testing.assert_allclose(got[:, [PACKET_NAMES.index(n) for n in names]], expected, atol=1e-6)


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("to, message", [
    ("ftp://127.0.0.1:11111", "the scheme 'ftp'"),
    ("127.0.0.1:11111", "scheme"),
    ("livelink://:11111", "no host"),
    ("livelink://127.0.0.1", "no port"),
    ("osc://127.0.0.1:70000", "no number in 1..65535"),
    ("osc://127.0.0.1:port", "no number in 1..65535"),
    ("livelink://no-such-host.invalid:11111", "does not resolve"),
    ("livelink://127.0.0.1:11111/path", "unexpected text"),
    ("livelink://255.255.255.255:11111", "unreachable"),
])
def test_a_bad_to_address_is_one_error_line(track, to, message, capsys):
    assert main(["--coeffs", str(track[0]), "--to", to, "--quiet"]) == 2
    line = _error_line(capsys)
    assert message in line and "--to" in line


def test_a_missing_file_is_one_error_line(tmp_path, capsys):
    assert main(["--coeffs", str(tmp_path / "nope.csv"), "--to", "livelink://127.0.0.1:11111"]) == 2
    assert "nope.csv: no such file" in _error_line(capsys)


@pytest.mark.parametrize("scheme, carries", [("livelink", "Live Link Face's packet"), ("osc", "OSC output")])
def test_names_the_protocol_has_no_place_for_are_named(tmp_path, scheme, carries, capsys):
    path = tmp_path / "controls.csv"
    path.write_text("jawOpen,JAW_OPEN_L,lipCornerPull\n0.1,0.2,0.3\n")
    assert main(["--coeffs", str(path), "--to", f"{scheme}://127.0.0.1:9"]) == 2
    line = _error_line(capsys)
    assert "['JAW_OPEN_L', 'lipCornerPull']" in line and carries in line


def test_a_port_in_use_is_named():
    with DatagramRecorder() as taken:
        with pytest.raises(Exception, match=f"port {taken.port} on 127.0.0.1 is in use"):
            DatagramRecorder(port=taken.port)


def test_flags_of_method_with_coeffs_and_method_without_audio_are_refused(track, capsys):
    assert main(["--coeffs", str(track[0]), "--rig", "r.npz", "--to", "osc://127.0.0.1:9"]) == 2
    assert "--rig belongs to --method" in _error_line(capsys)
    assert main(["--method", "random", "--to", "osc://127.0.0.1:9"]) == 2
    assert "--method needs --audio" in _error_line(capsys)


def test_a_receiver_not_listening_yet_is_no_error(track, capsys):
    with DatagramRecorder() as closed:
        port = closed.port
    assert main(["--coeffs", str(track[0]), "--to", f"livelink://127.0.0.1:{port}", "--quiet", "--fps", "600"]) == 0
    captured = capsys.readouterr()
    assert "sent 90 frames" in captured.out and "refused" in captured.err


def test_parse_target_keeps_ipv6_hosts():
    target = parse_target("osc://[::1]:39539")
    assert (target.host, target.port, str(target)) == ("::1", 39539, "osc://[::1]:39539")


def test_a_vertex_method_is_solved_on_the_rig_by_the_streaming_solver(tmp_path, monkeypatch, capsys):
    """faceformer's meshes (here written by a stand-in for its generate step: training it is slow) are
    solved frame by frame on --rig; the weights sent are the streaming solver's, near the true ones."""
    soundfile = pytest.importorskip("soundfile")
    import benchmark.generate
    from blendvoca.fit.streaming import StreamingSolver
    from blendvoca.rig import Rig

    rng = np.random.default_rng(1)
    names = ("jawOpen", "mouthFunnel", "mouthSmileLeft", "mouthSmileRight")
    neutral = rng.normal(0, 0.05, (60, 3))
    rig = Rig(neutral, rng.normal(0, 0.01, (4, 60, 3)), names, np.array([[0, 1, 2]]))
    rig.save(tmp_path / "rig.npz")
    truth = rng.uniform(0.1, 0.9, (30, 4))
    truth[:, 3] = truth[:, 2]  # symmetric smile: the solver's symmetry term keeps it
    frames = rig.evaluate(truth)

    def fake_generate_file(method, audio, out, **kwargs):
        assert method == "faceformer" and str(out).endswith(".npy")
        np.save(out, frames[None].astype(np.float32))
        return [out]

    monkeypatch.setattr(benchmark.generate, "generate_file", fake_generate_file)
    wav = tmp_path / "speech.wav"
    soundfile.write(wav, np.zeros(8000, np.float32), 16000)
    with DatagramRecorder() as receiver:
        assert main(["--method", "faceformer", "--checkpoint", str(tmp_path), "--audio", str(wav), "--quiet",
                     "--rig", str(tmp_path / "rig.npz"), "--fps", "300",
                     "--to", f"livelink://127.0.0.1:{receiver.port}"]) == 0
        assert receiver.wait(30, 5)
    got = np.stack([decode_packet(data).values for _, data in receiver.datagrams])[:, [PACKET_NAMES.index(n)
                                                                                       for n in names]]
    expected = StreamingSolver.from_rig(rig).solve_sequence(frames.astype(np.float32).astype(np.float64))
    np.testing.assert_allclose(got, expected, atol=1e-6)
    assert np.abs(got - truth).max() < 0.1


def test_a_vertex_method_without_rig_is_refused(tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    wav.write_bytes(b"")
    assert main(["--method", "faceformer", "--audio", str(wav), "--to", "livelink://127.0.0.1:11111"]) == 2
    assert "outputs vertices; give --rig" in _error_line(capsys)


def _free_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _bound(port: int) -> bool:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


def test_listen_records_what_the_sender_sends_as_a_live_link_take(tmp_path, capsys):
    from blendvoca.io.livelink import read_livelink_take

    rng = np.random.default_rng(5)
    weights, pose = rng.uniform(0, 1, (150, 52)), rng.uniform(-0.5, 0.5, (150, 9))
    take = tmp_path / "take.csv"
    write_livelink_take(take, weights, ARKIT_FACE_ORDER, fps=60.0, pose=pose)
    port, out, codes = _free_port(), tmp_path / "recorded.csv", []
    listener = threading.Thread(target=lambda: codes.append(main(
        ["--listen", f"livelink://127.0.0.1:{port}", "--out", str(out), "--frames", "150", "--seconds", "20"])))
    listener.start()
    for _ in range(200):
        if _bound(port):
            break
        threading.Event().wait(0.02)
    assert main(["--coeffs", str(take), "--to", f"livelink://127.0.0.1:{port}", "--quiet", "--fps", "120"]) == 0
    listener.join(30)
    assert codes == [0]
    recorded = read_livelink_take(out)
    assert recorded.fps == 120.0 and recorded.weights.shape == (150, 52)
    np.testing.assert_allclose(recorded.weights, weights, atol=1e-7)
    np.testing.assert_allclose(recorded.pose, pose, atol=1e-7)
    assert "recorded 150 frames" in capsys.readouterr().out


def test_listen_on_a_port_in_use_is_one_error_line_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "take.csv"
    with DatagramRecorder() as taken:
        port = taken.port
        assert main(["--listen", f"livelink://127.0.0.1:{port}", "--out", str(out), "--frames", "1"]) == 2
    line = _error_line(capsys)
    assert f"port {port} on 127.0.0.1 is in use" in line and "--listen" in line
    assert not out.exists()


@pytest.mark.parametrize("argv, message", [
    (["--listen", "osc://127.0.0.1:9000", "--out", "t.csv"], "the scheme 'osc'"),
    (["--listen", "livelink://127.0.0.1:11111"], "--listen needs --out"),
    (["--listen", "livelink://127.0.0.1:11111", "--out", "t.csv", "--to", "osc://127.0.0.1:1"], "--to belongs"),
    (["--coeffs", "x.csv", "--to", "osc://127.0.0.1:1", "--frames", "3"], "--frames belongs to --listen"),
    (["--coeffs", "x.csv"], "--to URL is needed"),
])
def test_listen_flags_are_checked(argv, message, capsys):
    assert main(argv) == 2
    assert message in _error_line(capsys)
