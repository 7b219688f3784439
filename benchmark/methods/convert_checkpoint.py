"""Rewrite a checkpoint of an earlier BlendVOCA version in the safe format, once, knowingly.

    python -m benchmark.methods.convert_checkpoint OLD NEW --trust

Earlier versions pickled numpy arrays into the torch files of the FaceFormer,
CodeTalker, CDFace and SAiD checkpoints; such a file is now refused, since loading a
pickle can run any code it names. This tool loads OLD with
``torch.load(weights_only=False)``, which runs what the file asks for, so it does
so only with ``--trust`` (a file you or a source you trust wrote), and writes NEW
holding tensors, numbers, strings, lists and dicts only: numpy arrays become tensors
of the same dtype and values, numpy scalars Python numbers. The methods turn the
arrays back on loading, so the converted checkpoint predicts exactly as before.

OLD is a checkpoint file (``cdface.pt``, ``said.pt``) or a folder written by a
method's ``save`` (``benchmark.run --checkpoint DIR``); NEW is then a file or a
folder, which must not exist yet. In a folder every torch file (``.pt``, ``.pth``)
is converted (one that already loads safely is copied unchanged) and every other
file (the JSON config, ``.npz`` statistics) copied.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import DataError, UserError
from blendvoca.io.torch_file import REFUSED_OBJECTS, read_torch_file, safe_payload, write_torch_file
from blendvoca.runtime.staging import staged_folder

__all__ = ["TORCH_SUFFIXES", "convert_checkpoint", "convert_file", "main"]

#: Names of the files of a checkpoint folder that are torch files.
TORCH_SUFFIXES = (".pt", ".pth", ".pth.tar")


def convert_file(old: str | os.PathLike, new: str | os.PathLike, *, trust: bool = False) -> bool:
    """Write the torch file ``old`` as ``new`` in the safe format.

    Parameters
    ----------
    old, new : str or os.PathLike
    trust : bool
        Must be True for a file that a safe load refuses: it is then loaded with
        ``weights_only=False``, which runs whatever its pickle names.

    Returns
    -------
    bool
        True when the file had to be converted, False when it already loaded safely
        (copied unchanged).

    Raises
    ------
    UserError
        ``old`` is refused by a safe load and ``trust`` is False.
    DataError
        ``old`` is no torch file, or holds objects other than arrays, numbers,
        strings and containers (they have no safe form).
    """
    old, new = Path(os.fspath(old)), Path(os.fspath(new))
    try:
        read_torch_file(old, where="convert_checkpoint")
    except UserError:
        raise
    except DataError as exc:
        if REFUSED_OBJECTS not in str(exc):
            raise  # not a torch file at all: nothing to convert
        if not trust:
            raise UserError(f"convert_checkpoint: {old} holds pickled Python objects; reading them runs whatever "
                            "code the file names, so it is done only with --trust, for a checkpoint you or a source "
                            "you trust wrote (nothing was read)") from None
    else:
        new.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(old, new)
        return False
    payload = read_torch_file(old, where="convert_checkpoint", weights_only=False)
    try:
        payload = safe_payload(payload, where=f"convert_checkpoint {old}")
    except TypeError as exc:
        raise DataError(f"{exc}; this is no checkpoint that BlendVOCA wrote") from None
    write_torch_file(new, payload)
    read_torch_file(new, where="convert_checkpoint (check of the converted file)")
    return True


def convert_checkpoint(old: str | os.PathLike, new: str | os.PathLike, *, trust: bool = False) -> list[Path]:
    """Write the checkpoint ``old`` (a torch file or a method's folder) as ``new`` in the
    safe format (see the module docstring).

    Returns
    -------
    list of Path
        The files of ``new`` that were converted (the others were copied).

    Raises
    ------
    UserError
        ``old`` is missing, ``new`` exists, or ``trust`` is needed and not given.
    DataError
        A torch file of ``old`` that cannot be converted (names it).
    """
    old, new = Path(os.fspath(old)).expanduser(), Path(os.fspath(new)).expanduser()
    if not old.exists():
        raise UserError(f"convert_checkpoint: expected a checkpoint file or folder at {old}, not found")
    if new.exists() or new.is_symlink():
        raise UserError(f"convert_checkpoint: {new} exists; expected a new path (nothing is overwritten)")
    if old.is_file():
        return [new] if convert_file(old, new, trust=trust) else []
    converted = []
    with staged_folder(new) as staging:  # NEW appears complete or not at all
        for source in sorted(old.rglob("*")):
            if source.is_symlink() or not source.is_file():
                continue  # a folder written by save holds plain files; links are not followed
            target = staging / source.relative_to(old)
            target.parent.mkdir(parents=True, exist_ok=True)
            if not source.name.endswith(TORCH_SUFFIXES):
                shutil.copyfile(source, target)
            elif convert_file(source, target, trust=trust):
                converted.append(new / source.relative_to(old))
    return converted


@cli.command
def main(argv=None) -> int:
    p = cli.parser("benchmark.methods.convert_checkpoint", __doc__)
    p.add_argument("old", metavar="OLD", help="checkpoint file or folder written by an earlier version")
    p.add_argument("new", metavar="NEW", help="where the converted checkpoint goes (must not exist)")
    p.add_argument("--trust", action="store_true",
                   help="load OLD's pickled objects, which runs whatever code they name: only for a checkpoint "
                        "you or a source you trust wrote")
    args = p.parse_args(argv)
    converted = convert_checkpoint(args.old, args.new, trust=args.trust)
    names = ", ".join(str(path) for path in converted) or "none (every file already loads safely; copied)"
    print(f"wrote {args.new}; converted: {names}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
