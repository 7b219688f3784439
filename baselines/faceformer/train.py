"""Training FaceFormer on vertex sequences: teacher forcing, MSE, Adam (the authors' recipe)."""

from __future__ import annotations

import math
import time

import numpy as np
import torch
from tqdm.auto import tqdm

from baselines.said.threads import torch_threads

__all__ = ["sequence_tensors", "train_faceformer"]


def sequence_tensors(seq, *, scale: float, normalise_audio: bool):
    """``(audio (1, N), template (1, V*3), vertices (1, T, V*3))`` float32 tensors of a sequence."""
    audio = torch.from_numpy(seq.audio)[None]
    if normalise_audio:
        from baselines.faceformer.audio import normalized_speech

        audio = normalized_speech(audio)
    return (audio, torch.from_numpy(seq.template)[None] * scale, torch.from_numpy(seq.vertices)[None] * scale)


def train_faceformer(model, train, val, subjects, *, training: dict, seed: int, max_steps: float, max_seconds: float,
                     progress: bool = True) -> dict:
    """Train ``model`` (a :class:`~baselines.faceformer.model.Faceformer`) in place.

    One sentence per step (batch 1, as the authors), teacher-forced MSE on the
    vertices, Adam. Keeps the weights with the lowest validation MSE when ``val`` is
    given (checked ten times over the run and at the end).

    Returns
    -------
    dict
        ``train_loss`` per step, ``val`` ``[step, loss]`` pairs, ``steps``, ``seconds``.
    """
    import copy

    scale = float(training["motion_scale"])
    w2v = model.config["audio"]["kind"] == "wav2vec2"
    rng = np.random.default_rng(seed)
    params = [p for p in model.parameters() if p.requires_grad]
    opt = torch.optim.Adam(params, lr=training["lr"])
    tensors = [(sequence_tensors(s, scale=scale, normalise_audio=w2v), subjects.index(s.subject)) for s in train]
    val_tensors = [(sequence_tensors(s, scale=scale, normalise_audio=w2v), 0) for s in val]
    n_sub = len(subjects)
    if training.get("max_epochs") and math.isinf(max_steps) and math.isinf(max_seconds):
        max_steps = int(training["max_epochs"]) * len(tensors)
    check_every = max(1, int(max_steps // 10)) if not math.isinf(max_steps) else 200

    def val_loss() -> float:
        model.eval()
        total = 0.0
        with torch.no_grad():
            for (audio, template, verts), _ in val_tensors:
                # unseen speakers: average over the styles, as the benchmark samples them
                losses = [torch.mean((model(audio, template, verts, torch.eye(n_sub)[k : k + 1]) - verts) ** 2)
                          for k in range(min(n_sub, 2))]
                total += float(sum(losses) / len(losses))
        model.train()
        return total / max(1, len(val_tensors))

    history = {"train_loss": [], "val": [], "best_step": None}
    best, best_state = math.inf, None
    start, step = time.perf_counter(), 0
    bar = tqdm(total=None if math.isinf(max_steps) else int(max_steps), desc=f"{type(model).__name__} training",
               disable=not progress)
    model.train()
    with torch_threads(training.get("num_threads")):
        order = []
        while step < max_steps and time.perf_counter() - start < max_seconds:
            if not order:
                order = list(rng.permutation(len(tensors)))
            (audio, template, verts), k = tensors[order.pop()]
            one_hot = torch.eye(n_sub)[k : k + 1]
            loss = torch.mean((model(audio, template, verts, one_hot) - verts) ** 2)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            if training.get("grad_clip"):
                torch.nn.utils.clip_grad_norm_(params, training["grad_clip"])
            opt.step()
            step += 1
            history["train_loss"].append(float(loss) / scale**2)
            bar.update(1)
            bar.set_postfix(mse_mm2=f"{history['train_loss'][-1] * 1e6:.4f}", refresh=False)
            if val_tensors and step % check_every == 0:
                v = val_loss()
                history["val"].append([step, v / scale**2])
                if v < best:
                    best, best_state, history["best_step"] = v, copy.deepcopy(model.state_dict()), step
        if val_tensors and step and (not history["val"] or history["val"][-1][0] != step):
            v = val_loss()
            history["val"].append([step, v / scale**2])
            if v < best:
                best, best_state, history["best_step"] = v, copy.deepcopy(model.state_dict()), step
    bar.close()
    if best_state is not None:
        model.load_state_dict(best_state)
    model.eval()
    history["steps"], history["seconds"] = step, time.perf_counter() - start
    return history
