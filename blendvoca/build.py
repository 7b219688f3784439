"""``python -m blendvoca.build``: the build command (:func:`blendvoca.builder.__main__.main`).

The build's code is :mod:`blendvoca.builder` and the folder format it writes
:mod:`blendvoca.format`; import from those (``blendvoca.builder.build_dataset``). The
builder's public names are still readable here until 2027-06-30, each with a
:class:`DeprecationWarning`.
"""

from __future__ import annotations

import sys
import warnings

try:
    import blendvoca.builder as _builder
    from blendvoca.builder.__main__ import main
except (ImportError, MemoryError) as _error:  # a library that cannot be mapped under a memory limit
    from blendvoca.errors import ran_out_of

    if __name__ != "__main__" or ran_out_of(_error) is None:
        raise
    sys.stderr.write(f"error: ran out of memory loading the build's libraries ({_error}); try more memory "
                     "(a higher `ulimit -v`, or close other programs)\n")
    sys.exit(2)

__all__ = ["main"]

#: When the names this module forwards to :mod:`blendvoca.builder` go.
REMOVED_AFTER = "2027-06-30"


def __getattr__(name: str):
    if name in _builder.__all__:
        warnings.warn(f"blendvoca.build.{name} is blendvoca.builder.{name}; the old path is removed after "
                      f"{REMOVED_AFTER}", DeprecationWarning, stacklevel=2)
        return getattr(_builder, name)
    raise AttributeError(f"module 'blendvoca.build' has no attribute {name!r}")


if __name__ == "__main__":
    sys.exit(main())
