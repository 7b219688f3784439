"""Training of CDFace in three stages (Sec. IV, implementation details).

1. the lip VQ prior and 2. the upper-face VQ prior, each with Eq. 3;
3. the code querying model with Eq. 15 + Eq. 16, both part priors frozen,
   teacher forcing (ground-truth past motion), closure mask from the ground truth.

Each stage samples random windows of ``window`` frames (whole sentences when None)
from the training sentences and stops at its step limit or time limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from baselines.cdface.closure import closure_mask
from baselines.cdface.losses import lip_losses, upper_face_losses
from baselines.cdface.vqvae import vq_loss
from baselines.common.dataset import sentence_audio
from baselines.common.device import MixedPrecision, module_device
from benchmark.methods.training_loop import StepLoop, optimiser_step
from blendvoca.errors import UserError
from blendvoca.runtime.threads import limited_threads

__all__ = ["LR_SCHEDULES", "SentenceData", "WindowSampler", "cosine_lr", "load_sentences", "moving_vertices", "prepare_sentences", "stage_limits",
           "train_cdface"]

#: Share of a total time budget given to the lip prior, the upper-face prior and the querying model.
STAGE_SHARES = (0.2, 0.2, 0.6)


@dataclass
class SentenceData:
    """One training sentence in model units.

    Attributes
    ----------
    lips : (T, 3 V_l) float32; upper : (T, 3 V_u) float32
    mask : (T,) float32 closure mask (Eq. 6)
    features : (T, F) float32 frozen audio features
    style : int
    """

    lips: np.ndarray
    upper: np.ndarray
    mask: np.ndarray
    features: np.ndarray
    style: int


class WindowSampler:
    """Random batches of windows of the training sentences.

    Parameters
    ----------
    sentences : list of SentenceData
    window : int or None
        Frames per window (None: one whole sentence per batch).
    batch_size : int
    rng : numpy Generator
    """

    def __init__(self, sentences, window, batch_size: int, rng: np.random.Generator):
        if not sentences:
            raise ValueError("WindowSampler: no training sentences")
        self.sentences, self.rng = sentences, rng
        self.window = None if window is None else int(window)
        self.batch_size = 1 if window is None else int(batch_size)
        if self.window is not None:
            short = min(len(s.lips) for s in sentences)
            self.window = min(self.window, short)

    def batch(self) -> dict:
        """Tensors ``lips``, ``upper``, ``mask``, ``features``, ``style``, ``offset``,
        ``first_lips``, ``first_upper`` (the frame before each window, zeros at 0)."""
        items = []
        for _ in range(self.batch_size):
            s = self.sentences[int(self.rng.integers(len(self.sentences)))]
            w = len(s.lips) if self.window is None else self.window
            start = int(self.rng.integers(len(s.lips) - w + 1))
            items.append((s, start, w))
        def stack(get):
            return torch.from_numpy(np.stack([get(s, a, w) for s, a, w in items]))
        return {
            "lips": stack(lambda s, a, w: s.lips[a:a + w]),
            "upper": stack(lambda s, a, w: s.upper[a:a + w]),
            "mask": stack(lambda s, a, w: s.mask[a:a + w]),
            "features": stack(lambda s, a, w: s.features[a:a + w]),
            "style": torch.as_tensor([s.style for s, _, _ in items], dtype=torch.int64),
            "offset": torch.as_tensor([a for _, a, _ in items], dtype=torch.int64),
            "first_lips": stack(lambda s, a, w: s.lips[a - 1] if a else np.zeros_like(s.lips[0])),
            "first_upper": stack(lambda s, a, w: s.upper[a - 1] if a else np.zeros_like(s.upper[0])),
        }


def stage_limits(training: dict, num_sentences: int, *, max_steps=None, max_seconds=None):
    """``[(steps, seconds)]`` of the three stages.

    Epoch counts (``vq_epochs``, ``query_epochs``) become steps of
    ``ceil(num_sentences * mean windows per sentence / batch)``, approximated by
    ``ceil(num_sentences / batch)``; a run's ``max_steps`` caps every stage and its
    ``max_seconds`` is shared out by :data:`STAGE_SHARES`.
    """
    per_epoch = max(1, math.ceil(num_sentences / (1 if training["window"] is None else training["batch_size"])))
    out = []
    for k, share in enumerate(STAGE_SHARES):
        prefix = "vq" if k < 2 else "query"
        epochs = training[f"{prefix}_epochs"]
        steps = training[f"{prefix}_max_steps"]
        if epochs is not None:
            steps = int(epochs) * per_epoch if steps is None else min(int(steps), int(epochs) * per_epoch)
        if max_steps is not None:
            steps = int(max_steps) if steps is None else min(int(steps), int(max_steps))
        seconds = training[f"{prefix}_max_seconds"]
        if max_seconds is not None:
            seconds = float(max_seconds) * share if seconds is None else min(float(seconds), float(max_seconds) * share)
        if steps is None and seconds is None:
            raise UserError("CDFace training: every stage needs a step or time limit (epochs, max_steps or max_seconds)")
        out.append((steps, seconds))
    return out


#: ``lr_schedule`` values: the stage's learning rate stays ``lr``, or decays from ``lr`` to 0 on a half cosine.
LR_SCHEDULES = ("constant", "cosine")


def cosine_lr(lr: float, step: int, steps=None, elapsed: float = 0.0, seconds=None) -> float:
    """Learning rate ``lr (1 + cos(pi f)) / 2`` at the fraction ``f`` of a stage done.

    ``f = step / steps`` under a step limit, else ``elapsed / seconds`` (a time
    limit only); with both, the larger.
    """
    fractions = [step / steps] if steps else []
    if seconds:
        fractions.append(elapsed / seconds)
    f = min(1.0, max(fractions)) if fractions else 0.0
    return float(lr) * 0.5 * (1.0 + math.cos(math.pi * f))


def _run_stage(name, params, loss_fn, sampler, steps, seconds, training, amp=None, **loop) -> list:
    """Optimise ``params`` on ``loss_fn`` of ``sampler``'s batches for ``steps`` steps and/or
    ``seconds`` on the one training loop (``loop``: :class:`~benchmark.methods.training_loop.StepLoop`'s
    ``model``, ``on_checkpoint``, ``fractions``, ``step_offset``). ``amp``
    (:class:`~baselines.common.device.MixedPrecision`) says where the batches go and whether
    the losses are autocast (default: the CPU, plain)."""
    amp = amp or MixedPrecision(None, "cpu")
    params = [p for p in params if p.requires_grad]
    opt = torch.optim.AdamW(params, lr=training["lr"], weight_decay=training["weight_decay"])
    schedule = training.get("lr_schedule", "constant")
    if schedule not in LR_SCHEDULES:
        raise UserError(f"CDFace training: expected lr_schedule in {LR_SCHEDULES}, got {schedule!r}")
    history = []

    def step(run):
        if schedule == "cosine":
            for group in opt.param_groups:
                group["lr"] = cosine_lr(training["lr"], run.step, steps, run.elapsed(), seconds)
        batch = {key: value.to(amp.device) for key, value in sampler.batch().items()}  # the CPU: no copy
        with amp.autocast():
            losses = loss_fn(batch)
        optimiser_step(losses["total"], opt, amp=amp, grad_clip=training["grad_clip"], params=params)
        history.append({k: float(v.detach()) for k, v in losses.items()})
        return history[-1]["total"]

    StepLoop(max_steps=steps, max_seconds=seconds, desc=f"CDFace: {name}", **loop).run(step)
    return history


def load_sentences(dataset, subjects) -> list[dict]:
    """``{"subject", "sentence", "vertices" (T, V, 3), "template" (V, 3), "audio" (N,)}`` of every sentence.

    Vertices are kept in float32 (half the memory: 4.6 GB for the 12 x 40 training
    split instead of 9.3 GB); the model's displacements are float32 anyway, and
    rounding 0.1 m coordinates to float32 moves them by less than 1e-8 m.
    """
    out = []
    for subject in subjects:
        template = dataset.template(subject)
        for sentence in dataset.sentences(subject):
            audio = sentence_audio(dataset, subject, sentence, where="CDFace")
            out.append({"subject": subject, "sentence": sentence,
                        "vertices": np.asarray(dataset.vertices(subject, sentence), dtype=np.float32),
                        "template": template, "audio": audio})
    return out


def moving_vertices(sentences, threshold: float | None) -> np.ndarray | None:
    """``(V,) bool``: vertices whose displacement from the template varies by more than
    ``threshold`` (temporal std of any coordinate, metres) in some sentence; None: all."""
    if threshold is None:
        return None
    moving = None
    for item in sentences:
        std = (np.asarray(item["vertices"]) - item["template"]).std(axis=0).max(axis=1) > float(threshold)
        moving = std if moving is None else moving | std
    return moving


def prepare_sentences(cdface, sentences, *, epsilon: float, lip_pair) -> list:
    """:class:`SentenceData` of sentences from :func:`load_sentences` (parts, closure mask, features)."""
    out = []
    for item in sentences:
        verts = item["vertices"]
        lips, upper = cdface.split_motion(verts, item["template"])
        feats = cdface.features(item["audio"], len(verts))[0].numpy()
        out.append(SentenceData(lips, upper, closure_mask(verts, lip_pair, epsilon), feats,
                                cdface.style_index(item["subject"])))
    return out


def train_cdface(cdface, sentences, *, seed: int = 0, max_steps=None, max_seconds=None, on_checkpoint=None,
                 fractions=(0.5,), mixed_precision=None) -> dict:
    """Train ``cdface`` in place on ``sentences`` (list of :class:`SentenceData`).

    ``on_checkpoint``: the runner's checkpoint call (``TrainingRequest.on_checkpoint``), made
    after the ``fractions`` of the steps of the last stage (the querying model; it has no
    validation, so the weights are the current ones) when that stage has a step limit, as
    ``on_checkpoint(step, total_steps=...)`` with the steps of the two VQ stages counted
    in; ``cdface`` generates during the call (eval mode, no gradients) and training then
    goes on exactly as without it.

    It trains on the device ``cdface.model`` is on: the windows are drawn on the CPU (the
    same windows for a seed on every device) and moved there; ``mixed_precision``
    (``"off"``, ``"bf16"``, ``"fp16"``) autocasts the losses when that device is a GPU.

    Returns
    -------
    dict ``{"lip_vq", "upper_vq", "query"}`` of per-step loss records.
    """
    training, loss_cfg = cdface.config["training"], cdface.config["loss"]
    limits = stage_limits(training, len(sentences), max_steps=max_steps, max_seconds=max_seconds)
    rng = np.random.default_rng(int(seed))
    torch.manual_seed(int(seed))
    model = cdface.model
    model.requires_grad_(True)
    amp = MixedPrecision(mixed_precision, module_device(model))
    history = {}
    with limited_threads(training["num_threads"], torch_only=True):
        for key, vq, part in (("lip_vq", model.lip_vq, "lips"), ("upper_vq", model.upper_vq, "upper")):
            vq.train()
            sampler = WindowSampler(sentences, training["window"], training["vq_batch_size"], rng)
            steps, seconds = limits[0 if key == "lip_vq" else 1]
            history[key] = _run_stage(key, vq.parameters(), lambda b, vq=vq, part=part: vq_loss(vq, b[part], b["offset"]),
                                      sampler, steps, seconds, training, amp=amp)
        for vq in (model.lip_vq, model.upper_vq):
            vq.eval()
            vq.requires_grad_(False)
        for module in (model.audio, model.style, model.lip_query, model.upper_query):
            module.train()

        def query_loss(b):
            out = model.teacher_forced(b["lips"], b["upper"], b["features"], b["style"], offset=b["offset"],
                                       first_lips=b["first_lips"], first_upper=b["first_upper"],
                                       past_dropout=training["past_dropout"])
            lip = lip_losses(out["lips"], b["lips"], b["mask"], out["lip_codes"], out["lip_quantized"],
                             lambda_d=loss_cfg["lambda_d_lips"], lambda_rc=loss_cfg["lambda_rc_lips"],
                             lambda_rg=loss_cfg["lambda_rg"])
            up = upper_face_losses(out["upper"], b["upper"], out["upper_codes"], out["upper_quantized"],
                                   lambda_d=loss_cfg["lambda_d_upper"], lambda_rc=loss_cfg["lambda_rc_upper"],
                                   lambda_rg=loss_cfg["lambda_rg"],
                                   repeats=model.num_lip_samples // out["upper"].shape[0])
            return {"total": lip["total"] + up["total"], **{f"lips_{k}": v for k, v in lip.items() if k != "total"},
                    **{f"upper_{k}": v for k, v in up.items() if k != "total"}}

        sampler = WindowSampler(sentences, training["window"], training["batch_size"], rng)
        done = len(history["lip_vq"]) + len(history["upper_vq"])
        history["query"] = _run_stage("query", model.query_parameters(), query_loss, sampler, *limits[2], training,
                                      amp=amp, model=model, on_checkpoint=on_checkpoint, fractions=fractions,
                                      step_offset=done)
        model.eval()
        model.requires_grad_(False)  # trained: inference only, as after CDFace.load
    return history
