"""Presets with flat overrides, and paths inside presets.

A preset is a named config of sections (``model``, ``training``, ...) of keys; a
method is built from a preset and *flat* overrides (``channels=128``) that land in
whichever section holds the key. A mistake in a preset name or a key is a
:class:`~blendvoca.errors.UserError` that lists the close matches.
"""

from __future__ import annotations

import copy
import difflib
import os

from blendvoca.errors import UserError

__all__ = ["expand_path", "resolved_preset"]


def expand_path(value: str) -> str:
    """Expand ``${VAR:-default}`` then ``~`` in a preset path."""
    if value.startswith("${") and value.endswith("}") and ":-" in value:
        var, default = value[2:-1].split(":-", 1)
        value = os.environ.get(var, default)
    return os.path.expanduser(value)


def resolved_preset(presets: dict, preset: str, overrides: dict, *, method: str) -> dict:
    """``presets[preset]`` (sections of keys) deep-copied with flat ``overrides`` applied
    and ``"preset"`` set: the rule SAiD's and CDFace's configs share.

    ``encoder`` may be a spec dict or a kind string, ``wav2vec2_path`` sets the wav2vec2
    directory (required, and ``${VAR:-default}`` / ``~`` expanded, for that encoder); an
    unknown preset or key is a :class:`~blendvoca.errors.UserError` naming ``method``
    and the close matches.
    """
    if preset not in presets:
        close = difflib.get_close_matches(str(preset), presets, n=3)
        raise UserError(f"{method} preset: expected one of {sorted(presets)}, got {preset!r}"
                        + (f" (did you mean {close}?)" if close else ""))
    config = copy.deepcopy(presets[preset])
    overrides = dict(overrides)
    path = overrides.pop("wav2vec2_path", None)
    if isinstance(overrides.get("encoder"), str):
        kind = overrides["encoder"]
        overrides["encoder"] = {"kind": kind, "path": path} if kind == "wav2vec2" else {"kind": kind}
    elif path is not None:
        overrides.setdefault("encoder", {"kind": "wav2vec2", "path": path})
    sections = {key: section for section, values in config.items() for key in values}
    for key, value in overrides.items():
        if key not in sections:
            close = difflib.get_close_matches(key, sections, n=3)
            raise UserError(f"{method} config: unknown key {key!r}"
                            + (f" (did you mean {close}?)" if close else f"; known keys: {sorted(sections)}"))
        config[sections[key]][key] = copy.deepcopy(value)
    encoder = config["model"]["encoder"]
    if encoder.get("kind") == "wav2vec2":
        if not encoder.get("path"):
            raise UserError(f"{method} config: the wav2vec2 encoder needs a local directory "
                            "(wav2vec2_path=... or BLENDVOCA_WAV2VEC2)")
        encoder["path"] = expand_path(str(encoder["path"]))
    config["preset"] = preset
    return config
