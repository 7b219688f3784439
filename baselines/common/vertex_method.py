"""The benchmark side shared by the FaceFormer and CodeTalker plug-ins.

Both are vertex methods (``output = "vertices"``) with a one-hot style over the
training speakers: sample ``s`` of an utterance is the animation in the style of
training speaker ``(seed + s) mod n_styles``, so ``S`` samples are ``S`` styles (the
papers' evaluation protocol of one animation per training-speaker condition).
Networks run at 30 fps; the results are resampled to the benchmark's 60 fps.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import torch

from baselines.common.checkpoint import load_checkpoint_file, old_format_hint, safe_payload, save_checkpoint_file
from baselines.common.device import checked_precision, method_device
from baselines.common.encoders.trainable import load_pretrained_wav2vec2
from baselines.common.presets import preset_help, preset_options
from baselines.common.sequences import (
    MotionSequence,
    motion_frames,
    motion_sequences,
    sequence_tensors,
    speaker_templates,
    to_benchmark_rate,
)
from benchmark.methods.base import Budget, Method, TrainingRequest
from blendvoca.errors import DataError
from blendvoca.runtime.threads import limited_threads

__all__ = ["VOCASET_TRAIN_SUBJECTS", "StyleVertexMethod", "official_style_names", "style_indices", "training_limits"]

#: The authors' VOCASET training speakers, in their one-hot order (the styles of the released weights).
VOCASET_TRAIN_SUBJECTS = (
    "FaceTalk_170728_03272_TA", "FaceTalk_170904_00128_TA", "FaceTalk_170725_00137_TA", "FaceTalk_170915_00223_TA",
    "FaceTalk_170811_03274_TA", "FaceTalk_170913_03279_TA", "FaceTalk_170904_03276_TA", "FaceTalk_170912_03278_TA",
)


def official_style_names(n: int) -> list[str]:
    """Names of the styles of an authors' checkpoint: VOCASET's training speakers when there are 8."""
    return list(VOCASET_TRAIN_SUBJECTS) if n == len(VOCASET_TRAIN_SUBJECTS) else [f"style{k}" for k in range(n)]


def style_indices(samples: int, seed: int, n_styles: int) -> list[int]:
    """Style (training speaker index) of each sample: ``(seed + s) mod n_styles``."""
    if n_styles < 1:
        raise ValueError(f"style_indices: expected at least one style, got {n_styles}")
    return [(int(seed) + s) % n_styles for s in range(int(samples))]


def training_limits(budget: Budget, default_steps, default_seconds) -> tuple[float, float]:
    """``(max_steps, max_seconds)`` from the budget, else the preset (``inf`` for none; an epoch count
    of the preset then applies)."""
    steps = budget.max_steps if budget.max_steps is not None else default_steps
    seconds = budget.max_seconds if budget.max_seconds is not None else default_seconds
    if budget.max_steps is not None and budget.max_seconds is None:
        seconds = None
    return (math.inf if steps is None else int(steps)), (math.inf if seconds is None else float(seconds))


class StyleVertexMethod(Method):
    """Base of the FaceFormer and CodeTalker plug-ins (see the module docstring).

    Subclasses provide ``name``, ``checkpoint_file``, ``presets`` (and ``preset_prefixes``),
    :meth:`build_network`, :meth:`network_from_state` and :meth:`fit`, and call :meth:`use_preset` (and
    :meth:`use_official` for the authors' weights) in their constructor; the network lives
    in ``self.network``, the style speakers in ``self.subjects`` and every speaker's
    template in ``self.templates``.
    """

    stochastic = True
    output = "vertices"
    checkpoint_file = "model.pt"
    #: The styles of an utterance run as one batch (False: one ``predict`` per style,
    #: for networks whose output depends on the batch position).
    batch_styles = True
    #: The presets (``{name: nested config}``) and flat-key prefixes of the subclass.
    presets: dict = {}
    preset_prefixes: dict | None = None
    #: One sentence per flat preset key of the subclass, besides the shared ones (``--list-config``).
    preset_help: dict = {}

    @classmethod
    def config_schema(cls):
        """The constructor's keys plus every flat key of the presets, typed from their values."""
        return super().config_schema().with_presets(cls.presets, default="cpu-demo", prefixes=cls.preset_prefixes,
                                                    extra=preset_options(), help=preset_help(cls.preset_help))

    def __init__(self, **config):
        super().__init__(**config)
        self.network = None
        self.subjects: list[str] = []
        self.templates: dict[str, np.ndarray] = {}
        self.history: dict = {}

    def use_preset(self, settings: dict, mixed_precision) -> None:
        """Take the resolved preset ``settings`` and the ``mixed_precision`` switch (autocast on a
        GPU, docs/gpu.md; nothing on the CPU); the method starts on the CPU."""
        self.mixed_precision = checked_precision(mixed_precision)
        self.device = method_device(None)
        self.settings = settings
        self.motion_scale = float(settings["training"]["motion_scale"])

    def use_official(self, network) -> None:
        """Take the authors' ``network`` as it is: its styles, no motion scaling, nothing to
        train (train reads the templates only; no ``--seeds``)."""
        self.network = network
        self.subjects = official_style_names(network.config["num_subjects"])
        self.motion_scale = 1.0
        self.learns = False

    def config(self) -> dict:
        return {**super().config(), "resolved": self.settings}

    # -- subclass hooks -------------------------------------------------------------
    def build_network(self, num_subjects: int, vertice_dim: int) -> None:
        """Create ``self.network`` (untrained)."""
        raise NotImplementedError

    def fit(self, train, val, request: TrainingRequest) -> dict:
        """Train ``self.network`` on :class:`~baselines.common.sequences.MotionSequence` lists under
        ``request`` (its seed, budget and checkpoint calls); return a history. The network is
        ``self.network`` from the start, already on ``self.device``, so :meth:`generate` works
        during a checkpoint call."""
        raise NotImplementedError

    def predict_motion(self, audio: np.ndarray, template: np.ndarray, style, num_frames: int) -> np.ndarray:
        """``(num_frames, V*3)`` float vertices at 30 fps in metres for one style, or
        ``(B, num_frames, V*3)`` for a list of B styles: the network's
        ``predict(audio, template, one_hot, num_frames)`` (both authors' signature) on the
        scaled motion. A list runs as one batch of B one-hot rows (the same audio and
        template in each; unless :attr:`batch_styles` is False): the per-style results
        of one call each, in a single autoregressive loop."""
        styles = [int(style)] if np.isscalar(style) else [int(s) for s in style]
        if len(styles) > 1 and not self.batch_styles:
            return np.stack([self.predict_motion(audio, template, s, num_frames) for s in styles])
        net = self.network.eval()
        w2v = net.config["audio"]["kind"] == "wav2vec2"
        seq = MotionSequence("", "", np.asarray(audio, np.float32), np.zeros((1, template.size), np.float32),
                             np.asarray(template, np.float32))
        a, tpl, _ = sequence_tensors(seq, scale=self.motion_scale, normalise_audio=w2v)
        batch = len(styles)
        one_hot = torch.eye(len(self.subjects))[styles]
        with torch.no_grad(), limited_threads(self.settings["training"].get("num_threads"), torch_only=True):
            out = net.predict(a.expand(batch, -1), tpl.expand(batch, -1), one_hot, num_frames)
        out = out.numpy() / self.motion_scale
        return out[0] if np.isscalar(style) else out

    def network_state(self) -> dict:
        """What :meth:`save` stores besides the config: the weights, the network's config, the motion scale."""
        return {"state_dict": self.network.state_dict(), "model_config": self.network.config,
                "motion_scale": self.motion_scale}

    def network_from_state(self, payload: dict):
        """The untrained network of :meth:`network_state`'s payload."""
        raise NotImplementedError

    def restore_network(self, payload: dict) -> None:
        """Rebuild ``self.network`` and the motion scale from :meth:`network_state`'s payload."""
        self.network = self.network_from_state(payload)
        self.network.load_state_dict(payload["state_dict"])
        self.motion_scale = float(payload["motion_scale"])

    # -- the contract -------------------------------------------------------------------
    contract = 3

    def train(self, dataset, request: TrainingRequest) -> None:
        """Train on the train split's vertex sequences (styles = its speakers) on ``device``
        (None: the CPU; ``"cuda"``: the network and the sentences move there, the plug-in's
        ``mixed_precision`` applies); the network is built on the CPU from the seed, so its
        initial weights are the same on every device. The authors' weights (given to the
        constructor) train nothing, make no ``on_checkpoint`` call and move to ``device``."""
        self.device = method_device(request.device)
        self.templates = speaker_templates(dataset)
        if self.network is None or not self.subjects:
            self.subjects = list(dataset.split("train"))
            if not self.subjects:
                raise DataError(f"{type(self).__name__}.train: the dataset has no training speakers")
            train = motion_sequences(dataset, "train")
            val = motion_sequences(dataset, "val") if dataset.split("val") else []
            torch.manual_seed(int(request.seed))  # the initial weights too: a step budget then trains the same network in every process
            self.build_network(len(self.subjects), int(train[0].template.size))
            if self.settings["model"]["audio"]["kind"] == "wav2vec2" and self.settings.get("wav2vec2_path"):
                load_pretrained_wav2vec2(self.network.audio_encoder, self.settings["wav2vec2_path"])
            self.network.to(self.device)  # built on the CPU from the seed, then moved
            self.history = self.fit(train, val, request)
        self.to(self.device)

    def to(self, device):
        """This method with its network on ``device`` (generation runs there); returns self."""
        self.device = method_device(device)
        if self.network is not None:
            self.network.to(self.device)
        return self

    def styles(self) -> tuple[str, ...]:
        """The speakers with a template, the training speakers first (the first is the default)."""
        first = [s for s in self.subjects if s in self.templates]
        return tuple(first + sorted(s for s in self.templates if s not in first))

    def style_index(self, subject: str) -> int:
        """One-hot index of a training speaker."""
        if subject not in self.subjects:
            raise KeyError(f"{self.name}: {subject!r} is not a training speaker; expected one of {self.subjects}")
        return self.subjects.index(subject)

    def generate(self, utterance, *, samples: int = 1, seed: int = 0):
        """``(S, T, V, 3)`` float64 metres at 60 fps: sample ``s`` in the style of speaker ``(seed + s) mod n``."""
        if self.network is None:
            raise RuntimeError(f"{self.name}: generate before train or load")
        if utterance.subject not in self.templates:
            raise KeyError(f"{self.name}: no template for subject {utterance.subject!r} "
                           f"(known: {sorted(self.templates)[:6]}...); train or load on this dataset first")
        template = self.templates[utterance.subject]
        frames30 = motion_frames(utterance.num_frames)
        motions = self.predict_motion(utterance.audio, template, style_indices(samples, seed, len(self.subjects)),
                                      frames30)  # one batch, unless batch_styles is False
        return np.stack([to_benchmark_rate(m, utterance.num_frames).reshape(utterance.num_frames, -1, 3)
                         for m in motions])

    def save(self, directory: str | os.PathLike) -> None:
        """Config (JSON), weights, style speakers and templates into ``directory``: the
        checkpoint file holds tensors, numbers and strings only (templates as float64
        tensors), so it loads with ``weights_only=True``."""
        super().save(directory)
        payload = {**self.network_state(), "subjects": list(self.subjects),
                   "templates": {k: torch.from_numpy(np.asarray(v)) for k, v in self.templates.items()},
                   "history": self.history}
        path = Path(os.fspath(directory)) / self.checkpoint_file
        save_checkpoint_file(path, safe_payload(payload, where=f"{type(self).__name__}.save {path}"))

    @classmethod
    def load(cls, directory: str | os.PathLike):
        """Rebuild from :meth:`save`'s output.

        Raises
        ------
        UserError
            No checkpoint file in ``directory``.
        DataError
            The checkpoint file is not one :meth:`save` wrote: not a torch file, pickled
            objects (an earlier version's format: the message names the converter), or
            weights that do not fit the stored configuration.
        """
        method = super().load(directory)
        directory = Path(os.fspath(directory))
        path = directory / cls.checkpoint_file
        where = f"{cls.__name__}.load"
        payload = load_checkpoint_file(path, where=where, old_format_hint=old_format_hint(directory))
        if not isinstance(payload, dict) or not {"subjects", "templates", "state_dict"} <= set(payload):
            raise DataError(f"{where}: {path} is not a checkpoint written by {cls.__name__}.save "
                            f"(expected a dict with subjects, templates and state_dict)")
        try:
            method.templates = {str(k): v.numpy() for k, v in payload["templates"].items()}
            method.subjects = list(payload["subjects"])
            method.history = payload.get("history", {})
            method.restore_network(payload)
        except (AttributeError, KeyError, TypeError, ValueError, RuntimeError) as exc:
            raise DataError(f"{where}: {path} does not hold weights this method can restore "
                            f"({type(exc).__name__}: {' '.join(str(exc).split())[:300]})") from None
        method.network.eval()
        return method
