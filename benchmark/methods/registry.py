"""Name -> method class registry: decorator, lazy ``"module:Class"`` strings and the
``blendvoca.methods`` entry point group of installed packages.

A ``"package.module:Class"`` string that is not a registered name is itself a method:
:func:`get_method` imports it the way :func:`register_lazy` targets are imported, so
``benchmark.run --method my_pkg.module:MyMethod`` runs a plug-in nobody registered."""

from __future__ import annotations

import difflib
import importlib
import importlib.metadata
import re

from blendvoca.errors import UserError

from .base import Method

__all__ = [
    "ENTRY_POINT_GROUP",
    "MethodClassError",
    "MethodImportError",
    "UnknownMethodError",
    "available_methods",
    "get_method",
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

# name -> class, or "module:Class" not imported yet
_REGISTRY: dict[str, type | str] = {}


def _check_name(name) -> str:
    if not isinstance(name, str):
        raise TypeError(f"method name: expected a str, got {type(name).__name__}")
    if not _NAME_PATTERN.match(name):
        raise ValueError(
            f"method name: expected lower-case letters, digits, '.', '_' or '-' "
            f"(starting with a letter or digit), got {name!r}"
        )
    return name


def _target_of(entry: type | str) -> str:
    if isinstance(entry, str):
        return entry
    return f"{entry.__module__}:{entry.__qualname__}"


def _add(name: str, entry: type | str) -> None:
    _check_name(name)
    if name in _REGISTRY:
        raise ValueError(
            f"method {name!r} is already registered (to {_target_of(_REGISTRY[name])}); "
            f"refusing to register it again (to {_target_of(entry)})"
        )
    _REGISTRY[name] = entry


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
        _add(name, cls)
        cls.name = name
        return cls

    return decorator


def register_lazy(name: str, target: str) -> None:
    """Register ``"package.module:Class"`` under ``name``; imported on first lookup."""
    if not isinstance(target, str) or target.count(":") != 1 or not all(target.split(":")):
        raise ValueError(f"register_lazy({name!r}): expected 'package.module:Class', got {target!r}")
    _add(name, target)


def unregister(name: str) -> None:
    """Remove ``name`` from the registry (for tests); unknown names raise KeyError."""
    del _REGISTRY[name]


def _check_class(cls, name: str, where: str) -> None:
    if not isinstance(cls, type):
        raise MethodClassError(f"{where}: method {name!r} must be a class, got {type(cls).__name__} {cls!r}")
    if not issubclass(cls, Method):
        missing = [attr for attr in ("generate", "train", "save", "load", "config") if not hasattr(cls, attr)]
        if missing:
            raise MethodClassError(
                f"{where}: method {name!r} ({_target_of(cls)}) must subclass "
                f"benchmark.methods.Method or provide {', '.join(missing)}"
            )


def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    # read afresh on every lookup: a package installed while the process runs
    # (as in the plug-in test) is found without restarting
    found: dict[str, importlib.metadata.EntryPoint] = {}
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        previous = found.get(ep.name)
        if previous is not None and previous.value != ep.value:
            raise ValueError(
                f"method {ep.name!r} is declared by two installed packages in entry point group "
                f"{ENTRY_POINT_GROUP!r}: {previous.value} and {ep.value}"
            )
        found[ep.name] = ep
    return found


def _merged() -> dict[str, type | str | importlib.metadata.EntryPoint]:
    merged: dict[str, type | str | importlib.metadata.EntryPoint] = dict(_REGISTRY)
    for name, ep in _entry_points().items():
        if name in merged:
            if _target_of(merged[name]) != ep.value:
                raise ValueError(
                    f"method {name!r} is registered to {_target_of(merged[name])} and also declared "
                    f"by an installed package (entry point {ENTRY_POINT_GROUP!r}) as {ep.value}"
                )
            continue
        merged[name] = ep
    return merged


def available_methods() -> list[str]:
    """Sorted names of all registered and installed methods."""
    return sorted(_merged())


def _import_target(target: str, name: str):
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except Exception as exc:  # ImportError, or the module failing while it is imported
        raise MethodImportError(f"method {name!r}: cannot import module {module_name!r} "
                                f"({type(exc).__name__}: {exc})") from exc
    obj = module
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError as exc:
            raise MethodImportError(f"method {name!r}: module {module_name!r} has no attribute {attr!r}") from exc
    return obj


def _is_target(name: str) -> bool:
    """True for a ``"package.module:Class"`` string (dotted names on both sides of one colon)."""
    module, sep, attr = name.partition(":")
    dotted = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
    return bool(sep) and bool(dotted.match(module)) and bool(dotted.match(attr))


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
    merged = _merged()
    if name not in merged and _is_target(name):
        cls = _import_target(name, name)
        _check_class(cls, name, where="get_method")
        return cls
    if name not in merged:
        close = difflib.get_close_matches(name, list(merged), n=3, cutoff=0.5)
        hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        raise UnknownMethodError(f"unknown method {name!r}{hint} Known methods: {', '.join(sorted(merged)) or 'none'}")
    entry = merged[name]
    if isinstance(entry, type):
        return entry
    if isinstance(entry, str):
        cls = _import_target(entry, name)
    else:
        try:
            cls = entry.load()
        except Exception as exc:  # broken installed plug-in: say which package and why
            raise MethodImportError(f"method {name!r}: cannot load entry point {entry.value!r} "
                                    f"({type(exc).__name__}: {exc})") from exc
    _check_class(cls, name, where="get_method")
    if isinstance(entry, str):
        _REGISTRY[name] = cls  # resolve once
    return cls


def method_schema(method):
    """The config declaration (:class:`~benchmark.methods.config.ConfigSchema`) of a method
    class or registered name (its ``config_schema``, a classmethod or an attribute), or
    None when it declares none."""
    if isinstance(method, str):
        method = get_method(method)
    declared = getattr(method, "config_schema", None)
    return declared() if callable(declared) else declared
