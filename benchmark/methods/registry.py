"""Name -> method class registry: decorator, lazy ``"module:Class"`` strings and the
``blendvoca.methods`` entry point group of installed packages.

A ``"package.module:Class"`` string that is not a registered name is itself a method:
:func:`get_method` imports it the way :func:`register_lazy` targets are imported, so
``benchmark.run --method my_pkg.module:MyMethod`` runs a plug-in nobody registered."""

from __future__ import annotations

import re

from blendvoca.errors import UserError
from blendvoca.registry import Registry, import_target, is_target

from .base import Method
from .config import plain_text

__all__ = [
    "ENTRY_POINT_GROUP",
    "METHODS",
    "MethodClassError",
    "MethodImportError",
    "UnknownMethodError",
    "available_methods",
    "get_method",
    "method_listing",
    "method_schema",
    "register",
    "register_lazy",
    "unregister",
]

#: Entry point group through which installed packages declare methods.
ENTRY_POINT_GROUP = "blendvoca.methods"

class UnknownMethodError(UserError, KeyError):
    """No usable method of that name: unknown (the message lists the close matches), or
    its target cannot be imported (:class:`MethodImportError`) or is not a method class
    (:class:`MethodClassError`). Command-line tools report it as one ``error:`` line."""

    def __str__(self) -> str:  # KeyError would print the message in quotes
        return str(self.args[0]) if self.args else ""


class MethodImportError(UnknownMethodError, ImportError):
    """A registered target or installed entry point whose module or attribute does not import."""


class MethodClassError(UnknownMethodError, TypeError):
    """A registered target or entry point that is not a :class:`Method` class."""


_NAME_PATTERN = re.compile(r"^[a-z0-9][a-z0-9._-]*$")


def _check_name(name) -> str:
    if not isinstance(name, str):
        raise TypeError(f"method name: expected a str, got {type(name).__name__}")
    if not _NAME_PATTERN.match(name):
        raise ValueError(
            f"method name: expected lower-case letters, digits, '.', '_' or '-' "
            f"(starting with a letter or digit), got {name!r}"
        )
    return name


def _check_class(cls, name: str, where: str = "get_method") -> None:
    if not isinstance(cls, type):
        raise MethodClassError(f"{where}: method {name!r} must be a class, got {type(cls).__name__} {cls!r}")
    if not issubclass(cls, Method):
        missing = [attr for attr in ("generate", "train", "save", "load", "config") if not hasattr(cls, attr)]
        if missing:
            raise MethodClassError(
                f"{where}: method {name!r} ({cls.__module__}:{cls.__qualname__}) must subclass "
                f"benchmark.methods.Method or provide {', '.join(missing)}"
            )


#: The method registry: registered classes, lazy targets and installed entry points.
METHODS = Registry("method", entry_point_group=ENTRY_POINT_GROUP, error=UnknownMethodError,
                   import_error=MethodImportError, check=_check_class)


def register(name: str):
    """Class decorator registering a :class:`Method` subclass under ``name``.

    The class's ``name`` attribute is set to ``name``.

    Examples
    --------
    >>> @register("my-method")            # doctest: +SKIP
    ... class MyMethod(Method): ...
    """
    _check_name(name)

    def decorator(cls):
        _check_class(cls, name, where="register")
        METHODS.add(name, cls)
        cls.name = name
        return cls

    return decorator


def register_lazy(name: str, target: str) -> None:
    """Register ``"package.module:Class"`` under ``name``; imported on first lookup."""
    _check_name(name)
    if not is_target(target):
        raise ValueError(f"register_lazy({name!r}): expected 'package.module:Class', got {target!r}")
    METHODS.add(name, target)


def unregister(name: str) -> None:
    """Remove ``name`` from the registry (for tests); unknown names raise KeyError."""
    METHODS.remove(name)


def available_methods() -> list[str]:
    """Sorted names of all registered and installed methods."""
    return sorted(METHODS.names())


def get_method(name: str) -> type[Method]:
    """The method class registered (or installed) under ``name``, or named by ``name``
    when it is a ``"package.module:Class"`` string (imported, not registered).

    Raises
    ------
    UnknownMethodError (a KeyError)
        Unknown name; the message lists the close matches and all known names.
    MethodImportError (an UnknownMethodError and an ImportError)
        The lazy target or entry point cannot be imported.
    MethodClassError (an UnknownMethodError and a TypeError)
        The target is not a method class.
    """
    if not isinstance(name, str):
        raise TypeError(f"get_method: expected a method name (str), got {type(name).__name__}")
    if name not in METHODS and is_target(name):
        cls = import_target(name, label=f"method {name!r}", error=MethodImportError)
        _check_class(cls, name)
        return cls
    return METHODS.get(name)


def method_listing() -> list[tuple[str, str, str, str]]:
    """``(name, kind, row, description)`` of every available method, sorted by name.

    ``kind`` is the method's ``output`` (``"coefficients"`` or ``"vertices"``), ``row``
    ``"reference"`` (shown apart on the leaderboard, never ranked) or ``"ranked"``, and
    ``description`` the first line of its class docstring without markup. A method
    that does not import is listed with ``kind`` ``"?"`` and its error as description.
    """
    rows = []
    for name in available_methods():
        try:
            cls = get_method(name)
        except UnknownMethodError as exc:
            rows.append((name, "?", "?", f"does not import: {exc}"))
            continue
        doc = (cls.__doc__ or "").strip().splitlines()
        rows.append((name, getattr(cls, "output", "coefficients"),
                     "reference" if getattr(cls, "reference", False) else "ranked",
                     plain_text(doc[0].strip()) if doc else ""))
    return rows


def method_schema(method):
    """The config declaration (:class:`~benchmark.methods.config.ConfigSchema`) of a method
    class or registered name (its ``config_schema``, a classmethod or an attribute), or
    None when it declares none."""
    if isinstance(method, str):
        method = get_method(method)
    declared = getattr(method, "config_schema", None)
    return declared() if callable(declared) else declared
