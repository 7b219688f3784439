"""Presets with flat overrides, and paths inside presets.

A preset is a named config of sections (``model``, ``training``, ...) of keys; a
method is built from a preset and *flat* overrides (``channels=128``) that land in
whichever section holds the key (:func:`benchmark.methods.config.preset_keys`, the
rule the config schemas describe too). A mistake in a preset name or a key is a
:class:`~blendvoca.errors.UserError` that lists the close matches.
"""

from __future__ import annotations

import copy
import difflib
import os

from baselines.common.chunking import chunk_options
from baselines.common.device import precision_option
from benchmark.methods.config import Option, preset_keys
from blendvoca.errors import UserError

__all__ = ["expand_path", "preset_options", "resolved_preset"]

#: The ``wav2vec2_path`` key of the presets whose ``model`` section has an ``encoder``.
WAV2VEC2_PATH = Option("wav2vec2_path", (str, type(None)), None, "local directory of the wav2vec2 encoder")


#: The one-sentence help of the flat preset keys the baselines share (``--list-config``);
#: each method's presets module adds its own in ``HELP`` (:func:`preset_help`).
COMMON_HELP = {
    "lr": "learning rate of the optimiser",
    "weight_decay": "weight decay of the optimiser",
    "grad_clip": "largest gradient norm, clipped to it (null: no clipping)",
    "max_steps": "training steps when no budget is given (null: by epochs or seconds)",
    "max_seconds": "training seconds when no budget is given (null: no time limit)",
    "max_epochs": "training epochs when no step or time limit ends it first (null: none)",
    "batch_size": "sequences per training step",
    "window": "training window length in 60 fps frames (null: whole sentences)",
    "num_threads": "torch threads while training and generating (null: torch's default)",
    "dropout": "dropout probability of the network's blocks",
    "motion_scale": "factor on vertex displacements inside the network (1000: millimetres, 1: metres)",
    "period": "period in frames of the periodic positional encoding / alignment bias",
    "feature_dim": "width of the decoder's features",
    "n_head": "attention heads of the decoder",
    "num_layers": "transformer decoder layers",
    "audio": "audio encoder spec (a dict, or a kind string: logmel, wav2vec2)",
    "encoder": "audio encoder spec (a dict, or a kind string: logmel, wav2vec2, wav2vec2-tiny)",
    "heads": "attention heads",
    "wav2vec2_path": "folder of the wav2vec 2.0 weights (from_pretrained layout) for that encoder",
}


def preset_help(own: dict | None = None) -> dict:
    """The help of a method's flat preset keys: :data:`COMMON_HELP` with the method's ``own`` over it."""
    return {**COMMON_HELP, **(own or {})}


def preset_options(*, encoder: bool = False) -> tuple:
    """The options a preset-based baseline's schema adds to its presets' keys
    (:meth:`~benchmark.methods.config.ConfigSchema.with_presets`): ``mixed_precision``, the
    chunking keys and, for presets with an ``encoder``, ``wav2vec2_path``."""
    return ((WAV2VEC2_PATH,) if encoder else ()) + (precision_option(), *chunk_options())


def expand_path(value: str) -> str:
    """Expand ``${VAR:-default}`` then ``~`` in a preset path."""
    if value.startswith("${") and value.endswith("}") and ":-" in value:
        var, default = value[2:-1].split(":-", 1)
        value = os.environ.get(var, default)
    return os.path.expanduser(value)


def resolved_preset(presets: dict, preset: str, overrides: dict, *, method: str,
                    prefixes: dict | None = None) -> dict:
    """``presets[preset]`` deep-copied with flat ``overrides`` applied: the one rule every
    preset-based baseline resolves its config with.

    Each flat key lands where :func:`benchmark.methods.config.preset_keys` says (a
    section's key, with the section's prefix from ``prefixes``, or a top-level value).
    A preset whose ``model`` section has an ``encoder`` (SAiD, CDFace) also takes
    ``encoder`` as a kind string and ``wav2vec2_path`` as the wav2vec2 directory
    (required, and ``${VAR:-default}`` / ``~`` expanded, for that encoder). An unknown
    preset or key is a :class:`~blendvoca.errors.UserError` naming ``method`` and the
    close matches.
    """
    if preset not in presets:
        close = difflib.get_close_matches(str(preset), presets, n=3)
        raise UserError(f"{method} preset: expected one of {sorted(presets)}, got {preset!r}"
                        + (f" (did you mean {close}?)" if close else ""))
    config = copy.deepcopy(presets[preset])
    overrides = dict(overrides)
    has_encoder = "encoder" in config.get("model", {})
    if has_encoder:
        path = overrides.pop("wav2vec2_path", None)
        if isinstance(overrides.get("encoder"), str):
            kind = overrides["encoder"]
            overrides["encoder"] = {"kind": kind, "path": path} if kind == "wav2vec2" else {"kind": kind}
        elif path is not None:
            overrides.setdefault("encoder", {"kind": "wav2vec2", "path": path})
    keys = preset_keys(config, prefixes)
    for flat, value in overrides.items():
        if flat not in keys:
            close = difflib.get_close_matches(flat, keys, n=3)
            raise UserError(f"{method} config: unknown key {flat!r}"
                            + (f" (did you mean {close}?)" if close else f"; known keys: {sorted(keys)}"))
        section, key = keys[flat]
        (config if section is None else config[section])[key] = copy.deepcopy(value)
    if has_encoder:
        encoder = config["model"]["encoder"]
        if encoder.get("kind") == "wav2vec2":
            if not encoder.get("path"):
                raise UserError(f"{method} config: the wav2vec2 encoder needs a local directory "
                                "(wav2vec2_path=... or BLENDVOCA_WAV2VEC2)")
            encoder["path"] = expand_path(str(encoder["path"]))
    return config
