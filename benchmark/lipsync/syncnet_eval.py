"""AV offset and confidence with SyncNet, as its public evaluation computes them.

Video at 25 fps (5-frame clips = 0.2 s), audio MFCCs at 100 frames/s (20 per
clip), embeddings of every clip start; for each video clip the distances to the
audio embeddings shifted by ``-vshift..vshift`` frames (zero-padded), averaged
over clips. Offset = ``vshift - argmin`` (positive: video after audio),
confidence = ``median - min`` of the mean distances.
"""

from __future__ import annotations

import numpy as np
import torch

from benchmark.lipsync.geometric import SyncEstimate
from benchmark.lipsync.mfcc import mfcc
from benchmark.render import front_camera, read_video, render_sequence, resample_frames
from blendvoca.errors import DataError, UserError

VIDEO_FPS = 25
AUDIO_RATE = 16000
CLIP = 5
CROP = 224


def syncnet_inputs(frames, samples, rate: int = AUDIO_RATE):
    """Video clips and MFCC blocks for every clip start.

    Parameters
    ----------
    frames : (T, H, W, 3) uint8 RGB at 25 fps
        Front-view face renders; resized to 224 x 224 when needed.
    samples : (N,) float array_like in [-1, 1], mono at 16 kHz
    rate : int
        Must be 16000 (SyncNet's MFCC rate).

    Returns
    -------
    video : (C, 3, 5, 224, 224) float32 tensor (BGR, 0..255)
    audio : (C, 1, 13, 20) float32 tensor
    """
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[3] != 3:
        raise UserError(f"syncnet_inputs: expected frames (T, H, W, 3), got {frames.shape}")
    if rate != AUDIO_RATE:
        raise UserError(f"syncnet_inputs: audio must be at {AUDIO_RATE} Hz, got {rate}")
    samples = np.asarray(samples, dtype=np.float64)
    # SyncNet reads 16-bit PCM integers: use that scale (it changes cepstrum 0)
    ceps = mfcc(samples * 32768.0, rate).T  # (13, F), 100 per second
    length = min(len(frames), len(samples) // (rate // VIDEO_FPS))
    clips = length - CLIP
    if clips < 1:
        raise UserError(f"syncnet_inputs: need more than {CLIP} frames of video and audio, got {length}")
    video = torch.as_tensor(frames[:length, :, :, ::-1].astype(np.float32)).permute(3, 0, 1, 2)  # (3, T, H, W) BGR
    if video.shape[2:] != (CROP, CROP):
        video = torch.nn.functional.interpolate(video, size=(CROP, CROP), mode="bilinear", align_corners=False)
    clip_video = torch.stack([video[:, i : i + CLIP] for i in range(clips)])
    steps = 100 // VIDEO_FPS
    need = (clips - 1) * steps + CLIP * steps
    if ceps.shape[1] < need:
        ceps = np.pad(ceps, ((0, 0), (0, need - ceps.shape[1])))
    blocks = np.stack([ceps[:, i * steps : i * steps + CLIP * steps] for i in range(clips)])[:, None]
    return clip_video, torch.as_tensor(blocks, dtype=torch.float32)


def embed(model, video: torch.Tensor, audio: torch.Tensor, batch_size: int = 20):
    """Lip and audio embeddings, (C, E) each."""
    model.eval()
    lips, auds = [], []
    with torch.no_grad():
        for i in range(0, len(video), batch_size):
            lips.append(model.forward_lip(video[i : i + batch_size]))
            auds.append(model.forward_aud(audio[i : i + batch_size]))
    return torch.cat(lips), torch.cat(auds)


def shifted_distances(lip: torch.Tensor, aud: torch.Tensor, vshift: int = 15) -> np.ndarray:
    """Distance of each lip embedding to the audio embeddings shifted by
    ``-vshift..vshift`` (zero-padded past the ends), (C, 2 * vshift + 1)."""
    padded = torch.nn.functional.pad(aud, (0, 0, vshift, vshift))
    win = 2 * vshift + 1
    rows = [torch.nn.functional.pairwise_distance(lip[[i]].repeat(win, 1), padded[i : i + win]) for i in range(len(lip))]
    return torch.stack(rows).numpy()


def syncnet_sync(model, frames, samples, rate: int = AUDIO_RATE, vshift: int = 15, batch_size: int = 20) -> SyncEstimate:
    """AV offset (video frames at 25 fps, positive = video late) and confidence.

    Parameters
    ----------
    model : benchmark.lipsync.syncnet.SyncNet
    frames : (T, H, W, 3) uint8 RGB at 25 fps
    samples : (N,) mono audio at 16 kHz in [-1, 1]
    vshift : int
        Offsets searched, ±frames.

    Returns
    -------
    SyncEstimate
        ``scores`` are the mean distances per shift (lower is better), ordered
        by offset ``-vshift..vshift``.
    """
    video, audio = syncnet_inputs(frames, samples, rate)
    lip, aud = embed(model, video, audio, batch_size)
    mean_dist = shifted_distances(lip, aud, vshift).mean(axis=0)
    best = int(np.argmin(mean_dist))
    offset = vshift - best
    conf = float(np.median(mean_dist) - mean_dist[best])
    # reorder so that scores[k] is the distance at offset k - vshift
    return SyncEstimate(offset=offset, confidence=conf, scores=mean_dist[::-1].copy())


def syncnet_sync_track(model, vertices, faces, samples, rate: int = AUDIO_RATE, fps: float = 60.0,
                       vshift: int = 15, backend: str = "auto") -> SyncEstimate:
    """SyncNet offset/confidence of a mesh sequence: resample to 25 fps, render the
    front view at 224 x 224 framed on the front half of the head (the face, as
    SyncNet's face crops), run :func:`syncnet_sync` with the audio.

    Parameters
    ----------
    vertices : (T, V, 3) at ``fps``; faces : (F, 3)
    samples : (N,) mono audio at 16 kHz
    """
    frames = syncnet_frames(vertices, faces, fps, backend=backend)
    return syncnet_sync(model, frames, samples, rate, vshift)


def syncnet_frames(vertices, faces, fps: float = 60.0, backend: str = "auto") -> np.ndarray:
    """The front-view renders SyncNet is given of a mesh sequence: resampled to 25 fps,
    224 x 224, framed on the front half of the head (the face, as SyncNet's face crops).

    Parameters
    ----------
    vertices : (T, V, 3) at ``fps``; faces : (F, 3)

    Returns
    -------
    (T', 224, 224, 3) uint8 RGB at 25 fps
    """
    video = resample_frames(vertices, fps, VIDEO_FPS)
    # frame the face as SyncNet's face crops do: only the front half of the head
    z = video[0, :, 2]
    front = z >= 0.5 * (z.min() + z.max())
    pose = front_camera(video[:, front], margin=1.05)
    return render_sequence(video, faces, size=CROP, backend=backend, pose=pose)


def syncnet_sync_video(model, path, vshift: int = 15) -> SyncEstimate:
    """SyncNet offset/confidence of a video file with audio (e.g. from
    ``python -m benchmark.render``): frames are resampled to 25 fps when the file
    has another rate, audio is decoded at 16 kHz mono."""
    frames, fps, audio = read_video(path, rate=AUDIO_RATE)
    if len(audio) == 0:
        raise DataError(f"syncnet_sync_video: {path} has no audio stream")
    if abs(fps - VIDEO_FPS) > 1e-3:
        frames = np.clip(np.rint(resample_frames(frames, fps, VIDEO_FPS)), 0, 255).astype(np.uint8)
    return syncnet_sync(model, frames, audio, AUDIO_RATE, vshift)
