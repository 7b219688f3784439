"""What a trained VAE was trained on: its card, and the check that it fits a build.

A VAE's state dict holds its weights only: the number of coefficients it reads is in
the shape of its first convolution, but not which shapes they are. The trainer
(:func:`benchmark.features.train.train_vae_on_build`) writes beside ``vae.pth`` a card
``vae.pth.json``::

    {"names": [the coefficient names, in column order], "data": {"recipe_id", "dataset"},
     "steps": N, "seed": k, "init": "published" (fine-tuned from it; absent: random weights),
     "reconstruction_r2": the share of the validation split's variance it gives back}

so that a VAE trained on one shape set is refused on a build of another
(:func:`check_vae_fits`): its latent features of other columns would be numbers of
nothing. A VAE without a card (trained elsewhere) is checked by its coefficient count.
"""

from __future__ import annotations

import json
from os import PathLike
from pathlib import Path

from blendvoca.errors import DataError, UserError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.json_file import read_json
from blendvoca.io.torch_file import read_torch_file

__all__ = ["check_vae_fits", "read_vae_card", "vae_card_path", "vae_channels", "write_vae_card"]

#: The state dict key whose shape gives the coefficients a VAE reads (``(out, channels, kernel)``).
_FIRST_CONV = "encoder.conv_layers.0.weight"


def vae_card_path(path) -> Path:
    """``<vae>.json``: the card of the VAE at ``path``."""
    path = Path(path).expanduser()
    return path.with_name(path.name + ".json")


def write_vae_card(path, names, *, recipe_id: str, dataset: str, steps: int, seed: int, beta: float = 1.0,
                   init: str | None = None, reconstruction_r2: float | None = None) -> Path:
    """Write the card of the VAE at ``path`` (atomically); returns the card's path. ``beta``
    and ``init`` (the starting weights, None: random) are recorded when they are not the
    defaults, the held-out reconstruction R^2 when given."""
    card = vae_card_path(path)
    record = {"names": [str(n) for n in names], "data": {"recipe_id": str(recipe_id), "dataset": str(dataset)},
              "steps": int(steps), "seed": int(seed)}
    if beta != 1.0:
        record["beta"] = float(beta)
    if init is not None:
        record["init"] = str(init)
    if reconstruction_r2 is not None:
        record["reconstruction_r2"] = round(float(reconstruction_r2), 4)
    with atomic_write(card, "w") as handle:
        json.dump(record, handle, indent=1)
    return card


def read_vae_card(path) -> dict | None:
    """The card of the VAE at ``path``, or None when it has none.

    Raises
    ------
    DataError
        A card that is not an object with a list of names (naming the file).
    """
    card = vae_card_path(path)
    if not card.is_file():
        return None
    record = read_json(card, what="a VAE card (JSON object)")
    if not isinstance(record, dict) or not isinstance(record.get("names"), list):
        raise DataError(f"{card}: expected a VAE card, a JSON object with 'names' (a list of coefficient names)")
    return record


def vae_channels(path) -> int:
    """The number of coefficients the VAE state dict at ``path`` reads.

    Raises
    ------
    DataError
        Not a VAE state dict (naming the file).
    """
    state = read_torch_file(path, where="vae_channels")
    if isinstance(state, dict) and "state_dict" in state and _FIRST_CONV not in state:
        state = state["state_dict"]
    try:
        return int(state[_FIRST_CONV].shape[1])
    except (KeyError, TypeError, AttributeError, IndexError):
        raise DataError(f"{path}: not a BlendVOCA VAE state dict (no {_FIRST_CONV!r})") from None


def check_vae_fits(path: str | PathLike, names, *, flag: str = "--vae", data=None) -> None:
    """UserError unless the VAE at ``path`` is a file that reads the coefficients ``names``
    (a build's ``dataset.names``): the same count, and where it has a card, the same names
    in the same order.

    Parameters
    ----------
    path : path-like
    names : sequence of str
    flag : str
        Names the option in the message.
    data : path-like, optional
        The build, for the message's training command.
    """
    if not Path(path).expanduser().is_file():
        raise UserError(f"{flag} {path}: no such file (a VAE state dict, python -m benchmark.features.train)")
    names = [str(n) for n in names]
    train = (f"; train one on this build: python -m benchmark.features.train --data {data} --out VAE.pth"
             if data is not None else "; train one on the build (python -m benchmark.features.train)")
    card = read_vae_card(path)
    trained_on = ""
    if card is not None:
        source = card.get("data") or {}
        trained_on = f", trained on {source.get('dataset', '?')} build {str(source.get('recipe_id', '?'))[:12]}"
    count = vae_channels(path)
    if count != len(names):
        raise UserError(f"{flag} {path}: a VAE of {count} coefficients{trained_on}, but the build has "
                        f"{len(names)} ({', '.join(names[:3])}, ...){train}")
    if card is not None and [str(n) for n in card["names"]] != names:
        theirs = [str(n) for n in card["names"]]
        where = next(i for i, (a, b) in enumerate(zip(theirs, names)) if a != b)
        raise UserError(f"{flag} {path}: a VAE trained on another shape set{trained_on}: its column {where} is "
                        f"{theirs[where]!r}, the build's is {names[where]!r}{train}")

