"""One registry shape: names -> objects imported on first use.

The project's four registries (methods, dataset adapters, blendshape naming
conventions, export formats) are each a :class:`Registry`. An entry is an object or a
``"package.module:attr"`` string imported on the first lookup of its name, so a
plug-in with heavy imports costs nothing until it is asked for; an optional
``importlib.metadata`` entry-point group adds the names installed packages declare.
An unknown name raises the registry's error (a :class:`~blendvoca.errors.UserError`)
with the close matches and the known names::

    FORMATS = Registry("export format", {"glb": "blendvoca.export.glb:Glb"})
    FORMATS.get("glb")    # the class, imported now
    FORMATS.get("gbl")    # UserError: unknown export format 'gbl' (did you mean 'glb'?); known: glb
"""

from __future__ import annotations

import difflib
import importlib
import importlib.metadata
import re
from collections.abc import Callable, Mapping

from blendvoca.errors import UserError

__all__ = ["Registry", "import_target", "is_target"]

_DOTTED = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


def is_target(text) -> bool:
    """True for a ``"package.module:attr"`` string (dotted names on both sides of one colon)."""
    if not isinstance(text, str):
        return False
    module, sep, attr = text.partition(":")
    return bool(sep) and bool(_DOTTED.match(module)) and bool(_DOTTED.match(attr))


def import_target(target: str, *, label: str, error: type[Exception] = UserError):
    """The object a ``"package.module:attr"`` string names (``attr`` may be dotted), imported now.

    Raises
    ------
    error
        ``"<label>: cannot import module ..."`` (with the module's own error) or
        ``"<label>: module ... has no attribute ..."``.
    """
    module_name, _, attr = target.partition(":")
    try:
        obj = importlib.import_module(module_name)
    except Exception as exc:  # ImportError, or the module failing while it is imported
        raise error(f"{label}: cannot import module {module_name!r} ({type(exc).__name__}: {exc})") from exc
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError as exc:
            raise error(f"{label}: module {module_name!r} has no attribute {attr!r}") from exc
    return obj


def _target_of(entry) -> str:
    """How a message names an entry: its target string, entry point value or ``module:qualname``."""
    if isinstance(entry, str):
        return entry
    if isinstance(entry, importlib.metadata.EntryPoint):
        return entry.value
    return f"{getattr(entry, '__module__', '?')}:{getattr(entry, '__qualname__', repr(entry))}"


class Registry:
    """Names of one kind of plug-in -> the objects they name, imported on first lookup.

    Parameters
    ----------
    kind : str
        What a name names, for messages (``"method"``, ``"dataset"``, ``"export format"``).
    entries : mapping, optional
        ``name -> object`` or ``name -> "package.module:attr"``, in listing order.
    entry_point_group : str, optional
        An ``importlib.metadata`` entry-point group whose names are added (read afresh
        on every lookup, so a package installed while the process runs is found).
    error : UserError subclass
        Raised for an unknown name.
    import_error : exception class, optional
        Raised when a target or entry point does not import (default ``error``).
    check : callable, optional
        ``check(obj, name)`` on every object a lookup imports: raises when it is not
        of the kind (a method that is not a class).
    where : str, optional
        Prefix of the unknown-name message (``"--dataset"``).
    """

    def __init__(self, kind: str, entries: Mapping | None = None, *, entry_point_group: str | None = None,
                 error: type[UserError] = UserError, import_error: type[Exception] | None = None,
                 check: Callable | None = None, where: str | None = None):
        self.kind = kind
        self.entry_point_group = entry_point_group
        self.error = error
        self.import_error = import_error or error
        self.check = check
        self.where = where
        self._entries: dict = {}
        for name, entry in (entries or {}).items():
            self.add(name, entry)

    # -------------------------------------------------------------- registering
    def add(self, name: str, entry) -> None:
        """Register ``entry`` (an object or a ``"module:attr"`` string) under ``name``.

        Raises
        ------
        ValueError
            ``name`` is registered already.
        """
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is already registered (to {_target_of(self._entries[name])}); "
                             f"refusing to register it again (to {_target_of(entry)})")
        self._entries[name] = entry

    def remove(self, name: str) -> None:
        """Unregister ``name`` (for tests); an unknown name raises KeyError."""
        del self._entries[name]

    # -------------------------------------------------------------- reading
    def _entry_points(self) -> dict:
        found: dict[str, importlib.metadata.EntryPoint] = {}
        if self.entry_point_group is None:
            return found
        for ep in importlib.metadata.entry_points(group=self.entry_point_group):
            previous = found.get(ep.name)
            if previous is not None and previous.value != ep.value:
                raise ValueError(f"{self.kind} {ep.name!r} is declared by two installed packages in entry point "
                                 f"group {self.entry_point_group!r}: {previous.value} and {ep.value}")
            found[ep.name] = ep
        return found

    def entries(self) -> dict:
        """``name -> entry`` (object, target string or entry point) of the registered and installed names."""
        merged = dict(self._entries)
        for name, ep in self._entry_points().items():
            if name in merged:
                if _target_of(merged[name]) != ep.value:
                    raise ValueError(f"{self.kind} {name!r} is registered to {_target_of(merged[name])} and also "
                                     f"declared by an installed package (entry point {self.entry_point_group!r}) "
                                     f"as {ep.value}")
                continue
            merged[name] = ep
        return merged

    def names(self) -> tuple[str, ...]:
        """The known names, registered ones in registration order, then installed ones."""
        return tuple(self.entries())

    def __contains__(self, name) -> bool:
        return name in self.entries()

    def unknown(self, name, *, where: str | None = None) -> UserError:
        """The error for a name this registry does not know: close matches and the known
        names, after ``where`` (default the registry's ``where``)."""
        known = self.names()
        close = difflib.get_close_matches(str(name), known, n=3)
        hint = f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""
        where = where or self.where
        prefix = f"{where}: " if where else ""
        return self.error(f"{prefix}unknown {self.kind} {name!r}{hint}; known: {', '.join(sorted(known)) or 'none'}")

    def get(self, name: str):
        """The object registered under ``name``, imported now (once: a target string is
        replaced by what it names).

        Raises
        ------
        error
            An unknown name (:meth:`unknown`).
        import_error
            A target or entry point that does not import.
        """
        entries = self.entries()
        if name not in entries:
            raise self.unknown(name)
        entry = entries[name]
        label = f"{self.kind} {name!r}"
        if isinstance(entry, str):
            obj = import_target(entry, label=label, error=self.import_error)
        elif isinstance(entry, importlib.metadata.EntryPoint):
            try:
                obj = entry.load()
            except Exception as exc:  # broken installed plug-in: say which package and why
                raise self.import_error(f"{label}: cannot load entry point {entry.value!r} "
                                        f"({type(exc).__name__}: {exc})") from exc
        else:
            return entry
        if self.check is not None:
            self.check(obj, name)
        if isinstance(entry, str):
            self._entries[name] = obj  # resolve once
        return obj
