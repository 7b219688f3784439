"""Training of the lip-sync expert: shift classification by contrastive distances.

Each training example is a crop of ``L`` frames of a coefficient track and the
audio features around it. For every motion frame the audio frames at all
shifts ``-max_shift..max_shift`` are candidates; the logits are the negative
squared embedding distances over a temperature, and the cross-entropy target is
the true lag (0 for real data; the synthetic corpus's ``lag_frames`` when its
sidecar is reachable), so the model learns exactly what :meth:`SyncExpert.sync`
asks: the true shift is the nearest. Time-budgeted (``max_seconds``) or
step-budgeted, with a cosine learning-rate decay over whichever ends first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from benchmark.lipsync.expert import DEFAULT_CONFIG, SyncExpert, audio_features, build_expert
from benchmark.methods.training_loop import StepLoop, optimiser_step
from blendvoca.errors import BlendVOCAError, DataError, UserError
from blendvoca.names import BLENDVOCA_NAMES


#: Smallest per-shape standard deviation used to standardise coefficients.
STD_FLOOR = 0.01


@dataclass(frozen=True)
class SyncItem:
    """One sentence for the expert: coefficients ``(T, 32)``, 16 kHz audio ``(N,)``,
    the true lag (frames, positive: motion after audio) and its name."""

    coeffs: np.ndarray
    audio: np.ndarray
    lag: int
    name: str


def dataset_items(dataset, split: str = "train") -> list[SyncItem]:
    """The sentences of a split of a :class:`benchmark.data.BlendVOCADataset`.

    The true lag comes from the synthetic sidecar (``synthetic.json``) of the
    build's source corpus when it is reachable, else 0 (real recordings).
    """
    lags = {}
    try:
        meta = dataset.corpus.synthetic
    except (OSError, BlendVOCAError, AttributeError):  # no source corpus reachable: real-data lags (0)
        meta = None
    if meta:
        for subject, info in meta.get("subjects", {}).items():
            for sentence, item in info.get("sentences", {}).items():
                lags[subject, sentence] = int(item.get("lag_frames", 0))
    items = []
    for subject in dataset.split(split):
        for sentence in dataset.sentences(subject):
            audio, rate = dataset.audio(subject, sentence)
            if rate != 16000:
                raise DataError(f"dataset_items: {subject}/{sentence}: expected 16 kHz audio, got {rate}")
            items.append(SyncItem(coeffs=np.asarray(dataset.coeffs(subject, sentence), dtype=np.float64),
                                  audio=np.asarray(audio, dtype=np.float32),
                                  lag=lags.get((subject, sentence), 0), name=f"{subject}/{sentence}"))
    return items


def _shift_logits(net, motion: torch.Tensor, mel: torch.Tensor, crop: int, max_shift: int, temperature: float):
    m = net.motion(motion)                           # (B, E, L)
    a = net.audio(mel)                               # (B, E, L + 2S)
    windows = a.unfold(2, crop, 1)                   # (B, E, 2S + 1, L): window k = audio shift S - k
    d2 = ((m[:, :, None, :] - windows) ** 2).sum(dim=1)  # (B, 2S + 1, L)
    return -d2 / temperature


def train_expert(items, *, max_steps: int | None = None, max_seconds: float | None = None, batch_size: int = 32,
                 crop: int = 48, lr: float = 2e-3, temperature: float = 0.1, seed: int = 0, config=None,
                 trained_on: dict | None = None, stop=None, threads: int = 1, channel_gain: float = 0.0,
                 channel_drop: float = 0.0) -> SyncExpert:
    """Train a :class:`SyncExpert` on sentences.

    Parameters
    ----------
    items : sequence of SyncItem
        Training sentences (``dataset_items(dataset, "train")``).
    max_steps, max_seconds : optional
        Budget; at least one must be given; training stops at whichever comes first.
    batch_size, crop : int
        Crops per step and their length (frames).
    lr : float
        Peak AdamW learning rate (cosine decay to 0 over the budget).
    temperature : float
        Of the squared distances in the logits.
    seed : int
    config : dict, optional
        Overrides of :data:`benchmark.lipsync.expert.DEFAULT_CONFIG`.
    trained_on : dict, optional
        Provenance stored in the checkpoint (steps and seconds are added).
    stop : callable, optional
        Checked each step; training ends early (keeping the model) when it returns True.
    threads : int
        Torch CPU threads while training (1: the small convolutions run several
        times faster single-threaded on a shared 2-core machine).
    channel_gain, channel_drop : float
        Motion augmentation (0: none, the original recipe): every crop's shapes are
        scaled by ``exp(N(0, channel_gain))`` each and zeroed with probability
        ``channel_drop`` each, so the expert reads the timing of whichever shapes
        move rather than one rig's or capture's proportions.

    Returns
    -------
    SyncExpert
        In eval mode. Interrupting (Ctrl-C) also returns the model trained so far.
    """
    if max_steps is None and max_seconds is None:
        raise UserError("train_expert: give max_steps or max_seconds")
    if not items:
        raise DataError("train_expert: no training sentences")
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    cfg = {**DEFAULT_CONFIG, **(config or {})}
    all_coeffs = np.concatenate([it.coeffs for it in items])
    if all_coeffs.shape[1] != cfg["num_coeffs"]:
        raise DataError(f"train_expert: coefficient tracks have {all_coeffs.shape[1]} columns, "
                         f"expected {cfg['num_coeffs']}")
    # A floor on the scale: shapes the training data hardly uses must not turn a
    # small deviation of a generated track into a huge input.
    expert = build_expert(cfg, all_coeffs.mean(axis=0), np.maximum(all_coeffs.std(axis=0), STD_FLOOR),
                          BLENDVOCA_NAMES, trained_on)
    net, S, r = expert.net, expert.max_shift, expert.net.reach
    motions, mels, lags = [], [], []
    for it in items:
        if abs(it.lag) > S:
            raise DataError(f"train_expert: {it.name}: lag {it.lag} exceeds max_shift {S}")
        T = len(it.coeffs)
        mel = audio_features(it.audio, num_frames=T, num_mels=cfg["num_mels"], nfft=cfg["nfft"])
        motion = expert.motion_features(it.coeffs)
        motions.append(np.pad(motion, ((r, r), (0, 0)), mode="edge"))
        mels.append(np.pad(mel, ((S + r, S + r), (0, 0)), mode="edge"))
        lags.append(it.lag)
    lengths = np.array([len(it.coeffs) for it in items])
    crop = int(min(crop, lengths.min()))
    weights = lengths / lengths.sum()
    opt = torch.optim.AdamW(net.parameters(), lr=lr, weight_decay=1e-4)

    def step(loop):
        done = loop.fraction_done()
        for group in opt.param_groups:
            group["lr"] = lr * 0.5 * (1.0 + np.cos(np.pi * done))
        which = rng.choice(len(items), size=batch_size, p=weights)
        m_batch, a_batch, targets = [], [], []
        for i in which:
            c = int(rng.integers(0, lengths[i] - crop + 1))
            m_batch.append(motions[i][c:c + crop + 2 * r])
            a_batch.append(mels[i][c:c + crop + 2 * S + 2 * r])
            targets.append(S - lags[i])
        m_t = torch.from_numpy(np.stack(m_batch)).transpose(1, 2)
        if channel_gain > 0 or channel_drop > 0:
            scale = np.exp(rng.normal(0.0, channel_gain, size=(len(which), m_t.shape[1], 1)))
            scale *= rng.random(size=scale.shape) >= channel_drop
            m_t = m_t * torch.from_numpy(scale.astype(np.float32))
        a_t = torch.from_numpy(np.stack(a_batch)).transpose(1, 2)
        m_t = m_t + 0.05 * torch.randn_like(m_t)
        a_t = a_t + 0.05 * torch.randn_like(a_t)
        logits = _shift_logits(net, m_t, a_t, crop, S, temperature)
        target = torch.tensor(targets)[:, None].expand(-1, crop)
        loss = torch.nn.functional.cross_entropy(logits, target)
        optimiser_step(loss, opt)
        return loss.item()

    net.train()
    done = StepLoop(model=net, max_steps=max_steps, max_seconds=max_seconds, desc="sync expert", threads=threads,
                    stop=stop, interruptible=True).run(step)
    expert.trained_on.update(steps=done.steps, seconds=round(done.seconds, 1),
                             final_loss=done.train_loss[-1] if done.train_loss else float("nan"),
                             sentences=len(items), crop=crop, batch_size=batch_size, seed=seed)
    if channel_gain > 0 or channel_drop > 0:
        expert.trained_on.update(channel_gain=channel_gain, channel_drop=channel_drop)
    return expert


def cached_expert(data, *, max_seconds: float | None = 240.0, max_steps: int | None = None, seed: int = 0,
                  cache_dir=None):
    """The expert trained on a build's training split, trained once and cached.

    The checkpoint is ``<cache>/sync-expert/<manifest hash[:16]>-<budget>-seed<seed>.pt``
    (``cache`` defaults to :func:`blendvoca.assets.cache_dir`), so the same build and
    budget reuse it and a changed build trains a new one.

    Parameters
    ----------
    data : path
        BlendVOCA build.
    max_seconds, max_steps : optional
        Training budget (as :func:`train_expert`).

    Returns
    -------
    (SyncExpert, Path)
        The expert and its checkpoint path (to report with the scores).
    """
    from pathlib import Path

    from benchmark.data import open_blendvoca
    from benchmark.lipsync.expert import load_expert, save_expert

    if cache_dir is None:
        from blendvoca.assets import cache_dir as user_cache

        cache_dir = user_cache()
    dataset = open_blendvoca(data)
    budget = f"{max_steps}steps" if max_steps is not None else f"{max_seconds:g}s"
    # Keyed by the dataset's recipe id: the same name for the same dataset on any machine.
    key = getattr(dataset, "recipe_id", dataset.manifest_hash)
    path = Path(cache_dir).expanduser() / "sync-expert" / f"{key[:16]}-{budget}-seed{seed}.pt"
    if path.is_file():
        return load_expert(path), path
    expert = train_expert(dataset_items(dataset, "train"), max_steps=max_steps, max_seconds=max_seconds, seed=seed,
                          trained_on={"data": str(Path(data).expanduser().resolve()), "split": "train",
                                      "subjects": dataset.split("train"), "recipe_id": key,
                                      "manifest_hash": dataset.manifest_hash})
    save_expert(expert, path)
    return expert, path
