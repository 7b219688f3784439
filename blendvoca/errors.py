"""The project's one error tree.

Every error that the project raises on purpose is a :class:`BlendVOCAError`, in one
of four branches, and the branch decides what a command-line tool does with it
(:mod:`blendvoca.cli` owns the exit codes)::

    BlendVOCAError
    ├── UserError        (ValueError)    a mistake in what was asked: a flag, a path, a
    │   │                                config entry, a missing asset      -> exit 2
    │   └── OutputDirError               an output folder that cannot be used
    ├── DataError        (ValueError)    a file whose content is wrong; the message names
    │                                    the file and the position (subject, sentence,
    │                                    frame, line)                        -> exit 2
    ├── MethodError      (RuntimeError)  a method plug-in misbehaved: raised while being
    │   │                                built, trained, loaded or asked to generate,
    │   │                                or returned something off the contract -> exit 3
    │   ├── MethodOutputError (ValueError)
    │   └── MethodTimeout
    └── CheckFailed                      a check that ran and found a problem (asset
                                         verification, a sanity check)       -> exit 4

Messages name what was expected, what arrived and where. ``UserError`` and
``DataError`` are ``ValueError`` subclasses (and ``MethodError`` a ``RuntimeError``)
so that code catching the builtin types keeps working; the command-line layer never
catches a bare ``ValueError``: anything outside this tree (and ``OSError`` on a user
path) is an internal bug and is shown with its traceback.
"""

from __future__ import annotations

__all__ = [
    "BlendVOCAError",
    "CheckFailed",
    "DataError",
    "MethodError",
    "MethodOutputError",
    "MethodTimeout",
    "OutputDirError",
    "UserError",
    "error_line",
]


class BlendVOCAError(Exception):
    """Base of every error the project raises on purpose."""


class UserError(BlendVOCAError, ValueError):
    """A mistake in what the user asked for (flag, path, config, asset); nothing was done."""


class DataError(BlendVOCAError, ValueError):
    """A file whose content is not what it should be; the message names the file and position."""


class OutputDirError(UserError):
    """An output folder that cannot be used: not ours, not writable, full, locked."""


class MethodError(BlendVOCAError, RuntimeError):
    """A method plug-in raised while being built, trained, loaded or asked to generate."""


class MethodOutputError(MethodError, ValueError):
    """A plug-in returned tracks of the wrong shape, non-finite or out-of-range values."""


class MethodTimeout(MethodError):
    """A method's ``generate`` or ``train`` ran past the limit the runner enforces."""


class CheckFailed(BlendVOCAError):
    """A check ran to the end and found a problem (a corrupted asset, a failed sanity check)."""


def error_line(error: BaseException) -> str:
    """One line for the user: the message, and for an ``OSError`` the path and the reason."""
    if isinstance(error, OSError) and not isinstance(error, BlendVOCAError):
        where = error.filename if error.filename is not None else ""
        reason = error.strerror or str(error)
        text = f"{where}: {reason}" if where else reason
    else:
        text = str(error)
    return "error: " + " ".join(text.split())
