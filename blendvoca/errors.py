"""The project's one error tree.

Every error that the project raises on purpose is a :class:`BlendVOCAError`, in one
of four branches, and the branch decides what a command-line tool does with it
(:mod:`blendvoca.cli` owns the exit codes)::

    BlendVOCAError
    ├── UserError        (ValueError)    a mistake in what was asked: a flag, a path, a
    │   │                                config entry, a missing asset      -> exit 2
    │   ├── OutputDirError               an output folder that cannot be used
    │   └── OutOfResources               memory or disk ran out (what ran out, what to try)
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

import re

__all__ = [
    "BlendVOCAError",
    "CheckFailed",
    "DataError",
    "MethodError",
    "MethodOutputError",
    "MethodTimeout",
    "OutOfResources",
    "OutputDirError",
    "UserError",
    "error_line",
    "out_of_resources",
    "ran_out_of",
]


class BlendVOCAError(Exception):
    """Base of every error the project raises on purpose."""


class UserError(BlendVOCAError, ValueError):
    """A mistake in what the user asked for (flag, path, config, asset); nothing was done."""


class DataError(BlendVOCAError, ValueError):
    """A file whose content is not what it should be; the message names the file and position."""


class OutputDirError(UserError):
    """An output folder that cannot be used: not ours, not writable, full, locked."""


class OutOfResources(UserError):
    """The machine ran out of memory or disk space; the message says which, where, and what to try."""


#: ``errno`` values that mean a resource ran out, and its name.
_RESOURCE_ERRNOS = {12: "memory", 28: "disk space", 122: "disk quota"}  # ENOMEM, ENOSPC, EDQUOT

#: The messages of torch's allocators when memory runs out (``DefaultCPUAllocator: can't
#: allocate memory``, ``CUDA out of memory``, ``Error code 12``), and of a thread that could not
#: start (its stack is memory: under ``ulimit -v`` OpenBLAS's and Python's threads fail so).
_ALLOCATOR_FAILURE = re.compile(r"can't allocate memory|CUDA out of memory|OutOfMemoryError|"
                                r"Error code 12 \(Cannot allocate memory\)|"
                                r"can't start new thread|Resource temporarily unavailable")

#: What to try, per resource.
_TRY = {
    "memory": ("fewer worker processes (--workers 1 where the command has it), a smaller --sentence-batch, "
               "a smaller split, or more memory (a higher `ulimit -v`, or close other programs)"),
    "disk space": "free space on that file system, or write to another folder",
    "disk quota": "free space within your quota, or write to another folder",
}


def ran_out_of(error: BaseException | None) -> str | None:
    """``"memory"``, ``"disk space"`` or ``"disk quota"`` when ``error``, or an error
    that caused it (``__cause__`` / ``__context__``), is a ``MemoryError`` or an
    ``OSError`` of ENOMEM, ENOSPC or EDQUOT; else None."""
    seen = set()
    while error is not None and id(error) not in seen:
        seen.add(id(error))
        if isinstance(error, OutOfResources):
            return getattr(error, "resource", "memory")
        if isinstance(error, MemoryError):
            return "memory"
        if isinstance(error, OSError) and error.errno in _RESOURCE_ERRNOS:
            return _RESOURCE_ERRNOS[error.errno]
        if isinstance(error, RuntimeError) and _ALLOCATOR_FAILURE.search(str(error)):
            return "memory"  # torch's allocators (CPU and CUDA) raise RuntimeErrors
        if isinstance(error, (ImportError, OSError)) and "failed to map segment" in str(error):
            return "memory"  # a shared library that could not be mapped (under `ulimit -v`; cffi's dlopen: OSError)
        error = error.__cause__ or error.__context__
    return None


def out_of_resources(error: BaseException, where: str = "") -> OutOfResources:
    """The :class:`OutOfResources` that reports ``error`` (one :func:`ran_out_of` names):
    what ran out, where (``where``, or the file of an ``OSError``), the original
    message, and what to try."""
    resource = ran_out_of(error) or "memory"
    if not where and isinstance(error, OSError) and error.filename:
        where = str(error.filename)
    detail = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
    detail = f"{type(error).__name__}: {detail}" if detail else type(error).__name__
    prefix = f"{where}: " if where else ""
    exc = OutOfResources(f"{prefix}ran out of {resource} ({detail}); try {_TRY[resource]}")
    exc.resource = resource
    return exc


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
