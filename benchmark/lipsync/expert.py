"""A learned lip-sync expert for coefficient tracks (SyncNet's recipe on blendshapes).

Two small temporal-convolution streams embed, at every 60 fps frame, a window of
the coefficient track (32 channels, standardised with the training statistics)
and a window of the speech's log-mel spectrogram (sampled at the same frame
times, normalised per utterance, so loudness alone carries no information) onto
the unit sphere. Trained contrastively on the training split
(:mod:`benchmark.lipsync.expert_training`): the audio window at the true lag must be
the nearest among all shifts.

Scoring is SyncNet's: the mean embedding distance between motion frame ``t`` and
audio frame ``t - s`` for every shift ``s`` in ``-max_shift..max_shift``; the
**offset** is the shift of the smallest mean distance and the **confidence** the
median minus the minimum distance. Sign: a positive offset means the motion comes
*after* the audio (motion frame ``t`` shows audio frame ``t - offset``), the
convention of the synthetic corpus's ``lag_frames`` and of the geometric score.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from os import PathLike

import numpy as np
import torch
from torch import nn

from benchmark.lipsync.geometric import SyncEstimate, offset_from_scores
from benchmark.lipsync.mfcc import mel_filterbank
from blendvoca.errors import DataError, UserError
from blendvoca.io.audio import resample_audio
from blendvoca.io.torch_file import read_torch_file, write_torch_file

FPS = 60
RATE = 16000
FORMAT = "blendvoca-sync-expert"
FORMAT_VERSION = 1
#: Smallest RMS coefficient deviation an utterance is divided by (``motion_norm="utterance"``):
#: a still track stays near 0 instead of turning round-off into motion.
MOTION_FLOOR = 1e-3
#: Recipe keys that a checkpoint's config holds only when they differ from the original
#: recipe (so the weights digests of experts trained before them do not change):
#: ``motion_norm`` ("training" or "utterance", :meth:`SyncExpert.motion_features`).
OPTIONAL_CONFIG = {"motion_norm": "training"}
DEFAULT_CONFIG = dict(num_coeffs=32, num_mels=40, channels=64, embedding=32, kernel=5, dilations=(1, 2, 2),
                      max_shift=15, nfft=512)


def audio_features(samples, *, num_frames: int, rate: int = RATE, fps: float = FPS, num_mels: int = 40,
                   nfft: int = 512) -> np.ndarray:
    """Log-mel spectrogram sampled at the motion frame times, normalised per utterance.

    Frame ``t`` is a Hann-windowed ``nfft``-sample span centred at ``t / fps`` s
    (zero beyond the ends); the log mel energies are standardised per band over
    the utterance (mean 0, and one standard deviation for all bands), so a
    louder or quieter recording gives the same features.

    Parameters
    ----------
    samples : (N,) array_like
        Mono speech at ``rate``.
    num_frames : int
        T, frames at ``fps``.

    Returns
    -------
    (T, num_mels) float32 ndarray
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 1 or x.size == 0:
        raise UserError(f"audio_features: expected mono samples (N,), got shape {x.shape}")
    half = nfft // 2
    padded = np.concatenate([np.zeros(half), x, np.zeros(half + nfft)])
    centres = np.round(np.arange(num_frames) * rate / fps).astype(np.int64)
    frames = padded[centres[:, None] + np.arange(nfft)[None, :]] * np.hanning(nfft)[None]
    power = np.abs(np.fft.rfft(frames, nfft)) ** 2
    mel = np.log(power @ mel_filterbank(num_mels, nfft, rate).T + 1e-10)
    floor = mel.max() - 8.0 * np.log(10.0)  # 80 dB below the loudest band energy
    mel = np.maximum(mel, floor)
    mel -= mel.mean(axis=0, keepdims=True)
    mel /= max(float(mel.std()), 1e-8)
    return mel.astype(np.float32)


def _stream(cin: int, channels: int, embedding: int, kernel: int, dilations) -> nn.Sequential:
    layers, c = [], cin
    for d in dilations:
        layers += [nn.Conv1d(c, channels, kernel, dilation=d), nn.BatchNorm1d(channels), nn.ReLU()]
        c = channels
    layers.append(nn.Conv1d(channels, embedding, 1))
    return nn.Sequential(*layers)


class SyncExpertNet(nn.Module):
    """The two streams: ``motion(B, num_coeffs, L)`` and ``audio(B, num_mels, L)`` ->
    unit embeddings ``(B, embedding, L - 2 * reach)`` (valid convolutions)."""

    def __init__(self, num_coeffs=32, num_mels=40, channels=64, embedding=32, kernel=5, dilations=(1, 2, 2)):
        super().__init__()
        self.motion_net = _stream(num_coeffs, channels, embedding, kernel, dilations)
        self.audio_net = _stream(num_mels, channels, embedding, kernel, dilations)
        #: Frames each side an output frame sees.
        self.reach = sum((kernel - 1) * d for d in dilations) // 2

    def motion(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.normalize(self.motion_net(x), dim=1)

    def audio(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.normalize(self.audio_net(x), dim=1)


def shift_distances(motion_emb: np.ndarray, audio_emb: np.ndarray, max_shift: int) -> np.ndarray:
    """Mean distance between motion frame ``t`` and audio frame ``t - s`` per shift.

    Parameters
    ----------
    motion_emb : (T, E) ndarray
    audio_emb : (T + 2 * max_shift, E) ndarray
        Audio embeddings of frames ``-max_shift .. T + max_shift - 1``.

    Returns
    -------
    (2 * max_shift + 1,) ndarray for shifts ``-max_shift..max_shift``.
    """
    T = len(motion_emb)
    out = np.empty(2 * max_shift + 1)
    for i, s in enumerate(range(-max_shift, max_shift + 1)):
        a = audio_emb[max_shift - s: max_shift - s + T]
        out[i] = np.linalg.norm(motion_emb - a, axis=1).mean()
    return out


@dataclass
class SyncExpert:
    """A trained expert: network, coefficient statistics and provenance.

    Use :meth:`sync`; create with :func:`load_expert` or
    :func:`benchmark.lipsync.expert_training.train_expert`.
    """

    net: SyncExpertNet
    config: dict
    coeff_mean: np.ndarray
    coeff_std: np.ndarray
    names: tuple
    trained_on: dict = field(default_factory=dict)

    @property
    def max_shift(self) -> int:
        return int(self.config["max_shift"])

    def _padded_inputs(self, coeffs, audio, rate: int):
        coeffs = np.asarray(coeffs, dtype=np.float64)
        if coeffs.ndim != 2 or coeffs.shape[1] != self.config["num_coeffs"] or len(coeffs) < 1:
            raise UserError(f"SyncExpert.sync: expected coeffs (T, {self.config['num_coeffs']}), got {coeffs.shape}")
        if not np.all(np.isfinite(coeffs)):
            raise UserError("SyncExpert.sync: coeffs hold NaN or infinite values")
        audio = np.asarray(audio, dtype=np.float32)
        if audio.ndim != 1 or audio.size == 0:
            raise UserError(f"SyncExpert.sync: expected mono audio (N,), got shape {audio.shape}")
        if rate != RATE:
            audio = resample_audio(audio, rate, RATE)
        T, r, S = len(coeffs), self.net.reach, self.max_shift
        mel = audio_features(audio, num_frames=T, num_mels=self.config["num_mels"], nfft=self.config["nfft"])
        motion = np.pad(self.motion_features(coeffs), ((r, r), (0, 0)), mode="edge")
        mel = np.pad(mel, ((S + r, S + r), (0, 0)), mode="edge")
        return motion.astype(np.float32), mel

    def motion_features(self, coeffs) -> np.ndarray:
        """The motion stream's input ``(T, num_coeffs)`` float32 of a coefficient track.

        ``config["motion_norm"]`` says how: ``"training"`` (the default)
        standardises each shape with the training statistics; ``"utterance"``
        subtracts the utterance's mean of each shape and divides by the
        utterance's RMS deviation over all shapes (:data:`MOTION_FLOOR` at least),
        as the audio features are normalised per utterance: a rig or capture that
        moves its shapes more, or rests them elsewhere, gives the same input up to
        the shapes' proportions, and a shape the training data hardly moves cannot
        be blown up by a small training standard deviation.
        """
        coeffs = np.asarray(coeffs, dtype=np.float64)
        mode = self.config.get("motion_norm", "training")
        if mode == "training":
            return ((coeffs - self.coeff_mean) / self.coeff_std).astype(np.float32)
        if mode == "utterance":
            centred = coeffs - coeffs.mean(axis=0, keepdims=True)
            scale = max(float(np.sqrt((centred**2).mean(axis=0).sum() / coeffs.shape[1])), MOTION_FLOOR)
            return (centred / scale).astype(np.float32)
        raise DataError(f"SyncExpert: unknown motion_norm {mode!r} (expected 'training' or 'utterance')")

    @torch.no_grad()
    def embeddings(self, coeffs, audio, rate: int = RATE) -> tuple[np.ndarray, np.ndarray]:
        """Motion embeddings ``(T, E)`` and audio embeddings ``(T + 2 * max_shift, E)``."""
        motion, mel = self._padded_inputs(coeffs, audio, rate)
        self.net.eval()
        m = self.net.motion(torch.from_numpy(motion.T[None].copy()))[0].T.numpy()
        a = self.net.audio(torch.from_numpy(mel.T[None].copy()))[0].T.numpy()
        return m.astype(np.float64), a.astype(np.float64)

    def sync(self, coeffs, audio, rate: int = RATE) -> SyncEstimate:
        """AV offset and confidence of a coefficient track against its speech.

        Parameters
        ----------
        coeffs : (T, 32) array_like
            Coefficients at 60 fps, columns in :attr:`names` order.
        audio : (N,) array_like
            Mono speech, float32 at 16 kHz (other ``rate`` values are resampled).

        Returns
        -------
        SyncEstimate
            ``offset`` in 60 fps frames (positive: the motion comes after the
            audio), ``confidence`` = median - min of ``scores``, the mean
            embedding distances for shifts ``-max_shift..max_shift``.
        """
        m, a = self.embeddings(coeffs, audio, rate)
        return offset_from_scores(shift_distances(m, a, self.max_shift), self.max_shift, higher_is_better=False)

    def state(self) -> dict:
        """The checkpoint dictionary :func:`save_expert` writes."""
        return {"format": FORMAT, "version": FORMAT_VERSION, "config": dict(self.config),
                "state_dict": self.net.state_dict(),
                "coeff_mean": torch.as_tensor(self.coeff_mean, dtype=torch.float64),
                "coeff_std": torch.as_tensor(self.coeff_std, dtype=torch.float64),
                "names": list(self.names), "trained_on": dict(self.trained_on)}

    def weights_digest(self) -> str:
        """SHA-256 of what decides the expert's scores: its config, network weights,
        coefficient normalisation and names. Unlike the checkpoint file's digest it
        leaves out ``trained_on`` (the data path, the wall seconds), so the same
        training repeated elsewhere gives the same digest."""
        digest = hashlib.sha256(json.dumps({"config": self.config, "names": list(self.names)}, sort_keys=True,
                                           default=list).encode())
        tensors = {**{f"net.{k}": v for k, v in self.net.state_dict().items()},
                   "coeff_mean": torch.as_tensor(self.coeff_mean, dtype=torch.float64),
                   "coeff_std": torch.as_tensor(self.coeff_std, dtype=torch.float64)}
        for name in sorted(tensors):
            value = tensors[name].detach().cpu().contiguous()
            digest.update(f"{name}:{value.dtype}:{tuple(value.shape)}".encode())
            digest.update(value.numpy().tobytes())
        return digest.hexdigest()


def build_expert(config: dict, coeff_mean, coeff_std, names, trained_on=None) -> SyncExpert:
    """An expert with a freshly initialised network."""
    cfg = {**DEFAULT_CONFIG, **config}
    cfg["dilations"] = list(cfg["dilations"])
    if cfg.get("motion_norm", "training") not in ("training", "utterance"):
        raise UserError(f"build_expert: motion_norm must be 'training' or 'utterance', got {cfg['motion_norm']!r}")
    for key, original in OPTIONAL_CONFIG.items():
        if cfg.get(key) == original:
            del cfg[key]
    net = SyncExpertNet(cfg["num_coeffs"], cfg["num_mels"], cfg["channels"], cfg["embedding"], cfg["kernel"],
                        tuple(cfg["dilations"]))
    return SyncExpert(net=net, config=cfg, coeff_mean=np.asarray(coeff_mean, dtype=np.float64),
                      coeff_std=np.asarray(coeff_std, dtype=np.float64), names=tuple(names),
                      trained_on=dict(trained_on or {}))


def save_expert(expert: SyncExpert, path: str | PathLike) -> None:
    """Write the checkpoint atomically (a torch file loadable with ``weights_only=True``)."""
    write_torch_file(path, expert.state())


def load_expert(path: str | PathLike) -> SyncExpert:
    """The expert saved at ``path`` (by ``python -m benchmark.lipsync.train_expert``).

    Raises
    ------
    DataError
        The file is not a sync-expert checkpoint (names the path and what it holds).
    """
    state = read_torch_file(path, where="load_expert")
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        what = type(state).__name__ if not isinstance(state, dict) else f"keys {sorted(state)[:6]}"
        raise DataError(f"load_expert: {path} is not a {FORMAT} checkpoint (holds {what}); "
                         "train one with python -m benchmark.lipsync.train_expert")
    if state.get("version") != FORMAT_VERSION:
        raise DataError(f"load_expert: {path} has format version {state.get('version')}, expected {FORMAT_VERSION}")
    expert = build_expert(state["config"], state["coeff_mean"].numpy(), state["coeff_std"].numpy(),
                          state["names"], state.get("trained_on"))
    expert.net.load_state_dict(state["state_dict"], strict=True)
    expert.net.eval()
    return expert
