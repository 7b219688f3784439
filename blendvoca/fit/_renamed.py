"""Keywords of the fitting functions renamed in 2026: the old spelling still works, with a warning."""

from __future__ import annotations

import functools
import warnings

#: The old spellings are accepted until this date, then removed.
REMOVED_AFTER = "2027-06-30"


def renamed_keywords(**renames: str):
    """Decorator: accept each ``old=`` keyword as its ``new`` name with a ``DeprecationWarning``.

    ``@renamed_keywords(delta="rate_bound")`` makes ``f(delta=0.2)`` call ``f(rate_bound=0.2)``;
    giving both spellings is a ``TypeError``.
    """

    def decorate(func):
        @functools.wraps(func)
        def renamed(*args, **kwargs):
            for old, new in renames.items():
                if old not in kwargs:
                    continue
                if new in kwargs:
                    raise TypeError(f"{func.__name__}: got both {new}= and its old spelling {old}=; give {new}= only")
                warnings.warn(f"{func.__name__}({old}=) is now {func.__name__}({new}=); {old}= is removed after "
                              f"{REMOVED_AFTER}", DeprecationWarning, stacklevel=2)
                kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        return renamed

    return decorate
