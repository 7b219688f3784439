"""The project's error family: every user mistake or bad input raises a subclass of
:class:`BlendVOCAError`, whose message names what was expected, what was found and
where (file, subject, sentence, frame).

The command-line tools turn these (and ``OSError`` on user paths) into one
``error: ...`` line and exit status 2 with :func:`error_line`.
"""

from __future__ import annotations


class BlendVOCAError(ValueError):
    """Base of the project's input and usage errors (a ``ValueError``)."""


class OutputDirError(BlendVOCAError):
    """An output folder that cannot be used: not ours, not writable, full, locked."""


def error_line(error: BaseException) -> str:
    """One line for the user: the message, and for an ``OSError`` the path and the reason."""
    if isinstance(error, OSError) and not isinstance(error, BlendVOCAError):
        where = error.filename if error.filename is not None else ""
        reason = error.strerror or str(error)
        text = f"{where}: {reason}" if where else reason
    else:
        text = str(error)
    return "error: " + " ".join(text.split())
