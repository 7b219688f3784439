import numpy as np
import pytest
import torch

from benchmark.lipsync import SyncNet, load_syncnet, syncnet_inputs, syncnet_sync_track
from benchmark.lipsync.syncnet_eval import shifted_distances
from tests.benchmark.fakes import fake_rig, flame_head, smooth_track, speech_for

# parameter layers of the public syncnet_v2 state_dict: Sequential index of every
# conv / batch-norm / linear in the four sub-networks
PUBLIC_LAYERS = {
    "netcnnaud": [0, 1, 4, 5, 8, 9, 11, 12, 14, 15, 18, 19],
    "netcnnlip": [0, 1, 4, 5, 8, 9, 11, 12, 14, 15, 18, 19],
    "netfcaud": [0, 1, 3],
    "netfclip": [0, 1, 3],
}


@pytest.fixture(scope="module")
def model():
    torch.manual_seed(0)
    return SyncNet().eval()


def test_parameter_names_follow_public_weights(model):
    layers = {}
    for key in model.state_dict():
        net, idx, _ = key.split(".", 2)
        layers.setdefault(net, set()).add(int(idx))
    assert {k: sorted(v) for k, v in layers.items()} == PUBLIC_LAYERS
    assert model.state_dict()["netcnnaud.18.weight"].shape == (512, 256, 5, 4)
    assert model.state_dict()["netcnnlip.0.weight"].shape == (96, 3, 5, 7, 7)


def test_loads_weights_from_path(model, tmp_path):
    path = tmp_path / "syncnet_v2.model"
    torch.save(model.state_dict(), path)
    loaded = load_syncnet(path)
    for k, v in model.state_dict().items():
        assert torch.equal(loaded.state_dict()[k], v)
    bad = dict(model.state_dict())
    bad.pop("netfclip.3.bias")
    torch.save(bad, path)
    with pytest.raises(RuntimeError, match="Missing key"):
        load_syncnet(path)


def test_input_shapes_and_frame_rates():
    frames = np.zeros((30, 100, 100, 3), dtype=np.uint8)  # 1.2 s at 25 fps, resized to 224
    audio = np.zeros(16000, dtype=np.float32)  # 1.0 s -> 25 video frames of audio
    video, mfcc_blocks = syncnet_inputs(frames, audio)
    assert video.shape == (20, 3, 5, 224, 224)
    assert mfcc_blocks.shape == (20, 1, 13, 20)
    with pytest.raises(ValueError, match="16000"):
        syncnet_inputs(frames, audio, rate=22050)


def test_offset_search_recovers_shift_of_embeddings():
    # the offset convention on embeddings directly: audio feature i matches lip i - 3
    rng = np.random.default_rng(0)
    aud = torch.as_tensor(rng.normal(size=(40, 16)), dtype=torch.float32)
    lip = torch.roll(aud, 3, dims=0)  # lip[i] = aud[i - 3]: video 3 frames late
    d = shifted_distances(lip, aud, vshift=15).mean(axis=0)
    assert 15 - int(np.argmin(d)) == 3


def test_end_to_end_on_rendered_sentence(model, assets_dir):
    neutral, faces = flame_head(assets_dir)
    rig = fake_rig(neutral, faces)
    rng = np.random.default_rng(0)
    track = smooth_track(72, rng)  # 1.2 s at 60 fps -> 29 frames at 25 fps
    verts = rig.evaluate(track)
    audio = speech_for(track[:, 3], rng)
    est = syncnet_sync_track(model, verts, faces, audio, backend="software", vshift=15)
    assert -15 <= est.offset <= 15
    assert est.scores.shape == (31,) and np.all(np.isfinite(est.scores))
    assert est.confidence >= 0
    assert est.offset == 15 - int(np.argmin(est.scores[::-1]))


def test_from_muxed_video_file(model, assets_dir, tmp_path):
    from benchmark.lipsync import syncnet_sync_video
    from benchmark.render import render_coeffs, write_video

    neutral, faces = flame_head(assets_dir)
    rig = fake_rig(neutral, faces)
    rng = np.random.default_rng(1)
    track = smooth_track(60, rng)  # 1 s at 60 fps, rendered at 30 fps: resampled to 25 on reading
    frames = render_coeffs(track, rig, out_fps=30, size=112, backend="software")
    path = write_video(tmp_path / "s.mp4", frames, 30, audio=speech_for(track[:, 3], rng))
    est = syncnet_sync_video(model, path, vshift=5)
    assert est.scores.shape == (11,) and -5 <= est.offset <= 5
