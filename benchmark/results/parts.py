"""The machinery of the result file's typed parts: a frozen dataclass per JSON object.

A part declares each JSON field as a dataclass field made by :func:`item`, with the
check that validates (and, for nested parts, builds) its value. :meth:`Part.from_json`
checks an object field by field and raises one :class:`Located` error naming the
field's path, what was expected and what arrived (``benchmark.results.check`` adds
the file and raises it as a :class:`~blendvoca.errors.DataError`);
:meth:`Part.to_json` gives the object back as it was read: fields the part does not
know, and known fields written as ``null``, are kept in :attr:`Part.extra`, so a file
read and written again is the same file.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["Invalid", "Located", "Part", "anything", "integer", "integers", "item", "list_of", "located", "mapping_of",
           "number", "numbers", "obj", "optional", "pair", "part", "seconds", "short", "string", "to_json", "truth"]


class Invalid(ValueError):
    """A field's value is not what the schema expects: ``(expected, value)``, or
    ``(message,)``; :func:`located` adds the field's path."""


def short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def item(check, *, key: str | None = None, required: bool = False, present: bool = False, always: bool = False):
    """A part's field: ``check(value, where)`` returns the typed value or raises
    :class:`Invalid`; ``key``: the JSON name when it is not the attribute's;
    ``required``: absent or null is refused; ``present``: absent is refused (null is
    not); ``always``: written as ``null`` when None."""
    return field(default=None, metadata={"check": check, "key": key, "required": required, "present": present,
                                         "always": always})


def _is_number(value) -> bool:
    try:  # OverflowError: an integer too large for a float
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    except OverflowError:
        return False


def number(value, where):
    """A finite number (not a boolean)."""
    if not _is_number(value):
        raise Invalid("a finite number", value)
    return value


def seconds(value, where):
    """A finite number of seconds >= 0."""
    if not _is_number(value) or value < 0:
        raise Invalid("seconds >= 0 or null", value)
    return value


def integer(value, where):
    if not isinstance(value, int) or isinstance(value, bool):
        raise Invalid("an integer", value)
    return value


def string(value, where):
    if not isinstance(value, str):
        raise Invalid("a string", value)
    return value


def truth(value, where):
    if not isinstance(value, bool):
        raise Invalid("true or false", value)
    return value


def anything(value, where):
    """Any JSON value, kept as written."""
    return value


def obj(value, where):
    """A JSON object, kept as written."""
    if not isinstance(value, dict):
        raise Invalid("an object", value)
    return value


def numbers(value, where):
    """A non-empty list of finite numbers (bootstrap replicates)."""
    if not isinstance(value, list) or not value or not all(_is_number(v) for v in value):
        raise Invalid("a non-empty list of finite numbers", value)
    return value


def pair(value, where):
    """``[low, high]`` of finite numbers, low <= high."""
    if not (isinstance(value, (list, tuple)) and len(value) == 2 and all(_is_number(v) for v in value)
            and value[0] <= value[1]):
        raise Invalid("[low, high] of finite numbers", value)
    return list(value)


def integers(value, where):
    if not isinstance(value, list) or not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        raise Invalid("a list of integers", value)
    return tuple(value)


def optional(check):
    """``check``, or None for null."""
    return lambda value, where: None if value is None else check(value, where)


def part(cls):
    """A nested part: the value is checked and built by ``cls.from_json``."""
    return lambda value, where: cls.from_json(value, where)


def list_of(check, expected: str = "a list"):
    """A list whose items pass ``check`` (``where[i]``), as a tuple."""
    def checked(value, where):
        if not isinstance(value, list):
            raise Invalid(expected, value)
        return tuple(located(check, v, f"{where}[{i}]") for i, v in enumerate(value))
    return checked


def mapping_of(check, expected: str = "an object"):
    """An object whose values pass ``check`` (``where.name``)."""
    def checked(value, where):
        if not isinstance(value, dict):
            raise Invalid(expected, value)
        return {str(k): located(check, v, f"{where}.{k}") for k, v in value.items()}
    return checked


class Located(ValueError):
    """An :class:`Invalid` value with the path of its field (``where: message``)."""


def located(check, value, where: str):
    """``check(value, where)``, its :class:`Invalid` raised as :class:`Located` at ``where``."""
    try:
        return check(value, where)
    except Invalid as exc:
        message = exc.args[0] if len(exc.args) == 1 else f"expected {exc.args[0]}, got {short(exc.args[1])}"
        raise Located(f"{where}: {message}") from None


@dataclass(frozen=True, kw_only=True)
class Part:
    """A typed JSON object of the result file (see the module docstring).

    Attributes
    ----------
    extra : dict
        Fields this version does not type (kept as written, so they survive a read and
        a write), and typed fields written as ``null``.
    """

    extra: dict = field(default_factory=dict, repr=False)
    #: Whether fields the part does not declare are kept (True) or refused (False).
    OPEN = True

    @classmethod
    def from_json(cls, value, where: str):
        """The part of a parsed JSON object ``value`` at ``where`` (a field path).

        Raises
        ------
        Located
            Naming the field and what was expected (:func:`benchmark.results.check`
            adds the file).
        """
        if not isinstance(value, dict):
            raise Located(f"{where}: expected an object, got {short(value)}")
        values, extra, known = {}, {}, set()
        for f in dataclasses.fields(cls):
            if f.name == "extra":
                continue
            key = f.metadata["key"] or f.name
            known.add(key)
            if f.metadata["present"] and key not in value:
                raise Located(f"{where}: lacks {key!r} (got fields {sorted(value)})")
            present = value.get(key)
            if present is None:
                if f.metadata["required"]:
                    raise Located(f"{where}: lacks {key!r} (got fields {sorted(value)})")
                if key in value and not f.metadata["always"]:
                    extra[key] = None
                continue
            values[f.name] = located(f.metadata["check"], present, f"{where}.{key}")
        unknown = {k: v for k, v in value.items() if k not in known}
        if unknown and not cls.OPEN:
            names = [f.metadata["key"] or f.name for f in dataclasses.fields(cls) if f.name != "extra"]
            raise Located(f"{where}.{sorted(unknown)[0]}: unknown field; expected some of {tuple(names)}")
        built = cls(**values, extra={**unknown, **extra})
        located(built.validate, None, where)
        return built

    def validate(self, value, where: str) -> None:
        """Checks across fields (a part that needs them overrides this and raises
        :class:`Invalid`); ``value`` is unused (the :func:`located` signature)."""

    def to_json(self) -> dict:
        """The JSON object of this part (what :meth:`from_json` read)."""
        out = dict(self.extra)
        for f in dataclasses.fields(self):
            if f.name == "extra":
                continue
            value = getattr(self, f.name)
            if value is not None or f.metadata["always"]:
                out[f.metadata["key"] or f.name] = to_json(value)
        return out


def to_json(value):
    """Parts, tuples and mappings of them as plain JSON values."""
    if isinstance(value, Part):
        return value.to_json()
    if isinstance(value, Mapping):
        return {k: to_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_json(v) for v in value]
    return value
