"""The build's old import paths, and the documented command ``python -m blendvoca.build``.

The build lives in :mod:`blendvoca.builder` and the folder format it writes
(layout, manifest, hashing) in :mod:`blendvoca.format`; new code imports those.
This module keeps existing imports working: it re-exports the build's public names
(and ``ManifestError``, ``listed_files`` and ``write_folder_manifest``, which the old
package exported) and answers each old submodule name with the module that now
holds its code, the very same object (patching one patches the other)::

    blendvoca.build.pipeline        -> blendvoca.builder.pipeline
    blendvoca.build.outdir          -> blendvoca.builder.outdir
    blendvoca.build.report          -> blendvoca.builder.report
    blendvoca.build.sentence        -> blendvoca.builder.sentence
    blendvoca.build.speaker         -> blendvoca.builder.speaker
    blendvoca.build.said_residuals  -> blendvoca.builder.said_residuals
    blendvoca.build.state           -> blendvoca.builder.state
    blendvoca.build.__main__        -> blendvoca.builder.__main__
    blendvoca.build.hashing         -> blendvoca.format.hashing
    blendvoca.build.manifest        -> blendvoca.format.manifest

``python -m blendvoca.build ARGS`` runs the build's command line
(:func:`blendvoca.builder.__main__.main`), and ``python -m blendvoca.build.manifest DIR``
the manifest tool (:func:`blendvoca.format.manifest.main`).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys

from blendvoca.builder import *  # noqa: F403 - the old package's public names
from blendvoca.builder import __all__ as _builder_all
from blendvoca.format.manifest import ManifestError, listed_files, write_folder_manifest

__all__ = [*_builder_all, "ManifestError", "listed_files", "write_folder_manifest"]

#: Old submodule name -> the module that holds its code now.
ALIASES = {
    "pipeline": "blendvoca.builder.pipeline",
    "outdir": "blendvoca.builder.outdir",
    "report": "blendvoca.builder.report",
    "sentence": "blendvoca.builder.sentence",
    "speaker": "blendvoca.builder.speaker",
    "said_residuals": "blendvoca.builder.said_residuals",
    "state": "blendvoca.builder.state",
    "__main__": "blendvoca.builder.__main__",
    "hashing": "blendvoca.format.hashing",
    "manifest": "blendvoca.format.manifest",
}

_PACKAGE = "blendvoca.build"


class _AliasLoader(importlib.abc.InspectLoader):
    """Loads ``blendvoca.build.<old>`` as the already imported module that holds its code.

    ``python -m blendvoca.build.<old>`` asks the loader for code to run as
    ``__main__`` under the old name: that code runs the module's ``main()``.
    """

    def __init__(self, target: str):
        self.target = target
        self._spec = None

    def create_module(self, spec):
        module = importlib.import_module(self.target)
        self._spec = module.__spec__
        return module

    def exec_module(self, module):
        # The import system has just given the module the alias's spec; it keeps its own.
        module.__spec__ = self._spec

    def get_source(self, fullname):
        return (f"import sys\nfrom {self.target} import main\n"
                "if __name__ == '__main__':\n    sys.exit(main())\n")

    def is_package(self, fullname):
        return False


class _AliasFinder(importlib.abc.MetaPathFinder):
    """Finds the names of :data:`ALIASES` under ``blendvoca.build``."""

    def find_spec(self, fullname, path=None, target=None):
        package, _, old = fullname.rpartition(".")
        if package != _PACKAGE or old not in ALIASES:
            return None
        origin = getattr(importlib.import_module(ALIASES[old]), "__file__", None)
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(ALIASES[old]), origin=origin)


if __name__ == "__main__":
    from blendvoca.builder.__main__ import main

    sys.exit(main())
else:
    # A package for the import system (its submodules are found by _AliasFinder only),
    # with the old package's submodules as attributes, as after `import blendvoca.build` before.
    __path__ = []
    for _old, _new in ALIASES.items():
        if not _old.startswith("__"):
            globals()[_old] = importlib.import_module(_new)
    if not any(isinstance(finder, _AliasFinder) for finder in sys.meta_path):
        sys.meta_path.append(_AliasFinder())
    del _old, _new
