"""The ``regression`` method plug-in."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from baselines.common.checkpoint import load_checkpoint_file, old_format_hint, save_checkpoint_file
from baselines.common.device import checked_precision, method_device, precision_config
from baselines.common.npz_file import read_npz_arrays
from baselines.regression.features import motion_rate_features
from baselines.regression.model import AudioToCoefficients
from baselines.regression.training import feature_statistics, trained_regressor
from benchmark.methods.base import Method, TrainingRequest
from blendvoca.errors import DataError
from blendvoca.runtime.threads import limited_threads

__all__ = ["RegressionMethod"]


class RegressionMethod(Method):
    """Spectrogram -> CNN + GRU -> 32 coefficients, trained by least squares.

    Re-implements the idea of end2end_AU_speech (Pham et al.) in PyTorch; trains on
    the train split (validation split picks the best checkpoint) in minutes on CPU.

    Parameters
    ----------
    steps : int
        Default number of optimisation steps (a ``Budget.max_steps`` overrides it).
    n_mels : int
        Mel bands (multiple of 4).
    channels : int
        Channels of the CNN layers.
    hidden : int
        Hidden size of the GRU.
    batch : int
        Windows per optimisation step.
    window : int
        Window length in 60 fps frames.
    lr : float
        Adam learning rate.
    threads : int or None
        Torch threads while training and generating (the previous count is restored after).
    mixed_precision : {"off", "bf16", "fp16"}
        Autocast of the training loss on a GPU (docs/gpu.md); nothing on the CPU.
    """

    name = "regression"
    stochastic = False

    def __init__(self, steps: int = 1200, n_mels: int = 40, channels: int = 64, hidden: int = 64,
                 batch: int = 16, window: int = 60, lr: float = 2e-3, threads: int | None = 1,
                 mixed_precision: str = "off"):
        super().__init__(steps=steps, n_mels=n_mels, channels=channels, hidden=hidden, batch=batch, window=window,
                         lr=lr, threads=threads, **precision_config(mixed_precision))
        #: autocast of the training loss on a GPU (docs/gpu.md); nothing on the CPU
        self.mixed_precision = checked_precision(mixed_precision)
        self.model = None
        self.stats = None
        self.history = None

    def _features(self, audio, num_frames):
        return motion_rate_features(np.asarray(audio, dtype=np.float32), num_frames, n_mels=self._config["n_mels"])

    def _sentences(self, dataset, split):
        feats, targets = [], []
        for subject in dataset.split(split):
            for sentence in dataset.sentences(subject):
                coeffs = np.asarray(dataset.coeffs(subject, sentence), dtype=np.float32)
                audio, _ = dataset.audio(subject, sentence)
                feats.append(self._features(audio, coeffs.shape[0]))
                targets.append(coeffs)
        return feats, targets

    contract = 3

    def train(self, dataset, request: TrainingRequest) -> None:
        """Train on the train split (the val split picks the kept weights) under ``request``;
        its ``on_checkpoint`` is called when a run without a time limit has done its
        ``checkpoint_fractions`` of the steps, the network then being the one training would
        keep at that point; its ``device``: where the network trains and then predicts
        (None: the CPU)."""
        with limited_threads(self._config["threads"], torch_only=True):
            feats, targets = self._sentences(dataset, "train")
            if not feats:
                raise DataError("regression: the dataset's train split has no sentences")
            try:
                val_feats, val_targets = self._sentences(dataset, "val")
            except (KeyError, ValueError):
                val_feats, val_targets = [], []
            mean, std = feature_statistics(feats)
            self.stats = (mean, std)
            norm = lambda fs: [((f - mean) / std).astype(np.float32) for f in fs]
            cfg = self._config

            def at_half(step, *, model, total_steps):
                self.model = model  # generate() uses the network as it is at this step
                try:
                    request.on_checkpoint(step, total_steps=total_steps)
                finally:
                    self.model = None

            self.model, self.history = trained_regressor(
                norm(feats), targets, val_features=norm(val_feats), val_targets=val_targets, seed=request.seed,
                budget=request.budget, default_steps=cfg["steps"], batch=cfg["batch"], window=cfg["window"], lr=cfg["lr"],
                model_kwargs={"channels": cfg["channels"], "hidden": cfg["hidden"]},
                on_checkpoint=None if request.on_checkpoint is None else at_half,
                fractions=request.checkpoint_fractions, device=request.device,
                mixed_precision=self.mixed_precision,
            )

    def to(self, device):
        """This method with its network on ``device`` (prediction runs there); returns self."""
        if self.model is not None:
            self.model.to(method_device(device))
        return self

    def generate(self, utterance, *, samples=1, seed=0):
        if self.model is None:
            raise RuntimeError("regression: generate called before train/load")
        mean, std = self.stats
        x = (self._features(utterance.audio, utterance.num_frames) - mean) / std
        with torch.no_grad(), limited_threads(self._config["threads"], torch_only=True):
            y = self.model(torch.from_numpy(x[None].astype(np.float32)))[0].double().numpy()
        return np.repeat(y[None], int(samples), axis=0)

    def save(self, directory) -> None:
        """Config (JSON), the network's state_dict (``model.pt``), feature statistics
        (``feature_stats.npz``) and the training history (JSON) into ``directory``."""
        super().save(directory)
        directory = Path(directory)
        save_checkpoint_file(directory / "model.pt", self.model.state_dict())
        np.savez(directory / "feature_stats.npz", mean=self.stats[0], std=self.stats[1])
        (directory / "history.json").write_text(json.dumps(self.history, indent=1) + "\n")

    @classmethod
    def load(cls, directory):
        """Rebuild from :meth:`save`'s output; its files are read without pickle.

        Raises
        ------
        UserError
            A file of the checkpoint is missing.
        DataError
            A file that :meth:`save` did not write (names the file).
        """
        method = super().load(directory)
        directory = Path(directory)
        cfg = method._config
        method.model = AudioToCoefficients(n_mels=cfg["n_mels"], channels=cfg["channels"], hidden=cfg["hidden"])
        path = directory / "model.pt"
        state = load_checkpoint_file(path, where="RegressionMethod.load", old_format_hint=old_format_hint(directory))
        try:
            method.model.load_state_dict(state)
        except (AttributeError, TypeError, RuntimeError) as exc:
            raise DataError(f"RegressionMethod.load: {path} does not hold this network's weights "
                            f"({type(exc).__name__}: {' '.join(str(exc).split())[:300]})") from None
        method.model.eval()
        stats = read_npz_arrays(directory / "feature_stats.npz", where="RegressionMethod.load")
        if not {"mean", "std"} <= set(stats):
            raise DataError(f"RegressionMethod.load: {directory / 'feature_stats.npz'} lacks 'mean' and 'std'")
        method.stats = (stats["mean"], stats["std"])
        history = directory / "history.json"
        try:
            method.history = json.loads(history.read_text(encoding="utf-8")) if history.is_file() else None
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DataError(f"RegressionMethod.load: {history} is not JSON ({exc})") from None
        return method
