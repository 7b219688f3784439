"""BlendVOCA's version, read from the package's own ``__init__.py``.

Not ``blendvoca.__version__``: run from the folder that holds a clone named ``blendvoca``
(``git clone ... blendvoca; pip install -e blendvoca; python -m blendvoca.build``), Python
finds that folder first on ``sys.path`` and makes ``blendvoca`` a namespace package of it,
whose ``__init__.py`` never runs (its submodules still load, through the editable
install's finder): every attribute the package defines is missing. The version is what
the build and the result files record, so it is read from the file, which is there in
both cases.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

__all__ = ["blendvoca_version"]


@functools.cache
def blendvoca_version() -> str:
    """``__version__`` of the ``blendvoca`` package this module belongs to ("unknown" when
    its ``__init__.py`` assigns none)."""
    init = Path(__file__).resolve().parents[1] / "__init__.py"
    for node in ast.parse(init.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__version__" for t in node.targets):
            return str(ast.literal_eval(node.value))
    return "unknown"
